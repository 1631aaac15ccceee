"""TABLE 'file'

A tabulated isotropic BRDF f(theta_i, theta_o, phi) read from a text table; reflection only.  `file` is relative
to the script's folder.  Columns (comma, semicolon or blank separated; `#` and `!!` start comments; one optional
header line): `theta_i_deg, theta_o_deg, phi_deg` and either one `brdf` column (every line) or one per system
line in the order of `WAVELENGTHS`; BRDF in 1/sr, >= 0.  theta_i (light) and theta_o (viewer) in [0, 90] deg;
phi, the relative azimuth, in [0, 180]: 0 with light and viewer on the same side (backscattering), 180 on the
mirror side.  The rows form a complete grid (every combination of the distinct values once, any order; an axis
may have a single value); the BRDF is interpolated trilinearly in degrees and held at the grid's edges.

| parameter | unit | meaning |
|---|---|---|
| file | path | the BRDF table (format above) |

Further rules.  The BRDF is assumed symmetric in phi -> -phi (an isotropic surface); the specular point is
theta_o = theta_i, phi = 180.  Nothing makes a table reciprocal: f(wi, wo) = f(wo, wi) only if the data are.
build() refuses a table whose hemispherical reflectance exceeds 1 at a tabulated theta_i, a grid with a missing
or repeated combination, angles outside their ranges, negative or non-finite values, and a column count other
than 3 + 1 or 3 + (number of lines).  Example (docs/examples/brdf.csv would hold such a table):

    theta_i_deg,theta_o_deg,phi_deg,brdf
    0,0,0,0.0955
    0,30,0,0.0951
    ...

Sampling: for each tabulated theta_i a piecewise-constant density over cells in (cos theta_o, phi) bounded by the
grid values (and 0, 90 / 0, 180 deg), each cell's probability proportional to the integral of f cos_o over it;
between two tabulated incidence angles the sample comes from either node's density with the trilinear
weights, so the pdf is their mixture and pdf > 0 wherever f > 0.  Weight = f cos_o / pdf.  A node whose BRDF is
zero everywhere falls back to cosine sampling.  albedo(cos_i) is exact for the trilinear interpolant: the
hemispherical integral at each tabulated theta_i (Gauss-Legendre, 8 x 8 points per cell: bilinear f times
the smooth cos theta sin theta, to about 1e-12), interpolated linearly in theta_i.
"""
import math

import numba
import numpy as np

from ...io.tables import read_rows
from ...core.diagnostics import error
from ...lang.spec import Form, Path
from ...kernels.sampling import cosine_hemisphere, onb
from ._common import INV_PI

KIND = "TABLE"
FORM = Form((Path("file"),))
EXAMPLE = None         # needs a file: docs/gen_language_tables.py shows one (FALLBACK_EXAMPLES)
TRANSMITS = False
N_PARAMS = None        # varies with the table: pack(...).shape[0]
H = 5                  # header rows: nI, nO, nP, nEo, nEp
DEG = math.pi / 180.0


# ---------------------------------------------------------------- reading
def read_brdf_table(path, span, n_lines: int):
    """(theta_i, theta_o, phi, brdf[nI, nO, nP, C]) from a table file; C = 1 or n_lines."""
    rows = read_rows(path, span)
    if not rows:
        raise error(span, f"'{path.name}' holds no rows of theta_i_deg, theta_o_deg, phi_deg, brdf")
    w = len(rows[0][1])
    if w != 4 and w != 3 + n_lines:
        raise error(span, f"'{path.name}' has {w} columns: expected theta_i_deg, theta_o_deg, phi_deg and one "
                    f"brdf column" + (f" or one per line ({n_lines})" if n_lines > 1 else ""))
    data = np.array([v for _, v in rows], float)
    for col, name, hi in ((0, "theta_i", 90.0), (1, "theta_o", 90.0), (2, "phi", 180.0)):
        bad = (data[:, col] < 0) | (data[:, col] > hi)
        if bad.any():
            ln = rows[int(np.argmax(bad))][0]
            raise error(span, f"{path.name}:{ln}: {name} = {data[bad][0, col]:g} deg is outside [0, {hi:g}]")
    if (data[:, 3:] < 0).any():
        ln = rows[int(np.argmax((data[:, 3:] < 0).any(axis=1)))][0]
        raise error(span, f"{path.name}:{ln}: a BRDF value is negative")
    axes = [np.unique(data[:, c]) for c in range(3)]
    shape = tuple(len(a) for a in axes)
    if len(data) != shape[0] * shape[1] * shape[2]:
        raise error(span, f"'{path.name}' has {len(data)} rows but its {shape[0]} theta_i x {shape[1]} theta_o x "
                    f"{shape[2]} phi values make {shape[0] * shape[1] * shape[2]}: the rows must form a complete grid")
    idx = [np.searchsorted(a, data[:, c]) for c, a in enumerate(axes)]
    flat = (idx[0] * shape[1] + idx[1]) * shape[2] + idx[2]
    if len(np.unique(flat)) != len(flat):
        raise error(span, f"'{path.name}': a (theta_i, theta_o, phi) combination appears twice")
    brdf = np.zeros(shape + (w - 3,))
    brdf[idx[0], idx[1], idx[2]] = data[:, 3:]
    return axes[0], axes[1], axes[2], brdf


