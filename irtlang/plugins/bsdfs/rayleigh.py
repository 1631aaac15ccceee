"""RAYLEIGH TAU tau... [ALBEDO w...] [DEPOL rho]

A single-scattering Rayleigh slab (Ryu et al. 2017, eqs. 7-8): reflectance factors rho_R and rho_T with the
Rayleigh phase function including depolarization; BRDF = rho / pi.  Reflects and transmits.

| parameter | unit | meaning |
|---|---|---|
| TAU | 1, per line | optical depth (>= 0) |
| ALBEDO | 1, per line | single-scattering albedo (default 1) |
| DEPOL | 1 | depolarization factor rho_n (default 0.0279) |

Model.  With mu_s = |wi.n| (the light's side), mu_v = |wo.n| (the viewer's) and Theta the scattering angle
between the incident propagation direction -wi and wo (cos Theta = -wi.wo, on either side of the slab):

- rho_R = w/4 P(Theta) / (mu_v + mu_s) [1 - exp(-tau (1/mu_v + 1/mu_s))]  (reflection, wo.n > 0);
- rho_T = w/4 P(Theta) / (mu_v - mu_s) [exp(-tau/mu_v) - exp(-tau/mu_s)]  (transmission, wo.n < 0),
  whose limit at mu_v = mu_s is w/4 P (tau/mu^2) exp(-tau/mu);
- P(Theta) = 3 / (4 (1 + 2 gamma)) [(1 + 3 gamma) + (1 - gamma) cos^2 Theta], gamma = rho_n / (2 - rho_n)
  (Hansen and Travis 1974), normalized to mean 1 over the sphere: P(0) = 1.47936, P(90 deg) = 0.76032 for
  rho_n = 0.0279; DEPOL 0 gives the pure 3/4 (1 + cos^2 Theta) of the reference values in ORACLES.md;
- a delta component: the unscattered beam exp(-tau/mu_s) continues along -wi.

Which cosine is whose.  rho_T is the divided difference of exp(-tau/mu) and so symmetric in (mu_s, mu_v), and
cos Theta = -wi.wo is symmetric too: the BRDF and the BTDF are reciprocal, and the slab works the same lit
from either side (the normal handed to the kernels is the one on the light's side).  Only the delta share
exp(-tau/mu_s) and the albedo belong to the light's mu_s.  rho_T is evaluated as
exp(-tau/mu_hi) tau/(mu_hi mu_lo) (1 - exp(-x))/x, x = tau/mu_lo - tau/mu_hi, with expm1: no cancellation
near mu_v = mu_s and no switch between formulas there.

Sampling: the unscattered beam with probability e/(e + w (1 - e)), e = exp(-tau/mu_s) (its weight is then
e + w (1 - e)); otherwise a Rayleigh direction about -wi (cos Theta from the exact inverse of the cubic CDF),
weight = f |cos_o| / pdf = w mu_v G (e + w (1 - e)) / (w (1 - e)) -- bounded, and nearly constant for thin
slabs.  albedo() reads a table over cos_i (azimuthally averaged phase, graded Gauss-Legendre quadrature).

Polarization (``mueller``): the one scattering of the slab acts by Rayleigh's Mueller matrix with the same
depolarization factor (kernels/polar.rayleigh_mueller, Hansen & Travis 1974) at the angle Theta, in the frame of
the scattering plane through -wi and wo; its P11 is P(Theta) above, so an unpolarized ray keeps the scalar
weight.  The unscattered beam keeps its state (the kernel's delta branch).
"""
import math

import numba
import numpy as np

from ...kernels.polar import perpendicular, rayleigh_mueller, rotate, scatter_stokes
from ...lang.spec import Clause, Form, PL, V, nonneg, unit_interval
from ._common import (slab_scatter, INV_4PI, INV_PI, MU_MIN, slab_albedo_lines, slab_delta_prob, slab_direct, slab_geometry,
                      slab_albedo_parts, table_interp2, table_mu_nodes)

