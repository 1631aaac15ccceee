"""Direction and point sampling with their densities.

Conventions
-----------
* Inputs ``u0, u1, u`` are uniform numbers in the open interval (0, 1) (see ``rng.uniform2``); values
  0 and 1 are also accepted and never produce NaN.
* Directions are sampled in a LOCAL frame whose +z is the reference axis (surface normal, cone axis, incoming
  direction for Henyey-Greenstein) and returned as unit vectors ``(x, y, z)``. ``to_frame`` / ``onb`` map
  them to world coordinates around any axis.
* Densities are per steradian for directions (``*_pdf``) and per unit area for the disk; polar angle theta
  is measured from +z, azimuth phi = 2 pi u1 (except the concentric disk map, which warps the azimuth).
* Lambertian in a cone of half-angle t (``lambert_cone``): density cos(theta) / (pi sin^2 t) for
  theta <= t; the full hemisphere's Lambertian flux share inside the cone is sin^2 t (ORACLES.md).
* Henyey-Greenstein: ``p(mu) = (1 - g^2) / (4 pi (1 + g^2 - 2 g mu)^1.5)`` per steradian, mean cosine g.
  ``hg_sample`` evaluates the inverse CDF of ORACLES.md, ``mu = [1 + g^2 - ((1 - g^2)/(1 - g + 2 g u))^2]/(2 g)``,
  in the algebraically equal form ``mu = w + 2 g u (1 - u) (3 - g^2 + 2 g w) / (1 + g w)^2`` with w = 2u - 1
  (expand both over (1 + g w)^2): no division by g, no cancellation as g -> 0 (it tends to the isotropic
  mu = w), and exactly -1 and 1 at u = 0 and 1.
* ``systematic_keep(total, p, u0)``: systematic sampling of a sequence of Russian-roulette decisions
  (survival probabilities p_1, p_2, ... < 1, drawn against ONE uniform u0 per sequence): candidate k survives when
  the interval [P_k, P_k + p_k), P_k = p_1 + ... + p_(k-1), holds a point u0 + m (m an integer).  Over u0 each
  candidate survives with probability exactly p_k (the interval is p_k long, mod 1), as with an independent
  draw, but the number of survivors among any run of candidates is floor or ceil of their summed p: the
  roulette's count no longer fluctuates.  Unbiased when which candidates arise, and their p, do not depend on
  u0.  Returns (kept, P_k + p_k).
* ``onb(nx, ny, nz)``: the branchless orthonormal basis of Duff et al. (JCGT 6(1), 2017), ``(t1, t2, n)``
  right-handed (t1 x t2 = n); the normal is normalised first.
"""
import math

import numba
import numpy as np

from .geometry import unit_in_range

__all__ = [
    "onb",
    "to_frame",
    "uniform_disk",
    "uniform_disk_pdf",
    "cosine_hemisphere",
    "cosine_hemisphere_pdf",
    "uniform_cone",
    "uniform_cone_pdf",
    "lambert_cone",
    "lambert_cone_pdf",
    "uniform_sphere",
    "uniform_sphere_pdf",
    "hg_sample",
    "hg_pdf",
    "hg_direction",
    "systematic_keep",
]

PI = math.pi
TWO_PI = 2.0 * math.pi
INV_PI = 1.0 / math.pi
INV_4PI = 0.25 / math.pi


@numba.njit(cache=True, fastmath=False)
def _unit(x, y, z):
    ok, ux, uy, uz = unit_in_range(x, y, z)
    if ok:
        return ux, uy, uz
    m = max(abs(x), abs(y), abs(z))
    if m == 0.0 or not math.isfinite(m):
        return 0.0, 0.0, 1.0
    x /= m
    y /= m
    z /= m
    n = math.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


@numba.njit(cache=True, fastmath=False)
def onb(nx, ny, nz):
    """Orthonormal basis (t1x, t1y, t1z, t2x, t2y, t2z) around n (Duff et al. 2017, branchless)."""
    nx, ny, nz = _unit(nx, ny, nz)
    sign = math.copysign(1.0, nz)
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    return (1.0 + sign * nx * nx * a, sign * b, -sign * nx,
            b, sign + ny * ny * a, -ny)


@numba.njit(cache=True, fastmath=False)
def to_frame(x, y, z, nx, ny, nz):
    """Local (x, y, z) with +z = n -> world: x t1 + y t2 + z n (n normalised)."""
    t1x, t1y, t1z, t2x, t2y, t2z = onb(nx, ny, nz)
    nx, ny, nz = _unit(nx, ny, nz)
    return (x * t1x + y * t2x + z * nx,
            x * t1y + y * t2y + z * ny,
            x * t1z + y * t2z + z * nz)


@numba.njit(cache=True, fastmath=False)
def uniform_disk(u0, u1):
    """Concentric map of the unit square to the unit disk (Shirley & Chiu 1997): (x, y)."""
    a = 2.0 * u0 - 1.0
    b = 2.0 * u1 - 1.0
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0
    if abs(a) > abs(b):
        r = a
        phi = (PI / 4.0) * (b / a)
    else:
        r = b
        phi = (PI / 2.0) - (PI / 4.0) * (a / b)
    return r * math.cos(phi), r * math.sin(phi)


