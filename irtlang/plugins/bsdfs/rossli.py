"""ROSSLI ISO f_iso... VOL f_vol... GEO f_geo...

The MODIS BRDF model (RossThick volumetric and LiSparse-Reciprocal geometric kernels):
R(ts, tv, phi) = f_iso + f_vol K_vol + f_geo K_geo, clamped to be non-negative; BRDF = R / pi.

| parameter | unit | meaning |
|---|---|---|
| ISO | 1, per line | isotropic kernel weight |
| VOL | 1, per line | RossThick weight |
| GEO | 1, per line | LiSparse-R weight |

Kernels (Roujean et al. 1992; Wanner, Li and Strahler 1995; Lucht, Schaaf and Strahler 2000, the MODIS
BRDF/albedo ATBD), with theta_s the light's zenith angle, theta_v the viewer's, phi the relative azimuth, 0 when
light and viewer are on the same side (the hot spot, backscattering) and 180 deg in the forward / specular
direction; the phase angle xi has cos xi = cos ts cos tv + sin ts sin tv cos phi = wi.wo:

- K_vol = [(pi/2 - xi) cos xi + sin xi] / (cos ts + cos tv) - pi/4 (RossThick);
- K_geo = O - sec ts - sec tv + (1 + cos xi) sec ts sec tv / 2 (LiSparse-Reciprocal, h/b = 2, b/r = 1, so
  the primed angles equal the true ones), with O = (t - sin t cos t)(sec ts + sec tv)/pi,
  cos t = (h/b) sqrt(D^2 + (tan ts tan tv sin phi)^2) / (sec ts + sec tv) clamped to [-1, 1],
  D^2 = tan^2 ts + tan^2 tv - 2 tan ts tan tv cos phi.

Reference values (ORACLES.md): (30, 30, 0) gives K_vol 0.121502, K_geo 0.178633; (60, 60, 0) pi/4 and 2.
White-sky (bihemispherical) integrals 0.189184 and -1.377622.  Reciprocal: f(wi, wo) = f(wo, wi).

Sampling is cosine-weighted (pdf = cos_o / pi), so the weight f cos_o / pdf is R itself: for MODIS-type
parameters R varies by tens of per cent over the hemisphere, so this is already close to the ideal constant
weight and a tabulated sampler would gain little.  albedo(cos_i) reads a table built by pack(): Gauss-Legendre
quadrature of R cos_o / pi over the hemisphere (split at mu_v = mu_s and at the hot spot, where K_geo has a
cusp), at cos_i nodes uniform in sqrt(cos_i) from cos_i = 0.01; below 0.01 (theta_i > 89.4 deg, where the
kernels diverge as sec theta_i) it holds the value at 0.01.  Cosines are floored at 1e-9 in eval.
"""
import math

import numba
import numpy as np

from ...lang.spec import Clause, Form, PL
from ...kernels.sampling import cosine_hemisphere, onb
from ._common import INV_PI, MU_MIN, table_interp, table_mu_nodes

KIND = "ROSSLI"
FORM = Form((), (Clause("ISO", (PL("iso"),), required=True), Clause("VOL", (PL("vol"),), required=True),
                 Clause("GEO", (PL("geo"),), required=True)))
EXAMPLE = "MODEL grass ROSSLI ISO 0.03 VOL 0.02 GEO 0.005"
TRANSMITS = False

HB = 2.0               # h/b
NT = 97
MU_TABLE_MIN = 0.01
T0 = math.sqrt(MU_TABLE_MIN)
ROW_A = 3
N_PARAMS = ROW_A + NT


def build(b, ctx) -> dict:
    return {"iso": b["iso"].values, "vol": b["vol"].values, "geo": b["geo"].values}


def transmits(params) -> bool:
    return False


@numba.njit(cache=True, fastmath=False)
def kernels(mu_s, mu_v, cos_xi):
    """(K_vol, K_geo) for the cosines of the two zenith angles and of the phase angle (cos xi = wi.wo)."""
    mu_s = min(1.0, max(mu_s, MU_MIN))
    mu_v = min(1.0, max(mu_v, MU_MIN))
    cos_xi = min(1.0, max(-1.0, cos_xi))
    xi = math.acos(cos_xi)
    sin_xi = math.sqrt(max(0.0, 1.0 - cos_xi * cos_xi))
    kvol = ((0.5 * math.pi - xi) * cos_xi + sin_xi) / (mu_s + mu_v) - 0.25 * math.pi
    ss = math.sqrt(max(0.0, 1.0 - mu_s * mu_s))
    sv = math.sqrt(max(0.0, 1.0 - mu_v * mu_v))
    sec_s = 1.0 / mu_s
    sec_v = 1.0 / mu_v
    tan_s = ss * sec_s
    tan_v = sv * sec_v
    # tan ts tan tv cos phi = (cos xi - mu_s mu_v) / (mu_s mu_v); its sin-part from |wi_t x wo_t|^2
    a = cos_xi - mu_s * mu_v                                   # sin ts sin tv cos phi
    sin2 = max(0.0, (ss * sv) ** 2 - a * a)                    # (sin ts sin tv sin phi)^2
    tc = a * sec_s * sec_v
    d2 = max(0.0, tan_s * tan_s + tan_v * tan_v - 2.0 * tc)
    ts2 = sin2 * (sec_s * sec_v) ** 2
    sec_sum = sec_s + sec_v
    cos_t = HB * math.sqrt(d2 + ts2) / sec_sum
    cos_t = min(1.0, max(-1.0, cos_t))
    t = math.acos(cos_t)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    O = (t - sin_t * cos_t) * sec_sum / math.pi
    kgeo = O - sec_sum + 0.5 * (1.0 + cos_xi) * sec_s * sec_v
    return kvol, kgeo


