"""ABG A a... B b... G g...

The Harvey ABG scatter model (Harvey 1976; Pfisterer 2011): a surface-scatter BRDF from polished or lightly
rough optics, written in the direction cosines projected on the surface,
f = A / (B + |beta - beta0|^g), reflection only.

| parameter | unit | meaning |
|---|---|---|
| A | 1/sr, per line | scale (A / B is the BRDF at the specular direction) |
| B | 1, per line | shoulder, > 0 (the roll-off sits at a distance B^(1/g) from beta0) |
| G | 1, per line | power-law slope, >= 0 (G = 0: a Lambertian of BRDF A / (B + 1)) |

Model.  beta = the component of wo in the surface plane (sin theta_o along the viewing azimuth), beta0 = the
component of the mirror direction of wi (= minus that of wi); |beta - beta0| = |wo_t + wi_t| is symmetric in
wi and wo, so the model is reciprocal.  In the projected-disk coordinates beta the projected solid angle is
the area (cos theta_o dOmega = d^2 beta), so the directional-hemispherical reflectance is the integral of f
over the unit disk: albedo(cos_i) = A int_{|beta| < 1} d^2 beta / (B + |beta - beta0|^g).  It is largest at
normal incidence (f decreases with the distance from beta0); build() refuses parameters whose normal-incidence
albedo exceeds 1.

Sampling: in the beta plane about beta0, a uniform azimuth and a radius r from the density proportional to
the piecewise-linear interpolant of h(r) = r / (B + r^g) on 64 nodes graded geometrically from the shoulder
truncated at r = 1 + |beta0| (no point of the unit disk lies farther from beta0); inverted exactly per segment
(a quadratic).  Points outside the unit disk are lost (weight 0, direction below the surface): none at normal
incidence, about a third at grazing incidence.  pdf = co q(beta), q(beta) = h_lin(r) / (2 pi r C(1 + |beta0|))
with C the cumulative mass, and weight = f / q(beta).  pack() stores the nodes, h and the cumulative masses per line,
and an albedo table over cos_i computed with Gauss-Legendre quadrature in polar coordinates about beta0.
"""
import math

import numba
import numpy as np

from ...core.diagnostics import error
from ...lang.spec import Clause, Form, PL, nonneg, positive
from ...kernels.sampling import onb
from ._common import table_interp, table_mu_nodes

KIND = "ABG"
def _slope_ok(g):
    return None if g == 0 or 1e-3 <= g <= 10 else "must be 0 or in [0.001, 10]"


FORM = Form((), (Clause("A", (PL("a", check=nonneg),), required=True, doc="scale (1/sr)"),
                 Clause("B", (PL("b", check=positive),), required=True, doc="shoulder"),
                 Clause("G", (PL("g", check=_slope_ok),), required=True, doc="slope")))
EXAMPLE = "MODEL mirror_scatter ABG A 0.001 B 0.0001 G 2"
TRANSMITS = False

NR = 64                # radial segments of the sampler
NT = 97                # albedo table nodes
T0 = 0.0
ROW_R = 3
ROW_H = ROW_R + NR + 1
ROW_C = ROW_H + NR + 1
ROW_A = ROW_C + NR + 1
N_PARAMS = ROW_A + NT


def _shoulder(b: float, g: float) -> float:
    """b^(1/g), where the BRDF turns over, computed in log space (no overflow for large b or small g)."""
    return math.exp(min(700.0, math.log(float(b)) / float(g))) if g > 0 else 1.0


def normal_albedo(a: float, b: float, g: float) -> float:
    """2 pi A int_0^1 r / (B + r^g) dr: the albedo at normal incidence (the largest)."""
    scale = _shoulder(b, g)
    pts = [p for p in (scale, 10 * scale) if 0 < p < 1]
    from scipy import integrate   # here, not at import: scipy costs every `irt run` ~0.3 s of start-up

    v = integrate.quad(lambda r: r / (b + r ** g), 0.0, 1.0, points=pts or None, limit=200,
                       epsabs=1e-13, epsrel=1e-11)[0]
    return 2.0 * math.pi * float(a) * v   # a plain float: an enormous A gives inf (refused), not a warning


def build(b, ctx) -> dict:
    A, B, G = b["a"].values, b["b"].values, b["g"].values
    n = max(len(A), len(B), len(G))
    A, B, G = (tuple(np.broadcast_to(x, (n,))) for x in (A, B, G))
    for i, (x, y, z) in enumerate(zip(A, B, G)):
        alb = normal_albedo(x, y, z)
        if not alb <= 1.0 + 1e-9:
            raise error(b.span, f"ABG reflects {alb:.4g} > 1 at normal incidence on line {i + 1}",
                        "lower A or raise B")
    return {"a": A, "b": B, "g": G}


