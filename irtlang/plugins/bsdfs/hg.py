"""HG G g... TAU tau... ALBEDO w... [ORDERS n]

A Henyey-Greenstein slab (clouds, aerosols) with a Pfeiffer-Chapman effective multiple-scattering phase
function of ORDERS terms.  Reflects and transmits.

| parameter | unit | meaning |
|---|---|---|
| G | 1, per line | asymmetry parameter, in (-1, 1) |
| TAU | 1, per line | optical depth (>= 0) |
| ALBEDO | 1, per line | single-scattering albedo, in [0, 1] |
| ORDERS | count | number of scattering orders in the effective phase function, 1 to 32 (default 4) |

Model.  The slab formulas of `RAYLEIGH` (Ryu et al. 2017, eqs. 7-8; mu_s = |wi.n| the light's cosine,
mu_v = |wo.n| the viewer's, cos Theta = -wi.wo on either side; BRDF = rho/pi; plus the unscattered delta
exp(-tau/mu_s) along -wi) with the phase function P replaced by the effective phase

    P_eff(Theta) = sum_{n=1..N} a_n HG(Theta; g^n),   a_n = w^(n-1) / sum_{m=1..N} w^(m-1),

HG(Theta; g) = (1 - g^2) / (1 + g^2 - 2 g cos Theta)^(3/2) (mean 1 over the sphere, mean cosine g).  What is
published and what is constructed here: Pfeiffer and Chapman (Opt. Express 16, 13637, 2008) show that the
direction after n successive Henyey-Greenstein scatterings (infinite medium) is distributed as a weighted
series of HG functions -- for a one-term HG of asymmetry g exactly HG(g^n), since the Legendre moments of HG
are g^l.  The weights a_n over the orders are this project's construction, not the paper's: each further order
is weighted by the single-scattering albedo (its survival), with no geometric escape factor, and the series is
truncated at N = ORDERS and renormalized.  P_eff keeps mean 1, so the slab's energy bookkeeping (single
scattering with exp attenuation) is unchanged; its mean cosine is sum a_n g^n.  ORDERS 1 is the plain
single-scattering HG slab.  The model remains a single-scattering slab with a broadened phase function: for
optically thick clouds it is a phenomenological stand-in for multiple scattering, not a solution of the
radiative transfer equation.

Sampling: the unscattered beam with probability e/(e + w (1 - e)), e = exp(-tau/mu_s); otherwise an order n
with probability a_n and an HG(g^n) direction about -wi (exact inverse CDF); weight = f |cos_o| / pdf with
pdf = (1 - p_delta) P_eff / (4 pi).  Reflection is reciprocal (f(wi, wo) = f(wo, wi)); so is transmission.
albedo() reads a table over cos_i: the azimuthal mean of HG is 2 E(m) / (pi (A - B) sqrt(A + B)),
m = 2B/(A + B), with E the complete elliptic integral of the second kind, then Gauss-Legendre quadrature
over mu_v graded towards the forward peak.
"""
import math

import numba
import numpy as np

from ...lang.spec import Clause, Form, PL, V, nonneg, positive, unit_interval
from ...kernels.sampling import hg_sample
from ._common import (slab_scatter, INV_4PI, INV_PI, MU_MIN, slab_albedo_lines, slab_delta_prob, slab_direct, slab_geometry,
                      slab_albedo_parts, table_interp2, table_mu_nodes)

MAX_ORDERS = 32


def _orders_check(x):
    return positive(x) or (None if x <= MAX_ORDERS else f"must be at most {MAX_ORDERS}")


KIND = "HG"
FORM = Form((), (Clause("G", (PL("g", check=lambda x: None if -1 < x < 1 else "must be in (-1, 1)"),), required=True),
                 Clause("TAU", (PL("tau", check=nonneg),), required=True),
                 Clause("ALBEDO", (PL("albedo", check=unit_interval),), required=True),
                 Clause("ORDERS", (V("orders", integer=True, check=_orders_check),))))
EXAMPLE = "MODEL cloud HG G 0.85 TAU 10 ALBEDO 0.9999 ORDERS 4"
TRANSMITS = True
SLAB = True            # the whole interaction: direct_transmission() is its specular (delta) part

NT = 97
T0 = 0.0
ROW_R = 4
ROW_T = ROW_R + NT
N_PARAMS = ROW_T + NT


def build(b, ctx) -> dict:
    return {"g": b["g"].values, "tau": b["tau"].values, "albedo": b["albedo"].values, "orders": b.get("orders", 4)}


def transmits(params) -> bool:
    return True


def order_weights(w: float, n: int) -> np.ndarray:
    a = np.array([w ** j for j in range(n)], float)
    a[0] = 1.0
    return a / a.sum()


def hg_ring_mean(g, c0, c1):
    """Azimuthal mean of HG(g) (mean-1 normalization) over cos Theta = c0 + c1 cos(phi), phi uniform."""
    A = 1.0 + g * g - 2.0 * g * c0
    B = np.abs(2.0 * g * c1)
    m = np.where(A + B > 0, 2.0 * B / (A + B), 0.0)
    from scipy import special   # here, not at import (start-up time)

    return (1.0 - g * g) * 2.0 * special.ellipe(np.clip(m, 0.0, 1.0)) / (np.pi * (A - B) * np.sqrt(A + B))


def _phase_avg_factory(g, a):
    def avg(ms, mv, reflect):
        ss = math.sqrt(max(0.0, 1.0 - ms * ms))
        sv = np.sqrt(np.maximum(0.0, 1.0 - mv * mv))
        c0 = -ms * mv if reflect else ms * mv
        c1 = ss * sv
        out = np.zeros_like(mv)
        for j, aj in enumerate(a):
            if aj > 0:
                out += aj * hg_ring_mean(g ** (j + 1), c0, c1)
        return out
    return avg


