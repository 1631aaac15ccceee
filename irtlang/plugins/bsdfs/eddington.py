"""EDDINGTON G g... TAU tau... ALBEDO w...

An optically thick scattering layer (a cloud deck) with the multiple-scattering reflectance and transmittance of
the delta-Eddington two-stream approximation.  Reflects and transmits.

| parameter | unit | meaning |
|---|---|---|
| G | 1, per line | asymmetry parameter of the particles' phase function, in (-1, 1) |
| TAU | 1, per line | optical depth (>= 0) |
| ALBEDO | 1, per line | single-scattering albedo, in [0, 1] |

Model.  The single-scattering slabs (`RAYLEIGH`, `HG`) book light scattered once and attenuated again on its
way out as absorbed: right for thin layers, wrong for a cloud of optical depth 10 (it would absorb a third of
the sunlight).  This model gives the whole layer's energy partition from the radiative transfer equation in the
delta-Eddington approximation (Joseph, Wiscombe and Weinman 1976, J. Atmos. Sci. 33, 2452): the forward peak
f = g^2 is moved into the direct beam (tau' = (1 - w f) tau, w' = (1 - f) w / (1 - w f), g' = g / (1 + g)), and
the layer's reflectance R(mu_s) and diffuse transmittance T(mu_s) over a black background are the two-stream
solutions of Meador and Weaver (1980, J. Atmos. Sci. 37, 630; their eqs. 14-15 with the delta-Eddington
gamma_1..4 of their Table 1; for w' = 1 the conservative limit R = [gamma_1 tau' + (gamma_3 - gamma_1 mu_s)
(1 - exp(-tau'/mu_s))] / (1 + gamma_1 tau')).  The direct beam is exp(-tau'/mu_s) along -wi.  Absorption is
1 - R - T - exp(-tau'/mu_s).  The multiply scattered light leaves the layer Lambertian (BRDF R(mu_s)/pi on the
incident side, T(mu_s)/pi on the other): the angular shape of a thick cloud's radiance is not modelled
(its limb brightening and glory are lost), its energy is.

Sampling: the direct beam with probability e / (R + T + e), e = exp(-tau'/mu_s); otherwise reflection or
transmission in proportion to R and T, cosine-weighted about the normal on that side; every sample carries
R + T + e.  The tables of R and T over mu_s are computed at pack time.
Checked (tests/physics/test_bsdf_eddington.py): the conservative limit, energy R + T + e = 1 for w = 1, the
thin-layer limit (single scattering), and the reflectance of a thick cloud against irtlang's VOLUME medium
(exact multiple scattering by Monte Carlo).
"""
import math

import numba
import numpy as np

from ...kernels.sampling import cosine_hemisphere, onb
from ...lang.spec import Clause, Form, PL, nonneg, unit_interval
from ._common import INV_PI, MU_MIN, table_interp, table_mu_nodes

KIND = "EDDINGTON"
FORM = Form((), (Clause("G", (PL("g", check=lambda x: None if -1 < x < 1 else "must be in (-1, 1)"),), required=True),
                 Clause("TAU", (PL("tau", check=nonneg),), required=True),
                 Clause("ALBEDO", (PL("albedo", check=unit_interval),), required=True)))
EXAMPLE = "MODEL deck EDDINGTON G 0.85 TAU 16 ALBEDO 0.99999"
TRANSMITS = True
SLAB = True            # the whole interaction: direct_transmission() is its specular (delta) part

NT = 97
T0 = 0.0
ROW_TAUS = 3           # the delta-scaled optical depth tau'
ROW_R = 4
ROW_T = ROW_R + NT
N_PARAMS = ROW_T + NT


def build(b, ctx) -> dict:
    return {"g": b["g"].values, "tau": b["tau"].values, "albedo": b["albedo"].values}


def transmits(params) -> bool:
    return True


def delta_scaling(g, tau, w):
    """(g', tau', w') of the delta-Eddington approximation (forward fraction f = g^2)."""
    f = g * g
    return g / (1.0 + g), (1.0 - w * f) * tau, (1.0 - f) * w / (1.0 - w * f)


def two_stream(g, tau, w, mu):
    """(R, T_diffuse, direct) of a layer over a black background, delta-Eddington (docstring).  Scalars."""
    gs, ts, ws = delta_scaling(g, tau, w)
    mu = max(mu, 1e-4)
    e = math.exp(-ts / mu)
    if ts <= 0.0:
        return 0.0, 0.0, 1.0
    g1 = (7.0 - ws * (4.0 + 3.0 * gs)) / 4.0
    g2 = -(1.0 - ws * (4.0 - 3.0 * gs)) / 4.0
    g3 = (2.0 - 3.0 * gs * mu) / 4.0
    g4 = 1.0 - g3
    if ws >= 1.0 - 1e-10:
        R = (g1 * ts + (g3 - g1 * mu) * (1.0 - e)) / (1.0 + g1 * ts)
        T = 1.0 - R - e
    else:
        k = math.sqrt(max(g1 * g1 - g2 * g2, 0.0))
        if abs(1.0 - k * k * mu * mu) < 1e-6:       # a removable singularity: step off it
            mu *= 1.0 + 2e-6
            e = math.exp(-ts / mu)
        a1 = g1 * g4 + g2 * g3
        a2 = g1 * g3 + g2 * g4
        ekt = math.exp(-k * ts)
        e2 = ekt * ekt
        D = (1.0 - k * k * mu * mu) * ((k + g1) + (k - g1) * e2)
        R = ws / D * ((1.0 - k * mu) * (a2 + k * g3) - (1.0 + k * mu) * (a2 - k * g3) * e2
                      - 2.0 * k * (g3 - a2 * mu) * e * ekt)
        # Meador and Weaver's T is the total transmission (direct included): the diffuse part is T - e
        T = -ws / D * ((1.0 + k * mu) * (a1 + k * g4) * e - (1.0 - k * mu) * (a1 - k * g4) * e2 * e
                       - 2.0 * k * (g4 + a1 * mu) * ekt)
    R = max(R, 0.0)
    T = max(T, 0.0)
    s = R + T + e
    if s > 1.0:                      # the approximation may overshoot by a little at grazing incidence
        R /= s
        T /= s
        e /= s
    return R, T, e