def transmits(params) -> bool:
    return False


def _nodes(b: float, g: float) -> np.ndarray:
    scale = _shoulder(b, g)
    r1 = 0.02 * min(scale, 1.0)
    return np.concatenate(([0.0], np.geomspace(r1, 2.0, NR)))


@numba.njit(cache=True, fastmath=False)
def _h(r, b, g):
    return r / (b + math.pow(r, g))


@numba.njit(cache=True, fastmath=False)
def _albedo_table(a, b, g, rn, mu_nodes, x, wq, xp, wp):
    """A int_0^{2 pi} dpsi H(rho(psi)) about beta0, H(rho) = int_0^rho r / (B + r^g) dr (Gauss-Legendre on
    the graded radial nodes), rho(psi) the distance from beta0 to the unit circle; psi in [0, pi], doubled."""
    nn = rn.shape[0]
    Hn = np.zeros(nn)
    for j in range(nn - 1):
        lo = rn[j]
        hi = rn[j + 1]
        s = 0.0
        for q in range(x.shape[0]):
            r = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x[q]
            s += 0.5 * (hi - lo) * wq[q] * _h(r, b, g)
        Hn[j + 1] = Hn[j] + s
    nt = mu_nodes.shape[0]
    out = np.zeros(nt)
    for i in range(nt):
        ms = min(1.0, mu_nodes[i])
        bb = math.sqrt(max(0.0, (1.0 - ms) * (1.0 + ms)))
        acc = 0.0
        for q in range(xp.shape[0]):
            psi = 0.5 * math.pi * (1.0 + xp[q])
            wpsi = 0.5 * math.pi * wp[q]
            sp = math.sin(psi)
            rho = -bb * math.cos(psi) + math.sqrt(max(0.0, 1.0 - bb * bb * sp * sp))
            j = 0
            while j < nn - 2 and rn[j + 1] <= rho:
                j += 1
            lo = rn[j]
            s = 0.0
            if rho > lo:
                for t in range(x.shape[0]):
                    r = 0.5 * (lo + rho) + 0.5 * (rho - lo) * x[t]
                    s += 0.5 * (rho - lo) * wq[t] * _h(r, b, g)
            acc += wpsi * (Hn[j] + s)
        out[i] = 2.0 * a * acc
    return out


def pack(params, n_lines: int) -> np.ndarray:
    P = np.zeros((N_PARAMS, n_lines))
    P[0] = np.broadcast_to(np.asarray(params["a"], float), (n_lines,))
    P[1] = np.broadcast_to(np.asarray(params["b"], float), (n_lines,))
    P[2] = np.broadcast_to(np.asarray(params["g"], float), (n_lines,))
    mu = table_mu_nodes(NT, T0 * T0)
    x, wq = np.polynomial.legendre.leggauss(16)
    xp, wp = np.polynomial.legendre.leggauss(96)
    cache = {}
    for k in range(n_lines):
        a, b, g = P[0, k], P[1, k], P[2, k]
        key = (a, b, g)
        if key not in cache:
            rn = _nodes(b, g)
            h = rn / (b + rn ** g)
            h[0] = 0.0
            c = np.concatenate(([0.0], np.cumsum(0.5 * (h[1:] + h[:-1]) * np.diff(rn))))
            cache[key] = (rn, h, c, _albedo_table(a, b, g, rn, mu, x, wq, xp, wp))
        rn, h, c, alb = cache[key]
        P[ROW_R:ROW_R + NR + 1, k] = rn
        P[ROW_H:ROW_H + NR + 1, k] = h
        P[ROW_C:ROW_C + NR + 1, k] = c
        P[ROW_A:ROW_A + NT, k] = alb
    return P


@numba.njit(cache=True, fastmath=False)
def _dist(wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    """|beta - beta0| = |wo_t + wi_t| (tangential components)."""
    ci = wix * nx + wiy * ny + wiz * nz
    co = wox * nx + woy * ny + woz * nz
    dx = wox + wix - (ci + co) * nx
    dy = woy + wiy - (ci + co) * ny
    dz = woz + wiz - (ci + co) * nz
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True, fastmath=False)
def _segment(P, k, row0, x):
    """j with P[row0 + j] <= x < P[row0 + j + 1], j in [0, NR - 1] (rows row0 .. row0 + NR increasing)."""
    lo = 0
    hi = NR
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if P[row0 + mid, k] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True, fastmath=False)
def _rmax(wix, wiy, wiz, nx, ny, nz):
    """1 + |beta0|: no point of the unit disk lies farther from beta0."""
    ci = wix * nx + wiy * ny + wiz * nz
    return min(1.0 + math.sqrt(max(0.0, (1.0 - ci) * (1.0 + ci))), 2.0)