def pack(params, n_lines: int) -> np.ndarray:
    P = np.zeros((N_PARAMS, n_lines))
    P[0] = np.broadcast_to(np.asarray(params["g"], float), (n_lines,))
    P[1] = np.broadcast_to(np.asarray(params["tau"], float), (n_lines,))
    P[2] = np.broadcast_to(np.asarray(params["albedo"], float), (n_lines,))
    N = int(params.get("orders", 4))
    P[3] = N
    mu = table_mu_nodes(NT, T0 * T0)
    # lines sharing g and w share the phase function: one vectorized table computation over their taus
    gw, inv = np.unique(P[[0, 2]].T, axis=0, return_inverse=True)
    inv = np.ravel(inv)
    for q, (g, w) in enumerate(gw):
        ks = np.nonzero(inv == q)[0]
        avg = _phase_avg_factory(g, order_weights(w, N))
        R, T = slab_albedo_lines(avg, P[1, ks], w, mu, key=("HG", float(g), N, NT, T0))
        P[ROW_R:ROW_R + NT, ks] = R.T
        P[ROW_T:ROW_T + NT, ks] = T.T
    return P


@numba.njit(cache=True, fastmath=False)
def hg_phase(cos_t, g):
    """HG normalized to mean 1 over the sphere (4 pi times the density)."""
    den = 1.0 + g * g - 2.0 * g * cos_t
    if den <= 0.0:
        return 0.0 if g * g >= 1.0 else np.inf
    return (1.0 - g * g) / (den * math.sqrt(den))


@numba.njit(cache=True, fastmath=False)
def phase(P, k, cos_t):
    """P_eff: sum over n = 1..N of a_n HG(g^n), a_n proportional to w^(n-1)."""
    g = P[0, k]
    w = P[2, k]
    N = int(P[3, k])
    s = 0.0
    tot = 0.0
    a = 1.0
    gn = g
    for n in range(N):
        s += a * hg_phase(cos_t, gn)
        tot += a
        a *= w
        gn *= g
        if a == 0.0:
            break
    return s / tot


@numba.njit(cache=True, fastmath=False)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    ci = wix * nx + wiy * ny + wiz * nz
    co = wox * nx + woy * ny + woz * nz
    cos_t = -(wix * wox + wiy * woy + wiz * woz)
    G = slab_geometry(P[1, k], max(ci, MU_MIN), max(abs(co), MU_MIN), co > 0.0)
    if G == 0.0 or P[2, k] == 0.0:
        return 0.0
    return 0.25 * P[2, k] * phase(P, k, cos_t) * G * INV_PI


@numba.njit(cache=True, fastmath=False)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    ci = wix * nx + wiy * ny + wiz * nz
    pd, q, norm, om = slab_delta_prob(P[1, k], P[2, k], ci)
    if q <= 0.0:
        return 0.0
    cos_t = -(wix * wox + wiy * woy + wiz * woz)
    return q * phase(P, k, cos_t) * INV_4PI


@numba.njit(cache=True, fastmath=False)
def delta_prob(P, k, cos_i):
    """The probability with which sample() returns the unscattered beam (a delta along -wi) at cos_i."""
    return slab_delta_prob(P[1, k], P[2, k], cos_i)[0]


@numba.njit(cache=True, fastmath=False)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """(wox, woy, woz, weight, delta); see the module docstring."""
    g = P[0, k]
    tau = P[1, k]
    w = P[2, k]
    ci = wix * nx + wiy * ny + wiz * nz
    pd, q, norm, om = slab_delta_prob(tau, w, ci)
    if norm <= 0.0:
        return -wix, -wiy, -wiz, 0.0, False
    if u2 < pd or q <= 0.0:
        return -wix, -wiy, -wiz, norm, True
    # the order: u2 rescaled to (0, 1) within the scattered branch
    v = min(max((u2 - pd) / q, 0.0), 1.0)
    N = int(P[3, k])
    tot = 0.0
    a = 1.0
    for n in range(N):
        tot += a
        a *= w
        if a == 0.0:
            break
    x = v * tot
    a = 1.0
    gn = g
    acc = 0.0
    for n in range(N):
        acc += a
        if x < acc or n == N - 1:
            break
        a *= w
        if a == 0.0:
            break
        gn *= g
    mu = hg_sample(u0, gn)
    return slab_scatter(wix, wiy, wiz, nx, ny, nz, mu, u1, tau, ci, norm, om)


@numba.njit(cache=True, fastmath=False)
def albedo(P, k, cos_i):
    """(R, T): R the scattered reflectance; T the scattered transmittance plus exp(-tau/cos_i)."""
    R, T = table_interp2(P, k, ROW_R, ROW_T, NT, T0, cos_i)
    return max(R, 0.0), max(T, 0.0) + slab_direct(P[1, k], cos_i)


@numba.njit(cache=True, fastmath=False)
def albedo_parts(P, k, cos_i):
    """(albedo's R and T, direct_transmission, delta_prob) in one call, each bit for bit the same (hero
    wavelengths evaluate them per line at every crossing of a slab)."""
    return slab_albedo_parts(P, k, ROW_R, ROW_T, NT, T0, P[1, k], P[2, k], cos_i)


@numba.njit(cache=True, fastmath=False)
def direct_transmission(P, k, cos_i):
    """exp(-tau / cos_i): the unscattered beam, along -wi."""
    return slab_direct(P[1, k], cos_i)