def build(b, ctx) -> dict:
    path = ctx.input_path(b["file"], b.span_of("file"))
    ti, to, ph, brdf = read_brdf_table(path, b.span_of("file"), ctx.n_lines())
    params = {"file": str(path), "theta_i": tuple(ti), "theta_o": tuple(to), "phi": tuple(ph), "brdf": brdf}
    P = pack(params, brdf.shape[3])
    nI = len(ti)
    alb = P[_offsets(P, 0)[8]:_offsets(P, 0)[8] + nI]
    worst = np.unravel_index(np.argmax(alb), alb.shape)
    if alb[worst] > 1.0 + 1e-6:
        raise error(b.span_of("file"), f"'{path.name}' reflects {alb[worst]:.4g} > 1 at theta_i = "
                    f"{ti[worst[0]]:g} deg" + (f" on line {worst[1] + 1}" if brdf.shape[3] > 1 else ""),
                    "a BRDF table must conserve energy: the integral of f cos over the hemisphere is at most 1")
    return params


def transmits(params) -> bool:
    return False


# ---------------------------------------------------------------- packing
def _edges(nodes, hi):
    return np.array(sorted(set([0.0, hi]) | set(float(x) for x in nodes)))


def pack(params, n_lines: int) -> np.ndarray:
    ti = np.asarray(params["theta_i"], float)
    to = np.asarray(params["theta_o"], float)
    ph = np.asarray(params["phi"], float)
    brdf = np.asarray(params["brdf"], float)
    nI, nO, nP = len(ti), len(to), len(ph)
    eo = _edges(to, 90.0)
    ep = _edges(ph, 180.0)
    nEo, nEp = len(eo), len(ep)
    ncell = (nEo - 1) * (nEp - 1)
    n_rows = H + nI + nO + nP + nI * nO * nP + 2 * nEo + nEp + nI * ncell + 2 * nI
    P = np.zeros((n_rows, n_lines))
    P[0], P[1], P[2], P[3], P[4] = nI, nO, nP, nEo, nEp
    o = H
    P[o:o + nI] = ti[:, None]
    o += nI
    P[o:o + nO] = to[:, None]
    o += nO
    P[o:o + nP] = ph[:, None]
    o += nP
    for k in range(n_lines):
        P[o:o + nI * nO * nP, k] = brdf[..., min(k, brdf.shape[3] - 1)].ravel()
    o += nI * nO * nP
    P[o:o + nEo] = eo[:, None]
    P[o + nEo:o + 2 * nEo] = np.cos(eo * DEG)[:, None]
    o += 2 * nEo
    P[o:o + nEp] = (ep * DEG)[:, None]
    x, wq = np.polynomial.legendre.leggauss(8)
    done = {}
    for k in range(n_lines):
        col = min(k, brdf.shape[3] - 1)
        if col not in done:
            _fill_cells(P, k, x, wq)
            done[col] = k
        else:
            P[:, k] = P[:, done[col]]
    return P


@numba.njit(cache=True, fastmath=False)
def _offsets(P, k):
    nI = int(P[0, k])
    nO = int(P[1, k])
    nP = int(P[2, k])
    nEo = int(P[3, k])
    nEp = int(P[4, k])
    oI = H
    oO = oI + nI
    oP = oO + nO
    oF = oP + nP
    oEo = oF + nI * nO * nP          # theta edges (deg), then their cosines
    oEp = oEo + 2 * nEo              # phi edges (rad)
    oW = oEp + nEp                   # per node: cumulative cell probabilities (ncell)
    ncell = (nEo - 1) * (nEp - 1)
    oT = oW + nI * ncell             # per node: total of f cos over the half hemisphere phi in [0, pi]
    oA = oT + nI                     # per node: albedo
    return nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell


@numba.njit(cache=True, fastmath=False)
def _bracket(P, k, row0, n, x):
    """(j, t): x between nodes j and j + 1 with weight t (held at the ends); n = 1 gives (0, 0)."""
    if n == 1 or x <= P[row0, k]:
        return 0, 0.0
    if x >= P[row0 + n - 1, k]:
        return n - 2, 1.0
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if P[row0 + mid, k] <= x:
            lo = mid
        else:
            hi = mid
    a = P[row0 + lo, k]
    b = P[row0 + lo + 1, k]
    return lo, (x - a) / (b - a)