KIND = "RAYLEIGH"
FORM = Form((), (Clause("TAU", (PL("tau", check=nonneg),), required=True),
                 Clause("ALBEDO", (PL("albedo", check=unit_interval),)),
                 Clause("DEPOL", (V("depol", check=lambda x: None if 0 <= x < 1 else "must be in [0, 1)"),))))
EXAMPLE = "MODEL air RAYLEIGH TAU 0.097 ALBEDO 1 DEPOL 0.0279"
TRANSMITS = True
SLAB = True            # the whole interaction: direct_transmission() is its specular (delta) part

NT = 97                # albedo table nodes (uniform in sqrt(cos_i))
T0 = 0.0
ROW_R = 3
ROW_T = ROW_R + NT
N_PARAMS = ROW_T + NT


def build(b, ctx) -> dict:
    tau = b["tau"].values
    return {"tau": tau, "albedo": b["albedo"].values if "albedo" in b else (1.0,) * len(tau),
            "depol": b.get("depol", 0.0279)}


def transmits(params) -> bool:
    return True


def gamma_of(depol: float) -> float:
    return depol / (2.0 - depol)


def phase_np(cos_t, gamma):
    return 3.0 / (4.0 * (1.0 + 2.0 * gamma)) * ((1.0 + 3.0 * gamma) + (1.0 - gamma) * cos_t * cos_t)


def _phase_avg_factory(gamma):
    def avg(ms, mv, reflect):
        ss2 = max(0.0, 1.0 - ms * ms)
        sv2 = np.maximum(0.0, 1.0 - mv * mv)
        c2 = ms * ms * mv * mv + 0.5 * ss2 * sv2      # azimuthal mean of cos^2 Theta (either side)
        return 3.0 / (4.0 * (1.0 + 2.0 * gamma)) * ((1.0 + 3.0 * gamma) + (1.0 - gamma) * c2)
    return avg


def pack(params, n_lines: int) -> np.ndarray:
    P = np.zeros((N_PARAMS, n_lines))
    P[0] = np.broadcast_to(np.asarray(params["tau"], float), (n_lines,))
    P[1] = np.broadcast_to(np.asarray(params["albedo"], float), (n_lines,))
    gamma = gamma_of(float(params.get("depol", 0.0279)))
    P[2] = gamma
    mu = table_mu_nodes(NT, T0 * T0)
    avg = _phase_avg_factory(gamma)
    # every line shares the phase function and the tables are linear in w: one computation over the taus
    R, T = slab_albedo_lines(avg, P[0], 1.0, mu, key=("RAYLEIGH", float(gamma), NT, T0))
    P[ROW_R:ROW_R + NT] = (R * P[1][:, None]).T
    P[ROW_T:ROW_T + NT] = (T * P[1][:, None]).T
    return P


@numba.njit(cache=True, fastmath=False)
def phase(cos_t, gamma):
    """Rayleigh phase with depolarization, normalized to mean 1 over the sphere."""
    return 3.0 / (4.0 * (1.0 + 2.0 * gamma)) * ((1.0 + 3.0 * gamma) + (1.0 - gamma) * cos_t * cos_t)


@numba.njit(cache=True, fastmath=False)
def phase_sample(u, gamma):
    """cos Theta with density P(cos)/2 on [-1, 1]: the real root of the (monotone) cubic CDF."""
    a = (1.0 - gamma) / 3.0
    b = 1.0 + 3.0 * gamma
    # CDF: 3/(8 (1 + 2 gamma)) [b (x + 1) + a (x^3 + 1)] = u  ->  a x^3 + b x + c = 0
    c = a + b - 8.0 * (1.0 + 2.0 * gamma) * u / 3.0
    p = b / a
    q = c / a
    s = math.sqrt(q * q / 4.0 + p * p * p / 27.0)
    A = -math.copysign(1.0, q) * math.pow(abs(q) / 2.0 + s, 1.0 / 3.0)
    x = 0.0 if A == 0.0 else A - p / (3.0 * A)
    # one Newton step on the cubic polishes the root
    f = a * x * x * x + b * x + c
    x -= f / (3.0 * a * x * x + b)
    return min(1.0, max(-1.0, x))