@numba.njit(cache=True, fastmath=False)
def uniform_disk_pdf():
    """Area density of uniform_disk on the unit disk: 1 / pi."""
    return INV_PI


@numba.njit(cache=True, fastmath=False)
def cosine_hemisphere(u0, u1):
    """Lambertian (cosine-weighted) direction about +z: (x, y, z), z = cos(theta) >= 0."""
    x, y = uniform_disk(u0, u1)
    r2 = x * x + y * y
    z = math.sqrt(max(0.0, (1.0 - r2)))
    return x, y, z


@numba.njit(cache=True, fastmath=False)
def cosine_hemisphere_pdf(cos_t):
    """cos(theta) / pi for cos_t >= 0, else 0."""
    return cos_t * INV_PI if cos_t > 0.0 else 0.0


@numba.njit(cache=True, fastmath=False)
def uniform_cone(u0, u1, cos_max):
    """Uniform direction in the cone theta <= acos(cos_max) about +z: (x, y, z).

    With v = u0 (1 - cos_max): cos = 1 - v, sin^2 = v (2 - v) (no cancellation for small cones).
    """
    v = u0 * (1.0 - cos_max)
    z = 1.0 - v
    s = math.sqrt(max(0.0, v * (2.0 - v)))
    phi = TWO_PI * u1
    return s * math.cos(phi), s * math.sin(phi), z


@numba.njit(cache=True, fastmath=False)
def uniform_cone_pdf(cos_max):
    """1 / (2 pi (1 - cos_max)) inside the cone."""
    return 1.0 / (TWO_PI * (1.0 - cos_max))


@numba.njit(cache=True, fastmath=False)
def lambert_cone(u0, u1, sin_max):
    """Lambertian direction restricted to theta <= asin(sin_max) about +z: (x, y, z).

    sin^2(theta) is uniform on [0, sin_max^2]: the unit-disk sample scaled by sin_max, lifted to the
    hemisphere.
    """
    x, y = uniform_disk(u0, u1)
    x *= sin_max
    y *= sin_max
    r = math.hypot(x, y)
    z = math.sqrt(max(0.0, (1.0 - r) * (1.0 + r)))
    return x, y, z


@numba.njit(cache=True, fastmath=False)
def lambert_cone_pdf(cos_t, sin_max):
    """cos(theta) / (pi sin_max^2) inside the cone (caller checks theta <= asin(sin_max))."""
    return cos_t * INV_PI / (sin_max * sin_max) if cos_t > 0.0 else 0.0


@numba.njit(cache=True, fastmath=False)
def uniform_sphere(u0, u1):
    """Uniform direction on the unit sphere: (x, y, z), z = 1 - 2 u0."""
    z = 1.0 - 2.0 * u0
    s = 2.0 * math.sqrt(max(0.0, u0 * (1.0 - u0)))
    phi = TWO_PI * u1
    return s * math.cos(phi), s * math.sin(phi), z


@numba.njit(cache=True, fastmath=False)
def uniform_sphere_pdf():
    """1 / (4 pi)."""
    return INV_4PI


@numba.njit(cache=True, fastmath=False)
def hg_sample(u, g):
    """Cosine mu of the Henyey-Greenstein scattering angle for uniform u, asymmetry g (|g| <= 1)."""
    w = 2.0 * u - 1.0
    gw = 1.0 + g * w
    if gw == 0.0:  # only g = +/-1 with u at the far end: a delta in the forward/backward direction
        return 1.0 if g > 0.0 else -1.0
    mu = w + 2.0 * g * u * (1.0 - u) * (3.0 - g * g + 2.0 * g * w) / (gw * gw)
    return min(1.0, max(-1.0, mu))


@numba.njit(cache=True, fastmath=False)
def hg_pdf(mu, g):
    """Henyey-Greenstein density per steradian: (1 - g^2) / (4 pi (1 + g^2 - 2 g mu)^1.5)."""
    den = 1.0 + g * g - 2.0 * g * mu
    if den <= 0.0:
        return np.inf
    return (1.0 - g * g) * INV_4PI / (den * math.sqrt(den))


@numba.njit(cache=True, fastmath=False)
def hg_direction(u0, u1, g, dx, dy, dz):
    """Scattered unit direction about the incoming d: mu from hg_sample(u0, g), azimuth 2 pi u1."""
    mu = hg_sample(u0, g)
    s = math.sqrt(max(0.0, (1.0 - mu) * (1.0 + mu)))
    phi = TWO_PI * u1
    x, y, z = to_frame(s * math.cos(phi), s * math.sin(phi), mu, dx, dy, dz)
    return _unit(x, y, z)


@numba.njit(cache=True, fastmath=False)
def systematic_keep(total, p, u0):
    """Systematic roulette (module docstring): whether the candidate of survival probability p (0 <= p < 1), after
    candidates whose probabilities sum to total, survives against the sequence's one uniform u0; and the new
    total."""
    after = total + p
    return math.floor(after - u0) > math.floor(total - u0), after