@numba.njit(cache=True, fastmath=False)
def _f_node(P, k, i, th_o, ph_deg):
    """Bilinear BRDF at tabulated theta_i node i."""
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = _offsets(P, k)
    a, s = _bracket(P, k, oO, nO, th_o)
    b, r = _bracket(P, k, oP, nP, ph_deg)
    a1 = min(a + 1, nO - 1)
    b1 = min(b + 1, nP - 1)
    base = oF + i * nO * nP
    f00 = P[base + a * nP + b, k]
    f01 = P[base + a * nP + b1, k]
    f10 = P[base + a1 * nP + b, k]
    f11 = P[base + a1 * nP + b1, k]
    return (1.0 - s) * ((1.0 - r) * f00 + r * f01) + s * ((1.0 - r) * f10 + r * f11)


@numba.njit(cache=True, fastmath=False)
def _fill_cells(P, k, x, wq):
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = _offsets(P, k)
    nq = x.shape[0]
    for i in range(nI):
        acc = 0.0
        for a in range(nEo - 1):
            t0 = P[oEo + a, k] * (math.pi / 180.0)
            t1 = P[oEo + a + 1, k] * (math.pi / 180.0)
            for b in range(nEp - 1):
                p0 = P[oEp + b, k]
                p1 = P[oEp + b + 1, k]
                s = 0.0
                for qa in range(nq):
                    th = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * x[qa]
                    wa = 0.5 * (t1 - t0) * wq[qa]
                    cs = math.cos(th) * math.sin(th)
                    for qb in range(nq):
                        ph = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * x[qb]
                        wb = 0.5 * (p1 - p0) * wq[qb]
                        s += wa * wb * cs * _f_node(P, k, i, th * (180.0 / math.pi), ph * (180.0 / math.pi))
                acc += s
                P[oW + i * ncell + a * (nEp - 1) + b, k] = acc
        P[oT + i, k] = acc
        P[oA + i, k] = 2.0 * acc
        if acc > 0.0:
            for c in range(ncell):
                P[oW + i * ncell + c, k] /= acc


# ---------------------------------------------------------------- kernels
@numba.njit(cache=True, fastmath=False)
def _frame(wix, wiy, wiz, nx, ny, nz):
    """(e1, e2): tangent axes, e1 along the light's tangential direction (phi = 0 there), else onb's t1."""
    ci = wix * nx + wiy * ny + wiz * nz
    ex = wix - ci * nx
    ey = wiy - ci * ny
    ez = wiz - ci * nz
    m = math.sqrt(ex * ex + ey * ey + ez * ez)
    if m < 1e-12:
        t1x, t1y, t1z, t2x, t2y, t2z = onb(nx, ny, nz)
        return t1x, t1y, t1z, t2x, t2y, t2z
    ex /= m
    ey /= m
    ez /= m
    return ex, ey, ez, ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex


@numba.njit(cache=True, fastmath=False)
def _angles(wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    """(theta_i deg, theta_o deg, |phi| rad, cos_o)."""
    ci = min(1.0, max(wix * nx + wiy * ny + wiz * nz, 0.0))
    co = min(1.0, wox * nx + woy * ny + woz * nz)
    e1x, e1y, e1z, e2x, e2y, e2z = _frame(wix, wiy, wiz, nx, ny, nz)
    ph = abs(math.atan2(wox * e2x + woy * e2y + woz * e2z, wox * e1x + woy * e1y + woz * e1z))
    return math.acos(ci) * (180.0 / math.pi), math.acos(max(co, 0.0)) * (180.0 / math.pi), ph, co


@numba.njit(cache=True, fastmath=False)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    th_i, th_o, ph, co = _angles(wix, wiy, wiz, wox, woy, woz, nx, ny, nz)
    if co <= 0.0:
        return 0.0
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = _offsets(P, k)
    j, t = _bracket(P, k, oI, nI, th_i)
    f = (1.0 - t) * _f_node(P, k, j, th_o, ph * (180.0 / math.pi))
    if t > 0.0:
        f += t * _f_node(P, k, j + 1, th_o, ph * (180.0 / math.pi))
    return f


@numba.njit(cache=True, fastmath=False)
def _cell_index(P, k, row0, n, x):
    """Cell a with edges[a] <= x < edges[a + 1] (the last cell includes its upper edge)."""
    if x <= P[row0, k]:
        return 0
    if x >= P[row0 + n - 1, k]:
        return n - 2
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if P[row0 + mid, k] <= x:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True, fastmath=False)
def _q_node(P, k, i, th_o, ph, co):
    """Density per steradian of node i's sampler at (theta_o deg, |phi| rad)."""
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = _offsets(P, k)
    if P[oT + i, k] <= 0.0:
        return co * INV_PI
    a = _cell_index(P, k, oEo, nEo, th_o)
    b = _cell_index(P, k, oEp, nEp, ph)
    c = a * (nEp - 1) + b
    hi = P[oW + i * ncell + c, k]
    lo = P[oW + i * ncell + c - 1, k] if c > 0 else 0.0
    dmu = P[oEo + nEo + a, k] - P[oEo + nEo + a + 1, k]
    dph = P[oEp + b + 1, k] - P[oEp + b, k]
    if dmu <= 0.0 or dph <= 0.0:
        return 0.0
    return max(0.0, hi - lo) / (2.0 * dmu * dph)


