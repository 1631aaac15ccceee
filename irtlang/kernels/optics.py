"""Interface optics: Fresnel reflectance, Snell refraction, mirror reflection, Beer-Lambert attenuation.

Conventions
-----------
* Directions and normals need not be unit vectors on input; every direction returned is a unit vector.
* ``n1`` is the index of the medium the ray comes from, ``n2`` the index beyond the interface.
* The normal may point either way: ``refract`` and ``reflect`` orient it against the incoming ray
  internally (``n . d < 0``), so the caller can pass the surface's geometric normal as is.
* ``cos_i`` for ``fresnel_*`` is the cosine of the angle of incidence in medium n1; its sign is ignored.
* ``sin^2`` of the angle of incidence is computed from the cross product ``|d x n|^2 / (|d|^2 |n|^2)``, which
  keeps full relative precision near normal incidence; ``cos`` from the dot product, full precision at
  grazing incidence.
* Total internal reflection (TIR) happens iff ``(n1/n2)^2 sin^2(theta_i) > 1``; ``refract`` then returns
  the mirror direction with ``tir = True`` and ``fresnel_unpolarized`` returns exactly 1.
"""
import math

import numba
import numpy as np

from .geometry import unit_in_range

__all__ = ["fresnel_rs_rp", "fresnel_unpolarized", "refract", "reflect", "beer_transmission"]


@numba.njit(cache=True, fastmath=False)
def _fresnel_core(cos_i, sin2_i, n1, n2):
    """(Rs, Rp) from cos and sin^2 of the incidence angle; (1, 1) under TIR."""
    eta = n1 / n2
    sin2_t = eta * eta * sin2_i
    if sin2_t >= 1.0:
        return 1.0, 1.0
    cos_t = math.sqrt((1.0 - sin2_t))
    a = n1 * cos_i
    b = n2 * cos_t
    rs = (a - b) / (a + b)
    a2 = n2 * cos_i
    b2 = n1 * cos_t
    rp = (a2 - b2) / (a2 + b2)
    return rs * rs, rp * rp


@numba.njit(cache=True, fastmath=False)
def fresnel_rs_rp(cos_i, n1, n2):
    """Fresnel power reflectances (Rs, Rp) for |cos_i| in medium n1 towards n2; (1, 1) under TIR."""
    c = min(abs(cos_i), 1.0)
    sin2 = (1.0 - c) * (1.0 + c)
    if c == 0.0:
        return 1.0, 1.0  # exact grazing incidence
    return _fresnel_core(c, sin2, n1, n2)


@numba.njit(cache=True, fastmath=False)
def fresnel_unpolarized(cos_i, n1, n2):
    """Unpolarized Fresnel reflectance R = (Rs + Rp) / 2 (exact formulas); 1 under TIR."""
    rs, rp = fresnel_rs_rp(cos_i, n1, n2)
    return 0.5 * (rs + rp)


@numba.njit(cache=True, fastmath=False)
def _unit(x, y, z):
    ok, ux, uy, uz = unit_in_range(x, y, z)
    if ok:
        return ux, uy, uz
    m = max(abs(x), abs(y), abs(z))
    if m == 0.0:
        return 0.0, 0.0, 0.0
    x /= m
    y /= m
    z /= m
    n = math.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


@numba.njit(cache=True, fastmath=False)
def reflect(dx, dy, dz, nx, ny, nz):
    """Mirror direction d - 2 (d.n) n (unit), for either orientation of n."""
    dx, dy, dz = _unit(dx, dy, dz)
    nx, ny, nz = _unit(nx, ny, nz)
    dn = dx * nx + dy * ny + dz * nz
    rx = dx - 2.0 * dn * nx
    ry = dy - 2.0 * dn * ny
    rz = dz - 2.0 * dn * nz
    return _unit(rx, ry, rz)


@numba.njit(cache=True, fastmath=False)
def refract(dx, dy, dz, nx, ny, nz, n1, n2):
    """Snell refraction from n1 into n2: (tx, ty, tz, tir). Under TIR, (t) is the mirror direction.

    Vector form with n oriented against d (cos_i = -d.n >= 0) and eta = n1 / n2:
    t = eta d + (eta cos_i - cos_t) n, cos_t = sqrt(1 - eta^2 sin^2_i).
    """
    dx, dy, dz = _unit(dx, dy, dz)
    nx, ny, nz = _unit(nx, ny, nz)
    cos_i = -(dx * nx + dy * ny + dz * nz)
    if cos_i < 0.0:
        nx = -nx
        ny = -ny
        nz = -nz
        cos_i = -cos_i
    cx = dy * nz - dz * ny
    cy = dz * nx - dx * nz
    cz = dx * ny - dy * nx
    sin2_i = min(cx * cx + cy * cy + cz * cz, 1.0)
    eta = n1 / n2
    sin2_t = eta * eta * sin2_i
    if sin2_t > 1.0:
        rx = dx + 2.0 * cos_i * nx
        ry = dy + 2.0 * cos_i * ny
        rz = dz + 2.0 * cos_i * nz
        rx, ry, rz = _unit(rx, ry, rz)
        return rx, ry, rz, True
    cos_t = math.sqrt(1.0 - sin2_t)
    f = eta * cos_i - cos_t
    tx = eta * dx + f * nx
    ty = eta * dy + f * ny
    tz = eta * dz + f * nz
    tx, ty, tz = _unit(tx, ty, tz)
    return tx, ty, tz, False


@numba.njit(cache=True, fastmath=False)
def beer_transmission(alpha, length):
    """exp(-alpha * length) for alpha >= 0 [1/length unit], length >= 0; 1 if alpha == 0, 0 if the
    optical depth is infinite. Negative optical depths (bad input) are clamped to 0."""
    if alpha == 0.0 or length == 0.0:
        return 1.0
    tau = alpha * length
    if not (tau > 0.0):
        return 1.0
    if tau == np.inf:
        return 0.0
    return math.exp(-tau)
