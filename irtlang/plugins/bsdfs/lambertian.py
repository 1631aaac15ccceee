"""LAMBERTIAN r [TRANSMIT t]

An ideal diffuser: BRDF = r / pi on the side the light comes from, BTDF = t / pi on the other; A = 1 - r - t.

| parameter | unit | meaning |
|---|---|---|
| r | 1, per line | hemispherical reflectance |
| TRANSMIT t | 1, per line | hemispherical transmittance (default 0) |

Kernel conventions (shared by every BSDF plugin; see irtlang/plugins/bsdfs/__init__.py): ``P`` is the
model's packed (N_PARAMS, L) block, ``k`` the line; ``wi`` points from the surface toward the light, ``wo``
toward the viewer, ``n`` is the unit normal on the side of ``wi`` (wi . n > 0); wo . n > 0 is reflection,
< 0 transmission.
"""
import math

import numba
import numpy as np

from ...core.diagnostics import error
from ...lang.spec import Clause, Form, PL, unit_interval
from ...kernels.sampling import cosine_hemisphere, onb

KIND = "LAMBERTIAN"
FORM = Form((PL("reflect", check=unit_interval),),
            (Clause("TRANSMIT", (PL("transmit", check=unit_interval),), doc="diffuse transmittance"),))
EXAMPLE = "MODEL paint LAMBERTIAN 0.5 TRANSMIT 0"
N_PARAMS = 2
INV_PI = 1.0 / math.pi


def build(b, ctx) -> dict:
    r = b["reflect"].values
    t = b["transmit"].values if "transmit" in b else (0.0,) * len(r)
    for i, (x, y) in enumerate(zip(r, t)):
        if x + y > 1.0 + 1e-12:
            raise error(b.span, f"LAMBERTIAN reflect + transmit = {x + y:g} > 1 on line {i + 1}")
    return {"reflect": r, "transmit": t}


def transmits(params) -> bool:
    return any(x > 0 for x in params["transmit"])


def pack(params, n_lines: int) -> np.ndarray:
    return np.array([np.broadcast_to(params["reflect"], (n_lines,)), np.broadcast_to(params["transmit"], (n_lines,))],
                    dtype=np.float64)


@numba.njit(cache=True)
def eval(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    c = wox * nx + woy * ny + woz * nz
    return (P[0, k] if c > 0.0 else P[1, k]) * INV_PI


@numba.njit(cache=True)
def pdf(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    r = P[0, k]
    t = P[1, k]
    if r + t <= 0.0:
        return 0.0
    c = wox * nx + woy * ny + woz * nz
    return (r if c > 0.0 else t) / (r + t) * abs(c) * INV_PI


@numba.njit(cache=True)
def sample(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    """(wox, woy, woz, weight, delta): weight = f |cos_o| / pdf; here exactly r + t."""
    r = P[0, k]
    t = P[1, k]
    if r + t <= 0.0:
        return 0.0, 0.0, 1.0, 0.0, False
    x, y, z = cosine_hemisphere(u0, u1)
    if u2 * (r + t) >= r:
        z = -z
    t1x, t1y, t1z, t2x, t2y, t2z = onb(nx, ny, nz)
    return (x * t1x + y * t2x + z * nx, x * t1y + y * t2y + z * ny, x * t1z + y * t2z + z * nz, r + t, False)


@numba.njit(cache=True)
def albedo(P, k, cos_i):
    """(R, T): directional-hemispherical reflectance and transmittance."""
    return P[0, k], P[1, k]


@numba.njit(cache=True)
def direct_transmission(P, k, cos_i):
    """Share passing straight through (for rays aimed at a TOWARD target): none for a diffuser."""
    return 0.0