@numba.njit(cache=True, fastmath=False)
def _mass(P, k, r):
    """Cumulative mass of the piecewise-linear radial density up to r (<= the last node)."""
    j = _segment(P, k, ROW_R, r)
    t = r - P[ROW_R + j, k]
    h0 = P[ROW_H + j, k]
    sl = (P[ROW_H + j + 1, k] - h0) / (P[ROW_R + j + 1, k] - P[ROW_R + j, k])
    return P[ROW_C + j, k] + h0 * t + 0.5 * sl * t * t


@numba.njit(cache=True, fastmath=False)
def _q(P, k, r, rmax):
    """Density of the sampler per unit area of the beta plane at distance r from beta0 (radii up to rmax)."""
    if r > rmax:
        return 0.0
    c_tot = _mass(P, k, rmax)
    if c_tot <= 0.0:
        return 0.0
    j = _segment(P, k, ROW_R, r)
    r0 = P[ROW_R + j, k]
    r1 = P[ROW_R + j + 1, k]
    h0 = P[ROW_H + j, k]
    h1 = P[ROW_H + j + 1, k]
    if j == 0:
        return h1 / r1 / (2.0 * math.pi * c_tot)        # h_lin(r) / r is constant on the first segment
    hl = h0 + (h1 - h0) * (r - r0) / (r1 - r0)
    return hl / (2.0 * math.pi * r * c_tot)


@numba.njit(cache=True, fastmath=False)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    co = wox * nx + woy * ny + woz * nz
    if co <= 0.0:
        return 0.0
    r = _dist(wix, wiy, wiz, wox, woy, woz, nx, ny, nz)
    return P[0, k] / (P[1, k] + math.pow(r, P[2, k]))


@numba.njit(cache=True, fastmath=False)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    co = wox * nx + woy * ny + woz * nz
    if co <= 0.0:
        return 0.0
    return co * _q(P, k, _dist(wix, wiy, wiz, wox, woy, woz, nx, ny, nz), _rmax(wix, wiy, wiz, nx, ny, nz))


@numba.njit(cache=True, fastmath=False)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """(wox, woy, woz, weight, delta): radius from the tabulated radial density, uniform azimuth about beta0."""
    rmax = _rmax(wix, wiy, wiz, nx, ny, nz)
    c_tot = _mass(P, k, rmax)
    if c_tot <= 0.0 or P[0, k] <= 0.0:
        return -nx, -ny, -nz, 0.0, False
    xm = u0 * c_tot
    lo = _segment(P, k, ROW_C, xm)
    r0 = P[ROW_R + lo, k]
    dr = P[ROW_R + lo + 1, k] - r0
    h0 = P[ROW_H + lo, k]
    sl = (P[ROW_H + lo + 1, k] - h0) / dr
    v = max(0.0, xm - P[ROW_C + lo, k])
    den = h0 + math.sqrt(max(0.0, h0 * h0 + 2.0 * sl * v))
    t = 2.0 * v / den if den > 0.0 else 0.0
    r = min(r0 + min(max(t, 0.0), dr), rmax)
    psi = 2.0 * math.pi * u1
    t1x, t1y, t1z, t2x, t2y, t2z = onb(nx, ny, nz)
    bx = -(wix * t1x + wiy * t1y + wiz * t1z) + r * math.cos(psi)
    by = -(wix * t2x + wiy * t2y + wiz * t2z) + r * math.sin(psi)
    b2 = bx * bx + by * by
    if b2 >= 1.0:
        return -nx, -ny, -nz, 0.0, False
    z = math.sqrt(1.0 - b2)
    ox = bx * t1x + by * t2x + z * nx
    oy = bx * t1y + by * t2y + z * ny
    oz = bx * t1z + by * t2z + z * nz
    q = _q(P, k, _dist(wix, wiy, wiz, ox, oy, oz, nx, ny, nz), rmax)
    if q <= 0.0:
        return -nx, -ny, -nz, 0.0, False
    return ox, oy, oz, eval(P, k, wix, wiy, wiz, ox, oy, oz, nx, ny, nz) / q, False


@numba.njit(cache=True, fastmath=False)
def albedo(P, k, cos_i):
    """(R, 0): the integral of f over the unit beta disk (table over cos_i)."""
    return max(0.0, table_interp(P, k, ROW_A, NT, T0, cos_i)), 0.0


@numba.njit(cache=True, fastmath=False)
def direct_transmission(P, k, cos_i):
    return 0.0