@numba.njit(cache=True, fastmath=False)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    th_i, th_o, ph, co = _angles(wix, wiy, wiz, wox, woy, woz, nx, ny, nz)
    if co <= 0.0:
        return 0.0
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = _offsets(P, k)
    j, t = _bracket(P, k, oI, nI, th_i)
    q = (1.0 - t) * _q_node(P, k, j, th_o, ph, co)
    if t > 0.0:
        q += t * _q_node(P, k, j + 1, th_o, ph, co)
    return q


@numba.njit(cache=True, fastmath=False)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """(wox, woy, woz, weight, delta): a tabulated node's cell density (see the module docstring)."""
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = _offsets(P, k)
    ci = min(1.0, max(wix * nx + wiy * ny + wiz * nz, 0.0))
    j, t = _bracket(P, k, oI, nI, math.acos(ci) * (180.0 / math.pi))
    if u2 < 1.0 - t or t <= 0.0:
        i = j
        v = u2 / (1.0 - t) if t < 1.0 else u2
    else:
        i = j + 1
        v = (u2 - (1.0 - t)) / t
    v = min(max(v, 0.0), 1.0)
    e1x, e1y, e1z, e2x, e2y, e2z = _frame(wix, wiy, wiz, nx, ny, nz)
    if P[oT + i, k] <= 0.0:
        x, y, z = cosine_hemisphere(u0, u1)
    else:
        lo = -1
        hi = ncell - 1
        while hi - lo > 1:          # the first cell whose cumulative probability exceeds v
            mid = (lo + hi) // 2
            if P[oW + i * ncell + mid, k] <= v:
                lo = mid
            else:
                hi = mid
        c = hi
        while c > 0 and P[oW + i * ncell + c, k] <= P[oW + i * ncell + c - 1, k]:
            c -= 1                  # never an empty cell (only reachable through rounding)
        c0 = P[oW + i * ncell + c - 1, k] if c > 0 else 0.0
        c1 = P[oW + i * ncell + c, k]
        vv = (v - c0) / (c1 - c0) if c1 > c0 else 0.5
        a = c // (nEp - 1)
        b = c - a * (nEp - 1)
        mu_a = P[oEo + nEo + a, k]
        mu_b = P[oEo + nEo + a + 1, k]
        z = mu_b + u0 * (mu_a - mu_b)
        ph = P[oEp + b, k] + u1 * (P[oEp + b + 1, k] - P[oEp + b, k])
        if vv >= 0.5:
            ph = -ph
        s = math.sqrt(max(0.0, (1.0 - z) * (1.0 + z)))
        x = s * math.cos(ph)
        y = s * math.sin(ph)
    ox = x * e1x + y * e2x + z * nx
    oy = x * e1y + y * e2y + z * ny
    oz = x * e1z + y * e2z + z * nz
    pd = pdf(P, k, wix, wiy, wiz, ox, oy, oz, nx, ny, nz)
    if pd <= 0.0 or z <= 0.0:
        return -nx, -ny, -nz, 0.0, False
    f = eval(P, k, wix, wiy, wiz, ox, oy, oz, nx, ny, nz)
    return ox, oy, oz, f * (ox * nx + oy * ny + oz * nz) / pd, False


@numba.njit(cache=True, fastmath=False)
def albedo(P, k, cos_i):
    """(R, 0): the tabulated-node albedos interpolated linearly in theta_i (exact for the trilinear f)."""
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = _offsets(P, k)
    ci = min(1.0, max(cos_i, 0.0))
    j, t = _bracket(P, k, oI, nI, math.acos(ci) * (180.0 / math.pi))
    R = (1.0 - t) * P[oA + j, k]
    if t > 0.0:
        R += t * P[oA + j + 1, k]
    return R, 0.0


@numba.njit(cache=True, fastmath=False)
def direct_transmission(P, k, cos_i):
    return 0.0
