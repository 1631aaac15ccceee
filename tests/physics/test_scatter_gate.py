"""OPAQUE WHERE: an object present only where a map's value lies in [lo, hi) (opaque there, clear air elsewhere),
against closed forms of the geometry.

The scene: a black sphere of radius R1 inside a gated shell of radius R2 (both centred at the origin), lit by a
collimated beam travelling along -x, sampled uniformly over a square of half-width h that holds the shell's disk
(GRID RECT RANDOM on the plane x = x0).  The shell's gate map is a 2 x 4 LATLON grid: 1 on the column of
longitudes -90 .. 0 deg, so on the lit side (x > 0) the shell is present where y < 0, and clear where y > 0 (and on
the whole night side, longitudes 90 .. 180 and -180 .. -90).  Closed forms, per emitted watt:

* a ray with y < 0 inside the shell's disk meets the present half: share p2 = pi R2^2 / (8 h^2); with a Lambertian
  model of albedo A there, A p2 is scattered and (1 - A) p2 absorbed on the shell, and nothing of it reaches the
  sphere;
* a ray with y > 0 passes the clear half: inside the sphere's disk (share p1 = pi R1^2 / (8 h^2)) it is absorbed
  by the sphere, outside it leaves through the clear night side.

Each ray carries its whole weight to one outcome (HALT 0), so each share is binomial: 5 sigma allowed.  The
alternatives the test tells apart: a shell that scattered everywhere (2 A p2 scattered), one whose present part
passed (1 - A) on, as a SCATTER model on a TRANSMIT interface does (1.5 p1 on the sphere; docs/tracer.md), or a
gate read on the wrong columns (0 scattered on the lit side).  (The shell also sends next-event rays toward the
far target below; they leave outward and change none of these shares.)

Next-event rays (TOWARD): the sphere (Lambertian, albedo A) sends one ray per hit toward a far disk on the +x axis
(zero phase) through the shell.  With the shell present on y < 0 of the lit side and black there (no model), the
disk receives the light of the sphere's y > 0 half only: half the zero-phase flux of a Lambert sphere,
(1/2) (2/3) A E (R1 / D)^2 times the disk's area (ORACLES.md, Lambert sphere; E the beam's irradiance), within 5
standard errors of the disk's incidence.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import ABS, EMITTED, INC, SCA, binomial_sigma, ledger_gap, row, trace_text  # noqa: E402

N = 400_000
R1, R2 = 4000.0, 6000.0
H = 1.001 * R2
X0 = 20000.0
A = 0.6


D_T, R_T = 1.0e6, 100.0         # the far target disk on the +x axis (km)
TARGET = ("SURFACE", f"  PLANE Z {D_T!r} DISK {R_T!r}", "OBJECT target", "  INTERFACE ABSORB", "  ROTATE Y 90")


def _script(gate: Path, shell_lines, sphere_lines, extra=TARGET, n=N) -> str:
    """Both tests send next-event rays TOWARD the target, so they share one compiled kernel."""
    lines = ["UNITS KM", "WAVELENGTHS 550 NM", "SEED 5", f"MODEL paint LAMBERTIAN {A!r}",
             f"MAP gate LATLON '{gate}'",
             "SURFACE", f"  SPHERE 0 0 0 {R1!r}", "OBJECT core", *("  " + x for x in sphere_lines),
             "SURFACE", f"  SPHERE 0 0 0 {R2!r}", "OBJECT shell", "  INTERFACE TRANSMIT AIR AIR",
             "  OPAQUE WHERE gate FROM 0.5 TO 1.5", *("  " + x for x in shell_lines), *extra,
             f"GRID RECT X {X0!r} {-H!r} {H!r} {-H!r} {H!r} {n} 1 RANDOM",
             "SOURCE DIRECTION -1 0 0", "FLUX TOTAL 1 W", "LEVEL 10", "HALT 0", "TRACE"]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def gate(tmp_path_factory):
    g = np.zeros((2, 4))
    g[:, 1] = 1.0                  # longitudes -90 .. 0: y < 0 on the lit side x > 0
    p = tmp_path_factory.mktemp("gate") / "gate.npy"
    np.save(p, g)
    return p


def _share_check(got, p, n=N):
    assert abs(got - p) <= 5 * binomial_sigma(p, n), (got, p, binomial_sigma(p, n))


def test_present_half_scatters_and_blocks_the_clear_half_passes(tmp_path, gate):
    res = trace_text(tmp_path, _script(gate, ["SCATTER MODEL paint TOWARD target"], ["INTERFACE ABSORB"]),
                     records=False)
    emitted = row(res, "EMITTED")[INC]
    shell, core = row(res, "shell"), row(res, "core")
    p1 = math.pi * R1 ** 2 / (8 * H ** 2)
    p2 = math.pi * R2 ** 2 / (8 * H ** 2)
    # scattered and absorbed on the shell: A and 1 - A of the rays on its present half (each a 0/1 draw of
    # weight A, resp. 1 - A, per ray: sigma scales by A)
    assert abs(shell[SCA] / emitted - A * p2) <= 5 * A * binomial_sigma(p2, N)
    assert abs(shell[ABS] / emitted - (1 - A) * p2) <= 5 * (1 - A) * binomial_sigma(p2, N)
    _share_check(core[ABS] / emitted, p1)          # only the clear half's rays reach the sphere
    assert ledger_gap(res) < 1e-12


def test_next_event_rays_pass_the_clear_part_and_stop_on_the_present_part(tmp_path, gate):
    res = trace_text(tmp_path, _script(gate, [], ["INTERFACE ABSORB", "SCATTER MODEL paint TOWARD target"]),
                     records=False)
    names = [x.upper() for x in res.rows]
    got, se = res.flux_on(names.index("TARGET"))
    E = 1.0 / (4 * H ** 2)                          # W per km2 of beam
    want = 0.5 * (2.0 / 3.0) * A * E * (R1 / D_T) ** 2 * math.pi * R_T ** 2
    assert se > 0 and abs(got - want) <= 5 * se, (got, want, se)
    # the shell's present part stops the rays it meets, the sphere sees only the clear half's rays
    p1 = math.pi * R1 ** 2 / (8 * H ** 2)
    emitted = row(res, "EMITTED")[INC]
    _share_check(row(res, "core")[INC] / emitted, p1)