@numba.njit(cache=True, fastmath=False)
def reflectance_factor(iso, vol, geo, mu_s, mu_v, cos_xi):
    kv, kg = kernels(mu_s, mu_v, cos_xi)
    return max(0.0, iso + vol * kv + geo * kg)


@numba.njit(cache=True, fastmath=False)
def _albedo_tables(W, mu_nodes, x, wq):
    """R_dh at each node, for each weight triple W (m, 3): the sum over mu_v panels [0, mu_s], [mu_s, 1] and phi in
    [0, pi] (doubled); the kernels are evaluated once on the quadrature grid and shared by the triples."""
    nt = mu_nodes.shape[0]
    n = x.shape[0]
    m = W.shape[0]
    out = np.zeros((m, nt))
    kv = np.empty((2 * n, n))
    kg = np.empty((2 * n, n))
    ww = np.empty((2 * n, n))
    for i in range(nt):
        ms = mu_nodes[i]
        ss = math.sqrt(max(0.0, 1.0 - ms * ms))
        for panel in range(2):
            lo = 0.0 if panel == 0 else ms
            hi = ms if panel == 0 else 1.0
            for a in range(n):
                mv = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x[a]
                wa = 0.5 * (hi - lo) * wq[a]
                sv = math.sqrt(max(0.0, 1.0 - mv * mv))
                for b in range(n):
                    ph = 0.5 * math.pi * (1.0 + x[b])
                    wb = 0.5 * math.pi * wq[b]
                    cxi = ms * mv + ss * sv * math.cos(ph)
                    kv[panel * n + a, b], kg[panel * n + a, b] = kernels(ms, mv, cxi)
                    ww[panel * n + a, b] = wa * wb * mv
        for q in range(m):
            iso = W[q, 0]
            vol = W[q, 1]
            geo = W[q, 2]
            acc = 0.0
            for r in range(2 * n):
                for b in range(n):
                    acc += ww[r, b] * max(0.0, iso + vol * kv[r, b] + geo * kg[r, b])
            out[q, i] = 2.0 * acc * INV_PI
    return out


def _albedo_table(iso, vol, geo, mu_nodes, x, wq):
    """R_dh at each node for one weight triple."""
    return _albedo_tables(np.array([[iso, vol, geo]], float), mu_nodes, x, wq)[0]


def pack(params, n_lines: int) -> np.ndarray:
    P = np.zeros((N_PARAMS, n_lines))
    for r, key in enumerate(("iso", "vol", "geo")):
        P[r] = np.broadcast_to(np.asarray(params[key], float), (n_lines,))
    mu = table_mu_nodes(NT, MU_TABLE_MIN)
    x, wq = np.polynomial.legendre.leggauss(64)
    keys, inv = np.unique(P[0:3].T, axis=0, return_inverse=True)
    P[ROW_A:ROW_A + NT] = _albedo_tables(np.ascontiguousarray(keys), mu, x, wq)[np.ravel(inv)].T
    return P


@numba.njit(cache=True, fastmath=False)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    co = wox * nx + woy * ny + woz * nz
    if co <= 0.0:
        return 0.0
    ci = wix * nx + wiy * ny + wiz * nz
    cxi = wix * wox + wiy * woy + wiz * woz
    return reflectance_factor(P[0, k], P[1, k], P[2, k], ci, co, cxi) * INV_PI


@numba.njit(cache=True, fastmath=False)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    co = wox * nx + woy * ny + woz * nz
    return co * INV_PI if co > 0.0 else 0.0


@numba.njit(cache=True, fastmath=False)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """Cosine-weighted direction; weight = f cos_o / pdf = R (the reflectance factor there)."""
    x, y, z = cosine_hemisphere(u0, u1)
    t1x, t1y, t1z, t2x, t2y, t2z = onb(nx, ny, nz)
    ox = x * t1x + y * t2x + z * nx
    oy = x * t1y + y * t2y + z * ny
    oz = x * t1z + y * t2z + z * nz
    if z <= 0.0:
        return ox, oy, oz, 0.0, False
    ci = wix * nx + wiy * ny + wiz * nz
    cxi = wix * ox + wiy * oy + wiz * oz
    return ox, oy, oz, reflectance_factor(P[0, k], P[1, k], P[2, k], ci, z, cxi), False


@numba.njit(cache=True, fastmath=False)
def albedo(P, k, cos_i):
    """(R, 0): directional-hemispherical reflectance from the table (clamped >= 0)."""
    return max(0.0, table_interp(P, k, ROW_A, NT, T0, cos_i)), 0.0


@numba.njit(cache=True, fastmath=False)
def direct_transmission(P, k, cos_i):
    return 0.0
