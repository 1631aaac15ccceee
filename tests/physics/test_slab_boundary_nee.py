"""A slab scatter model on an index step (the Earth's air shells): its rays toward a target against brute force.

An atmosphere shell is a boundary between two media (`INTERFACE TRANSMIT air_k air_k+1`) that carries a slab
model (`RAYLEIGH TAU ...`): Fresnel reflection at the boundary first, the slab takes the rest (docs/tracer.md).
The slab's share of the light is then (its albedo) x (1 - R_Fresnel): the rays it sends toward a target
(next-event estimation) and the weights of its sampled scatterings must both carry that factor; under total
internal reflection the share is 0.  Until 2026-12-03 neither did: the sampled scatterings carried the slab's
whole albedo on top of the reflected R (light created at every shell crossing, in proportion to R), and a
grazing camera path trapped between two shells by total internal reflection sent a full-weight ray toward the
Sun at each of its 400 reflections (the firefly at 823.8 nm in the flagship's disk spectra).  The old kernel
fails the second and third tests below (flux on the balls under total internal reflection; -0.19 W of
absorption, 360 standard errors below 0) and passes the first, where both of its estimators carried the same
wrong factor.

The oracle is the mirror-image design of test_scatter_lambert.py: the boundary (z = 0, glass n = 1.8 below,
air above) carries the slab TOWARD `near`, an absorbing ball at (+1.5, 0, 1); `twin`, its mirror image across
x = 0, gets the same flux in expectation by brute force (the scattered paths that happen to hit it).  The beam
comes from the glass side, tilted in y only (the scene stays symmetric under x -> -x); its unscattered part
goes on in the y-z plane and misses both balls.
"""
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _trace_util import ABS, ledger_gap, row, trace_text  # noqa: E402

N_RAYS = 400_000


def boundary_script(n: int, incidence_deg: float, seed: int = 11) -> str:
    t = math.radians(incidence_deg)
    return f"""UNITS M
WAVELENGTHS 550 NM
SEED {seed}
MEDIUM glass INDEX 1.8
MODEL haze RAYLEIGH TAU 0.5
SURFACE
  PLANE Z 0 DISK 1
OBJECT boundary
  INTERFACE TRANSMIT glass AIR
  SCATTER MODEL haze TOWARD near
SURFACE
  SPHERE 1.5 0 1 0.4
OBJECT near
  INTERFACE ABSORB
SURFACE
  SPHERE -1.5 0 1 0.4
OBJECT twin
  INTERFACE ABSORB
GRID DISK Z -0.2 0.6 RAYS {n} RANDOM
SOURCE DIRECTION 0 {math.sin(t):.12f} {math.cos(t):.12f}
FLUX TOTAL 1 W
LEVEL 20
HALT 0
TRACE
"""


def test_slab_on_an_index_step_agrees_with_brute_force(tmp_path):
    """30 deg in glass of n = 1.8 (R_Fresnel about 0.2 at the boundary): the next-event flux on near and the
    brute-force flux on twin agree within 5 combined standard errors (one contribution per source ray to each
    ball: the beam crosses the boundary once and the balls absorb).  The factor 1 - R in only one of the two
    estimators puts them about 1 / (1 - R) = 1.24 apart, 8 standard errors (measured with the factor in the
    rays toward near alone)."""
    res = trace_text(tmp_path, boundary_script(N_RAYS, 30.0), records=False)
    f_nee, se_nee = res.flux_on(1)
    f_bf, se_bf = res.flux_on(2)
    sig = math.hypot(se_nee, se_bf)
    assert f_nee > 0 and f_bf > 0
    assert 0.2 * f_bf > 5 * sig                    # the test can see the bias it guards against
    assert abs(f_nee - f_bf) <= 5 * sig, (f_nee, f_bf, sig, (f_nee - f_bf) / sig)
    assert ledger_gap(res) < 1e-12


def test_no_rays_toward_the_target_under_total_internal_reflection(tmp_path):
    """40 deg in glass of n = 1.8 is beyond the critical angle (33.7 deg): the boundary reflects everything, the
    slab gets nothing, and neither estimator may put light on the balls.  Exactly zero, not a tolerance: the
    reflected beam goes down and away, and nothing is sent toward near."""
    res = trace_text(tmp_path, boundary_script(20_000, 40.0), records=False)
    assert res.flux_on(1)[0] == 0.0
    assert res.flux_on(2)[0] == 0.0
    assert row(res, "IMPORTANCE")[ABS] == 0.0
    assert ledger_gap(res) < 1e-12


def test_the_slab_scatters_only_what_the_boundary_lets_in(tmp_path):
    """Energy: near the critical angle (33 deg; R_Fresnel about 0.5) the boundary reflects R and the slab
    scatters its albedo times the 1 - R that enters, so the boundary's absorbed flux (ledger: the weight in
    minus the weight out, per event) is >= 0 in expectation.  Sampled scatterings that carried the slab's whole
    albedo on top of R created light: about -0.4 W of absorption per watt here.  Eight runs with different
    seeds give the mean and its standard error; the mean must not lie below 0 by more than 5 of them."""
    vals = []
    for seed in range(8):
        res = trace_text(tmp_path, boundary_script(40_000, 33.0, seed=100 + seed), records=False)
        vals.append(row(res, "boundary")[ABS])
        assert ledger_gap(res) < 1e-12
    mean = sum(vals) / len(vals)
    se = math.sqrt(sum((v - mean) ** 2 for v in vals) / (len(vals) - 1) / len(vals))
    assert mean >= -5 * se, (mean, se, vals)