@numba.njit(cache=True, fastmath=False)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    tau = P[0, k]
    w = P[1, k]
    ci = wix * nx + wiy * ny + wiz * nz
    co = wox * nx + woy * ny + woz * nz
    cos_t = -(wix * wox + wiy * woy + wiz * woz)
    G = slab_geometry(tau, max(ci, MU_MIN), max(abs(co), MU_MIN), co > 0.0)
    return 0.25 * w * phase(cos_t, P[2, k]) * G * INV_PI


@numba.njit(cache=True, fastmath=False)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    ci = wix * nx + wiy * ny + wiz * nz
    pd, q, norm, om = slab_delta_prob(P[0, k], P[1, k], ci)
    cos_t = -(wix * wox + wiy * woy + wiz * woz)
    return q * phase(cos_t, P[2, k]) * INV_4PI


@numba.njit(cache=True, fastmath=False)
def delta_prob(P, k, cos_i):
    """The probability with which sample() returns the unscattered beam (a delta along -wi) at cos_i."""
    return slab_delta_prob(P[0, k], P[1, k], cos_i)[0]


@numba.njit(cache=True, fastmath=False)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """(wox, woy, woz, weight, delta); see the module docstring for the choice of the delta."""
    tau = P[0, k]
    w = P[1, k]
    ci = wix * nx + wiy * ny + wiz * nz
    pd, q, norm, om = slab_delta_prob(tau, w, ci)
    if norm <= 0.0:
        return -wix, -wiy, -wiz, 0.0, False
    if u2 < pd or q <= 0.0:
        return -wix, -wiy, -wiz, norm, True
    mu = phase_sample(u0, P[2, k])
    return slab_scatter(wix, wiy, wiz, nx, ny, nz, mu, u1, tau, ci, norm, om)


@numba.njit(cache=True, fastmath=False)
def albedo(P, k, cos_i):
    """(R, T): R the scattered reflectance; T the scattered transmittance plus exp(-tau/cos_i)."""
    R, T = table_interp2(P, k, ROW_R, ROW_T, NT, T0, cos_i)
    return max(R, 0.0), max(T, 0.0) + slab_direct(P[0, k], cos_i)


@numba.njit(cache=True, fastmath=False)
def albedo_parts(P, k, cos_i):
    """(albedo's R and T, direct_transmission, delta_prob) in one call, each bit for bit the same (hero
    wavelengths evaluate them per line at every crossing of a slab)."""
    return slab_albedo_parts(P, k, ROW_R, ROW_T, NT, T0, P[0, k], P[1, k], cos_i)


@numba.njit(cache=True, fastmath=False)
def direct_transmission(P, k, cos_i):
    """exp(-tau / cos_i): the unscattered beam, along -wi."""
    return slab_direct(P[0, k], cos_i)


@numba.njit(cache=True, fastmath=False)
def mueller(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz, q, u, v, ex, ey, ez):
    """Polarized single scattering (the contract: plugins/bsdfs/_common.depolarize): Rayleigh's Mueller matrix
    at cos Theta = -wi.wo in the scattering plane's frame e1 = (-wi) x wo / |.|; rho = 2 gamma / (1 + gamma)."""
    g = P[2, k]
    rho = 2.0 * g / (1.0 + g)
    mu = -(wix * wox + wiy * woy + wiz * woz)
    sx, sy, sz = perpendicular(-wix, -wiy, -wiz, wox, woy, woz, ex, ey, ez)
    qs, us = rotate(-wix, -wiy, -wiz, ex, ey, ez, q, u, sx, sy, sz)
    p11, p12, p22, p33, p44 = rayleigh_mueller(mu, rho)
    i1, nq, nu, nv = scatter_stokes(qs, us, v, p11, p12, p22, p33, p44)
    return i1 / p11, nq, nu, nv, sx, sy, sz
