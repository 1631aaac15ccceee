"""GLINT WIND speed INDEX n [ALBEDO a]

Ocean sun glint: Cox-Munk isotropic slope distribution (s^2 = 0.003 + 0.00512 U), Nakajima-Tanaka
shadowing and Fresnel reflection for water of index n, plus a water-leaving Lambert term of albedo
ALBEDO minus the glint's total integrated scatter.

| parameter | unit | meaning |
|---|---|---|
| WIND | speed (bare: m/s) | wind speed 12.5 m above the sea |
| INDEX | 1, per line | refractive index of water |
| ALBEDO | 1, per line | total albedo including the water-leaving term (default 0.02) |

Model (Cox and Munk 1954; Nakajima and Tanaka 1983).  With h = (wi + wo)/|wi + wo| the facet normal,
beta its tilt (cos beta = h.n), mu_s = wi.n, mu_v = wo.n:

- slopes: p = exp(-tan^2 beta / s^2) / (pi s^2), s^2 = 0.003 + 0.00512 U the total (isotropic) mean
  square slope -- the Beckmann distribution of roughness s;
- glint BRDF = F(n, wi.h) p S / (4 mu_s mu_v cos^4 beta), F the unpolarized Fresnel reflectance from air into
  water of index n at the facet's incidence angle (wi.h, half the specular angle);
- shadowing S = 1 / (1 + L(mu_s) + L(mu_v)), L(mu) = [exp(-v^2) / (v sqrt(pi)) - erfc(v)] / 2,
  v = mu / (s sqrt(1 - mu^2)) (Nakajima-Tanaka; the same as Smith's height-correlated masking for Beckmann);
- water-leaving Lambert term: BRDF = max(0, ALBEDO - TIS(mu_s)) / pi, TIS(mu_s) the glint's
  directional-hemispherical reflectance (a table over cos_i built by pack()).

Convention of the reference values: the glint reflectance factor is pi times the glint BRDF (as for
RAYLEIGH), i.e. rho = pi F p S / (4 mu_s mu_v cos^4 beta).  At the specular point (beta = 0) for n = 1.34
this gives 0.258724 (30/30 deg, U = 5), 0.190513 (U = 7), 0.136522 (U = 10) and 0.370524 (45/45, U = 7),
the values of ORACLES.md to their 4 digits.  Shadowing does not discriminate there: at 30 and 45 deg
L(mu) < 1e-10 for these winds, so the values hold with or without it.  They do rule out a reflectance factor
without the factor pi (pi times smaller) and reading s^2 as the variance per slope axis (total 2 s^2: half as
large at beta = 0).

Reciprocity: the glint term is reciprocal (symmetric in wi, wo); the Lambert term as specified depends on
mu_s only (through TIS), so the full model is reciprocal only where TIS(mu_s) = TIS(mu_v) or ALBEDO <= TIS.

Polarization (``mueller``): the glint term reflects by Fresnel's Mueller matrix on the facet (its plane of
incidence holds wi, wo and h; e1' = its normal, s), divided by F so that its I row for unpolarized light is the
scalar model; the water-leaving Lambert term depolarizes.  The outgoing state is the mix of both by their
shares of f at (wi, wo).

Sampling: with probability A_L / (A_L + TIS), A_L = max(0, ALBEDO - TIS(mu_s)), a cosine-weighted direction,
otherwise a facet normal from the slope distribution (tan^2 beta = -s^2 ln u, uniform azimuth: density
p / cos^3 beta per steradian of h) and the mirror direction wo = 2 (wi.h) h - wi, density
p / (4 cos^3 beta wi.h) per steradian of wo.  The weight is f cos_o / pdf with pdf the mixture of both
densities.  A facet facing away (wi.h <= 0) or a mirror direction below the horizon returns weight 0 and a
direction below the surface (where pdf = 0): pdf() integrates to one minus that lost share.
"""
import math

import numba
import numpy as np

from ...lang.spec import Clause, Form, PL, V, nonneg, unit_interval
from ...core.units import SPEED
from ...kernels.optics import fresnel_unpolarized
from ...kernels.polar import frame, fresnel_mueller, perpendicular, rotate
from ...kernels.sampling import cosine_hemisphere, onb
from ._common import INV_PI, MU_MIN, table_interp, table_mu_nodes