def pack(params, n_lines: int) -> np.ndarray:
    P = np.zeros((N_PARAMS, n_lines))
    P[0] = np.broadcast_to(np.asarray(params["g"], float), (n_lines,))
    P[1] = np.broadcast_to(np.asarray(params["tau"], float), (n_lines,))
    P[2] = np.broadcast_to(np.asarray(params["albedo"], float), (n_lines,))
    mu = table_mu_nodes(NT, T0 * T0)
    cache = {}
    for k in range(n_lines):
        key = (P[0, k], P[1, k], P[2, k])
        if key not in cache:
            rt = np.array([two_stream(key[0], key[1], key[2], float(m))[:2] for m in mu])
            cache[key] = (rt[:, 0], rt[:, 1], delta_scaling(*key)[1])
        P[ROW_R:ROW_R + NT, k], P[ROW_T:ROW_T + NT, k], P[ROW_TAUS, k] = cache[key]
    return P


@numba.njit(cache=True, fastmath=False)
def _direct(P, k, cos_i):
    return math.exp(-P[ROW_TAUS, k] / max(abs(cos_i), 1e-4)) if P[ROW_TAUS, k] > 0.0 else 1.0


@numba.njit(cache=True, fastmath=False)
def _rt(P, k, cos_i):
    R = max(table_interp(P, k, ROW_R, NT, T0, cos_i), 0.0)
    T = max(table_interp(P, k, ROW_T, NT, T0, cos_i), 0.0)
    return R, T


@numba.njit(cache=True, fastmath=False)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    ci = wix * nx + wiy * ny + wiz * nz
    co = wox * nx + woy * ny + woz * nz
    R, T = _rt(P, k, max(ci, MU_MIN))
    return (R if co > 0.0 else T) * INV_PI


@numba.njit(cache=True, fastmath=False)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    ci = wix * nx + wiy * ny + wiz * nz
    co = wox * nx + woy * ny + woz * nz
    R, T = _rt(P, k, max(ci, MU_MIN))
    tot = R + T + _direct(P, k, ci)
    if tot <= 0.0:
        return 0.0
    return (R if co > 0.0 else T) / tot * abs(co) * INV_PI


@numba.njit(cache=True, fastmath=False)
def delta_prob(P, k, cos_i):
    """The probability with which sample() returns the direct beam (a delta along -wi) at cos_i: e / (R + T + e)."""
    R, T = _rt(P, k, max(cos_i, MU_MIN))
    e = _direct(P, k, cos_i)
    tot = R + T + e
    return e / tot if tot > 0.0 else 0.0


@numba.njit(cache=True, fastmath=False)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """(wox, woy, woz, weight, delta); see the module docstring."""
    ci = wix * nx + wiy * ny + wiz * nz
    R, T = _rt(P, k, max(ci, MU_MIN))
    e = _direct(P, k, ci)
    tot = R + T + e
    if tot <= 0.0:
        return -wix, -wiy, -wiz, 0.0, False
    if u2 * tot < e:
        return -wix, -wiy, -wiz, tot, True
    x, y, z = cosine_hemisphere(u0, u1)
    if u2 * tot >= e + R:
        z = -z                       # transmitted: the hemisphere beyond the layer
    t1x, t1y, t1z, t2x, t2y, t2z = onb(nx, ny, nz)
    ox = x * t1x + y * t2x + z * nx
    oy = x * t1y + y * t2y + z * ny
    oz = x * t1z + y * t2z + z * nz
    if z == 0.0:
        return ox, oy, oz, 0.0, False
    return ox, oy, oz, tot, False


@numba.njit(cache=True, fastmath=False)
def albedo(P, k, cos_i):
    """(R, T): R the reflectance; T the diffuse transmittance plus the direct beam exp(-tau'/cos_i)."""
    R, T = _rt(P, k, cos_i)
    return R, T + _direct(P, k, cos_i)


@numba.njit(cache=True, fastmath=False)
def albedo_parts(P, k, cos_i):
    """(albedo's R and T, direct_transmission, delta_prob) in one call, each bit for bit the same: the layer's
    two-stream solution once (hero wavelengths evaluate them per line at every crossing)."""
    R, T = _rt(P, k, cos_i)
    e = _direct(P, k, cos_i)
    if cos_i >= MU_MIN:
        tot = R + T + e
    else:
        Rd, Td = _rt(P, k, MU_MIN)
        tot = Rd + Td + e
    return R, T + e, e, (e / tot if tot > 0.0 else 0.0)


@numba.njit(cache=True, fastmath=False)
def direct_transmission(P, k, cos_i):
    """exp(-tau'/cos_i): the direct beam (with the delta-scaled forward peak), along -wi."""
    return _direct(P, k, cos_i)