KIND = "GLINT"
FORM = Form((), (Clause("WIND", (V("wind", SPEED, check=nonneg),), required=True),
                 Clause("INDEX", (PL("index", check=lambda x: None if x >= 1 else "must be >= 1"),), required=True),
                 Clause("ALBEDO", (PL("albedo", check=unit_interval),))))
EXAMPLE = "MODEL sea GLINT WIND 7 m/s INDEX 1.34 ALBEDO 0.02"
TRANSMITS = False

NT = 97
T0 = 0.0
ROW_TIS = 3
N_PARAMS = ROW_TIS + NT
SQRT_PI = math.sqrt(math.pi)


def build(b, ctx) -> dict:
    n = b["index"].values
    return {"wind": b["wind"], "index": n, "albedo": b["albedo"].values if "albedo" in b else (0.02,) * len(n)}


def transmits(params) -> bool:
    return False


def slope_variance(wind: float) -> float:
    """Cox-Munk isotropic mean square slope for a wind speed in m/s."""
    return 0.003 + 0.00512 * wind


@numba.njit(cache=True, fastmath=False)
def shadow_lambda(mu, s2):
    """Nakajima-Tanaka / Smith Lambda(mu) for mean square slope s2 (0 at mu = 1, -> inf at mu = 0)."""
    if mu >= 1.0:
        return 0.0
    mu = max(mu, MU_MIN)
    v = mu / math.sqrt(s2 * (1.0 - mu) * (1.0 + mu))
    if v > 26.0:
        return 0.0
    return 0.5 * (math.exp(-v * v) / (v * SQRT_PI) - math.erfc(v))


@numba.njit(cache=True, fastmath=False)
def glint_brdf(s2, n, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    """The glint term alone (1/sr)."""
    ci = max(wix * nx + wiy * ny + wiz * nz, MU_MIN)
    co = wox * nx + woy * ny + woz * nz
    if co <= 0.0:
        return 0.0
    hx = wix + wox
    hy = wiy + woy
    hz = wiz + woz
    hm = math.sqrt(hx * hx + hy * hy + hz * hz)
    if hm == 0.0:
        return 0.0
    cb = min((hx * nx + hy * ny + hz * nz) / hm, 1.0)
    if cb <= 1e-60:                      # p underflows long before: exp(-1/(cb^2 s^2))
        return 0.0
    tan2 = (1.0 - cb) * (1.0 + cb) / (cb * cb)
    if tan2 > 700.0 * s2:
        return 0.0
    p = math.exp(-tan2 / s2) / (math.pi * s2)
    cih = (wix * hx + wiy * hy + wiz * hz) / hm
    F = fresnel_unpolarized(cih, 1.0, n)
    S = 1.0 / (1.0 + shadow_lambda(ci, s2) + shadow_lambda(co, s2))
    cb2 = cb * cb
    return F * p * S / (4.0 * ci * max(co, MU_MIN) * cb2 * cb2)


@numba.njit(cache=True, fastmath=False)
def _tis_table(s2, n, mu_nodes, x, wq):
    """Glint directional-hemispherical reflectance at each node: Gauss-Legendre over theta_o and phi in
    [0, pi] (doubled), in panels that put the specular peak (theta_i, pi) on panel edges and resolve its
    width (about 2 s)."""
    nt = mu_nodes.shape[0]
    m = x.shape[0]
    out = np.zeros(nt)
    s = math.sqrt(s2)
    tb = np.empty(6)
    pb = np.empty(3)
    for i in range(nt):
        ms = mu_nodes[i]
        th_i = math.acos(min(1.0, ms))
        wix = math.sqrt(max(0.0, 1.0 - ms * ms))
        tb[0] = 0.0
        tb[1] = max(0.0, th_i - 5.0 * s)
        tb[2] = th_i
        tb[3] = min(0.5 * math.pi, th_i + 5.0 * s)
        tb[4] = 0.5 * math.pi
        pb[0] = 0.0
        pb[1] = max(0.0, math.pi - 10.0 * s)
        pb[2] = math.pi
        acc = 0.0
        for pt in range(4):
            lo = tb[pt]
            hi = tb[pt + 1]
            if hi <= lo:
                continue
            for a in range(m):
                th = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x[a]
                wa = 0.5 * (hi - lo) * wq[a]
                st = math.sin(th)
                ct = math.cos(th)
                for pp in range(2):
                    plo = pb[pp]
                    phi_ = pb[pp + 1]
                    if phi_ <= plo:
                        continue
                    for b in range(m):
                        ph = 0.5 * (plo + phi_) + 0.5 * (phi_ - plo) * x[b]
                        wb = 0.5 * (phi_ - plo) * wq[b]
                        f = glint_brdf(s2, n, wix, 0.0, ms, st * math.cos(ph), st * math.sin(ph), ct, 0.0, 0.0, 1.0)
                        acc += wa * wb * f * ct * st
        out[i] = 2.0 * acc
    return out


def pack(params, n_lines: int) -> np.ndarray:
    P = np.zeros((N_PARAMS, n_lines))
    P[0] = slope_variance(float(params["wind"]))
    P[1] = np.broadcast_to(np.asarray(params["index"], float), (n_lines,))
    P[2] = np.broadcast_to(np.asarray(params["albedo"], float), (n_lines,))
    mu = table_mu_nodes(NT, T0 * T0)
    x, wq = np.polynomial.legendre.leggauss(40)
    cache = {}
    for k in range(n_lines):
        key = (P[0, k], P[1, k])
        if key not in cache:
            cache[key] = _tis_table(P[0, k], P[1, k], mu, x, wq)
        P[ROW_TIS:ROW_TIS + NT, k] = cache[key]
    return P


@numba.njit(cache=True, fastmath=False)
def tis(P, k, cos_i):
    """The glint's directional-hemispherical reflectance (table)."""
    return max(0.0, table_interp(P, k, ROW_TIS, NT, T0, cos_i))


@numba.njit(cache=True, fastmath=False)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    co = wox * nx + woy * ny + woz * nz
    if co <= 0.0:
        return 0.0
    ci = wix * nx + wiy * ny + wiz * nz
    lam = max(0.0, P[2, k] - tis(P, k, ci)) * INV_PI
    return glint_brdf(P[0, k], P[1, k], wix, wiy, wiz, wox, woy, woz, nx, ny, nz) + lam


@numba.njit(cache=True, fastmath=False)
def _glint_pdf(s2, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    """Density per steradian of wo of the facet-normal sampler (reflection side only)."""
    co = wox * nx + woy * ny + woz * nz
    if co <= 0.0:
        return 0.0
    hx = wix + wox
    hy = wiy + woy
    hz = wiz + woz
    hm = math.sqrt(hx * hx + hy * hy + hz * hz)
    if hm == 0.0:
        return 0.0
    cb = min((hx * nx + hy * ny + hz * nz) / hm, 1.0)
    cih = (wix * hx + wiy * hy + wiz * hz) / hm
    if cb <= 1e-60 or cih <= 1e-200:
        return 0.0
    tan2 = (1.0 - cb) * (1.0 + cb) / (cb * cb)
    if tan2 > 700.0 * s2:
        return 0.0
    p = math.exp(-tan2 / s2) / (math.pi * s2)
    return p / (cb * cb * cb) / (4.0 * cih)


@numba.njit(cache=True, fastmath=False)
def _lobe_prob(P, k, ci):
    """(q_lambert, A_L): the probability of the Lambert lobe and its albedo."""
    t = tis(P, k, ci)
    al = max(0.0, P[2, k] - t)
    if al + t <= 0.0:
        return 0.0, 0.0
    return al / (al + t), al


@numba.njit(cache=True, fastmath=False)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    co = wox * nx + woy * ny + woz * nz
    if co <= 0.0:
        return 0.0
    ci = wix * nx + wiy * ny + wiz * nz
    q, al = _lobe_prob(P, k, ci)
    return (1.0 - q) * _glint_pdf(P[0, k], wix, wiy, wiz, wox, woy, woz, nx, ny, nz) + q * co * INV_PI


@numba.njit(cache=True, fastmath=False)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """(wox, woy, woz, weight, delta): the mixture of the facet sampler and the Lambert lobe."""
    s2 = P[0, k]
    ci = wix * nx + wiy * ny + wiz * nz
    q, al = _lobe_prob(P, k, ci)
    if al <= 0.0 and tis(P, k, ci) <= 0.0:
        return -nx, -ny, -nz, 0.0, False
    t1x, t1y, t1z, t2x, t2y, t2z = onb(nx, ny, nz)
    if u2 < q:
        x, y, z = cosine_hemisphere(u0, u1)
        ox = x * t1x + y * t2x + z * nx
        oy = x * t1y + y * t2y + z * ny
        oz = x * t1z + y * t2z + z * nz
    else:
        tan2 = -s2 * math.log(max(u0, 1e-300))
        cb = 1.0 / math.sqrt(1.0 + tan2)
        sb = math.sqrt(tan2) * cb
        ph = 2.0 * math.pi * u1
        a = sb * math.cos(ph)
        b = sb * math.sin(ph)
        mx = a * t1x + b * t2x + cb * nx
        my = a * t1y + b * t2y + cb * ny
        mz = a * t1z + b * t2z + cb * nz
        c = wix * mx + wiy * my + wiz * mz
        ox = 2.0 * c * mx - wix
        oy = 2.0 * c * my - wiy
        oz = 2.0 * c * mz - wiz
        m = math.sqrt(ox * ox + oy * oy + oz * oz)
        ox /= m
        oy /= m
        oz /= m
        if c <= 0.0:          # a facet facing away: lost (its mirror direction is below the surface)
            if ox * nx + oy * ny + oz * nz > 0.0:
                return -nx, -ny, -nz, 0.0, False
            return ox, oy, oz, 0.0, False
    co = ox * nx + oy * ny + oz * nz
    if co <= 0.0:
        return ox, oy, oz, 0.0, False
    pd = pdf(P, k, wix, wiy, wiz, ox, oy, oz, nx, ny, nz)
    if pd <= 0.0:
        return -nx, -ny, -nz, 0.0, False
    f = eval(P, k, wix, wiy, wiz, ox, oy, oz, nx, ny, nz)
    return ox, oy, oz, f * co / pd, False


@numba.njit(cache=True, fastmath=False)
def albedo(P, k, cos_i):
    """(TIS + max(0, ALBEDO - TIS), 0) = (max(ALBEDO, TIS), 0)."""
    t = tis(P, k, cos_i)
    return t + max(0.0, P[2, k] - t), 0.0


@numba.njit(cache=True, fastmath=False)
def direct_transmission(P, k, cos_i):
    return 0.0


@numba.njit(cache=True, fastmath=False)
def mueller(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz, q, u, v, ex, ey, ez):
    """Polarized reflection (the contract: plugins/bsdfs/_common.depolarize): the glint's share of f reflects
    by the facet's Fresnel Mueller matrix over F, the Lambert share leaves unpolarized."""
    f = eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz)
    fg = glint_brdf(P[0, k], P[1, k], wix, wiy, wiz, wox, woy, woz, nx, ny, nz)
    hx = wix + wox
    hy = wiy + woy
    hz = wiz + woz
    hm = math.sqrt(hx * hx + hy * hy + hz * hz)
    # the incoming ray's direction is -wi; s = d x h / |d x h| (the facet's plane of incidence holds wo too)
    sx, sy, sz = perpendicular(-wix, -wiy, -wiz, hx, hy, hz, ex, ey, ez)
    if not (f > 0.0 and fg > 0.0 and hm > 0.0):
        fx, fy, fz = frame(wox, woy, woz, sx, sy, sz)
        return 1.0, 0.0, 0.0, 0.0, fx, fy, fz
    g = fg / f
    qs, us = rotate(-wix, -wiy, -wiz, ex, ey, ez, q, u, sx, sy, sz)
    A, B, x, y, _a, _b, _c = fresnel_mueller((wix * hx + wiy * hy + wiz * hz) / hm, 1.0, P[1, k])
    i1 = g * (A + B * qs) / A + (1.0 - g)
    if not (i1 > 0.0):
        return 0.0, 0.0, 0.0, 0.0, sx, sy, sz
    c = g / (A * i1)
    return i1, c * (B + A * qs), c * (x * us - y * v), c * (y * us + x * v), sx, sy, sz
