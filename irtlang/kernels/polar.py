"""Polarization: Stokes vectors, their reference frames and the Mueller matrices of interfaces and scattering.

A contract in a few lines (docs/tracer.md, "Polarization"):

* A polarized ray carries its flux w (the Stokes I, so every ledger row stays as it is) and the *normalized*
  Stokes parameters q = Q/I, u = U/I, v = V/I, with a reference vector e1 (unit, perpendicular to the direction
  d).  The frame (e1, e2 = d x e1, d) is right-handed.  With the field E = Re[(a1 e1 + a2 e2) exp(i(k.r - wt))]:
  I = |a1|^2 + |a2|^2, Q = |a1|^2 - |a2|^2 (Q > 0: E along e1), U = 2 Re(conj(a1) a2) (U > 0: E along
  (e1 + e2)/sqrt 2), V = 2 Im(conj(a1) a2) (V > 0: E turns from e1 toward e2, counter-clockwise seen facing the
  oncoming light: the IAU sign, with e1 as "north" and e2 as "east").
* An element with the Jones matrix diag(r1, r2) in the frame (e1, e2) has the Mueller matrix
  [[A, B, 0, 0], [B, A, 0, 0], [0, 0, x, -y], [0, 0, y, x]] with A = (|r1|^2 + |r2|^2)/2, B = (|r1|^2 - |r2|^2)/2,
  x + i y = conj(r1) r2 (``diattenuate``).
* Fresnel amplitudes in the frame e1 = s (normal to the plane of incidence), e2 = d x s before and after the
  interface: Born & Wolf's rs = (n1 cos i - n2 cos t) / (n1 cos i + n2 cos t), rp = (n2 cos i - n1 cos t) /
  (n2 cos i + n1 cos t); under total internal reflection cos t = +i sqrt(eta^2 sin^2 i - 1) (the evanescent wave
  decays), so |rs| = |rp| = 1 and conj(rs) rp = exp(i delta).  A metal (``COATING ... METAL n EXTINCTION k``) has the
  complex index N = n + i k in the same formulas (``metal_mueller``): diattenuation and retardance on reflection.
* Rayleigh scattering (with depolarization factor rho) in the frame e1 = the normal to the scattering plane,
  per steradian over 4 pi: P11 = D 3/4 (1 + c^2) + (1 - D), P12 = D 3/4 (1 - c^2), P22 = D 3/4 (1 + c^2),
  P33 = D 3/2 c, P44 = D D' 3/2 c, D = (1 - rho)/(1 + rho/2), D' = (1 - 2 rho)/(1 - rho) (Hansen & Travis 1974,
  eq. 2.16, with Q referred to the perpendicular direction, hence P12 > 0).  P11 is the scalar phase function
  the unpolarized tracer uses.
All functions are pure, inlined into the trace kernel when it is specialized for POLARIZATION.
"""
import cmath
import math

import numba

from .sampling import onb

TWO_PI = 2.0 * math.pi


@numba.njit(cache=True, inline="always")
def frame(dx, dy, dz, ex, ey, ez):
    """e made perpendicular to the unit direction d and unit; onb's first vector if e is (nearly) along d."""
    p = ex * dx + ey * dy + ez * dz
    ex -= p * dx
    ey -= p * dy
    ez -= p * dz
    m = math.sqrt(ex * ex + ey * ey + ez * ez)
    if not (m > 1e-6):
        t1x, t1y, t1z, _a, _b, _c = onb(dx, dy, dz)
        return t1x, t1y, t1z
    return ex / m, ey / m, ez / m


@numba.njit(cache=True, inline="always")
def perpendicular(dx, dy, dz, ax, ay, az, ex, ey, ez):
    """The unit normal d x a / |d x a| (the s direction of a plane holding d and a); e if d and a are parallel."""
    sx = dy * az - dz * ay
    sy = dz * ax - dx * az
    sz = dx * ay - dy * ax
    m = math.sqrt(sx * sx + sy * sy + sz * sz)
    if not (m > 1e-12):
        return ex, ey, ez
    return sx / m, sy / m, sz / m


@numba.njit(cache=True, inline="always")
def rotate(dx, dy, dz, ex, ey, ez, q, u, nx, ny, nz):
    """(q, u) referred to the frame e1 = n instead of e1 = e (both unit and perpendicular to d)."""
    c = ex * nx + ey * ny + ez * nz
    # e2 = d x e
    s = (dy * ez - dz * ey) * nx + (dz * ex - dx * ez) * ny + (dx * ey - dy * ex) * nz
    c2 = c * c - s * s
    s2 = 2.0 * c * s
    return q * c2 + u * s2, -q * s2 + u * c2


@numba.njit(cache=True, inline="always")
def diattenuate(q, u, v, A, B, x, y):
    """Apply [[A, B, 0, 0], [B, A, 0, 0], [0, 0, x, -y], [0, 0, y, x]] to (1, q, u, v): (I factor, q', u', v')."""
    i1 = A + B * q
    if not (i1 > 0.0):
        return 0.0, 0.0, 0.0, 0.0
    return i1, (B + A * q) / i1, (x * u - y * v) / i1, (y * u + x * v) / i1


@numba.njit(cache=True, inline="always")
def fresnel_mueller(cos_i, n1, n2):
    """Fresnel reflection and transmission as Mueller coefficients in the s frame:
    (Ar, Br, xr, yr, At, Bt, xt): reflection [[Ar, Br], [Br, Ar], [xr, -yr], [yr, xr]], transmission likewise
    with yt = 0 (transmitted flux, with the factor n2 cos t / (n1 cos i)); at and beyond the critical angle the
    transmission is 0 and the reflection a pure retarder (Ar = 1, Br = 0, xr + i yr = exp(i delta))."""
    c = min(abs(cos_i), 1.0)
    sin2 = (1.0 - c) * (1.0 + c)
    eta = n1 / n2
    sin2t = eta * eta * sin2
    if c == 0.0:
        return 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0
    if sin2t >= 1.0:
        g = math.sqrt(sin2t - 1.0)
        rs = complex(n1 * c, -n2 * g) / complex(n1 * c, n2 * g)
        rp = complex(n2 * c, -n1 * g) / complex(n2 * c, n1 * g)
        z = rs.conjugate() * rp
        return 1.0, 0.0, z.real, z.imag, 0.0, 0.0, 0.0
    ct = math.sqrt(1.0 - sin2t)
    a = n1 * c
    b = n2 * ct
    a2 = n2 * c
    b2 = n1 * ct
    rs = (a - b) / (a + b)
    rp = (a2 - b2) / (a2 + b2)
    ts = 2.0 * a / (a + b)
    tp = 2.0 * a / (a2 + b2)
    et = b / a
    Rs = rs * rs
    Rp = rp * rp
    Ts = et * ts * ts
    Tp = et * tp * tp
    return 0.5 * (Rs + Rp), 0.5 * (Rs - Rp), rs * rp, 0.0, 0.5 * (Ts + Tp), 0.5 * (Ts - Tp), et * ts * tp


@numba.njit(cache=True, inline="always")
def metal_mueller(cos_i, n1, n, k):
    """Reflection by an absorbing medium of complex index N = n + i k (a metal; k >= 0, the wave decays as
    exp(-k w z / c) with the field's exp(i(k.r - wt))) from a medium of real index n1, as Mueller coefficients
    in the s frame: (Ar, Br, xr, yr), nothing transmitted (it is absorbed within a skin depth).  Born & Wolf's
    rs = (n1 c - W) / (n1 c + W), rp = (N^2 c - n1 W) / (N^2 c + n1 W) with W = N cos t = sqrt(N^2 - n1^2 s^2),
    the root with Im W >= 0; at normal incidence rp = -rs, as for the ideal mirror (Jones diag(r, -r))."""
    c = min(abs(cos_i), 1.0)
    sin2 = (1.0 - c) * (1.0 + c)
    N2 = complex(n * n - k * k, 2.0 * n * k)
    W = cmath.sqrt(N2 - n1 * n1 * sin2)      # Im >= 0: the principal root, as Im N^2 = 2 n k >= 0
    a = n1 * c
    rs = (a - W) / (a + W)
    rp = (N2 * c - n1 * W) / (N2 * c + n1 * W)
    Rs = rs.real * rs.real + rs.imag * rs.imag
    Rp = rp.real * rp.real + rp.imag * rp.imag
    z = rs.conjugate() * rp
    return 0.5 * (Rs + Rp), 0.5 * (Rs - Rp), z.real, z.imag


@numba.njit(cache=True, inline="always")
def rayleigh_mueller(mu, rho):
    """(P11, P12, P22, P33, P44) of Rayleigh scattering at cos(angle) mu, depolarization factor rho, per
    steradian (P11 integrates to 1 over the sphere)."""
    D = (1.0 - rho) / (1.0 + 0.5 * rho)
    D2 = (1.0 - 2.0 * rho) / (1.0 - rho) if rho < 1.0 else 0.0
    k = 1.0 / (4.0 * math.pi)
    c2 = mu * mu
    p11 = (D * 0.75 * (1.0 + c2) + (1.0 - D)) * k
    p12 = D * 0.75 * (1.0 - c2) * k
    p22 = D * 0.75 * (1.0 + c2) * k
    p33 = D * 1.5 * mu * k
    return p11, p12, p22, p33, D2 * p33


@numba.njit(cache=True, inline="always")
def scatter_stokes(qs, us, v, p11, p12, p22, p33, p44):
    """Stokes after scattering, from (1, qs, us, v) referred to the scattering plane's normal: (I factor per
    steradian, q', u', v') in the same frame."""
    i1 = p11 + p12 * qs
    if not (i1 > 0.0):
        return 0.0, 0.0, 0.0, 0.0
    return i1, (p12 + p22 * qs) / i1, p33 * us / i1, p44 * v / i1


@numba.njit(cache=True, inline="always")
def azimuth_angle(A, u):
    """chi in [0, 2 pi) with density (1 - A cos 2 chi) / (2 pi), |A| <= 1: the inverse of its CDF
    (chi - A/2 sin 2 chi) / (2 pi) by Newton's method kept inside a shrinking bracket."""
    target = TWO_PI * u
    lo = 0.0
    hi = TWO_PI
    x = target
    for _ in range(60):
        f = x - 0.5 * A * math.sin(2.0 * x) - target
        if f > 0.0:
            hi = x
        else:
            lo = x
        df = 1.0 - A * math.cos(2.0 * x)
        step = f / df if df > 1e-12 else 2.0 * (hi - lo)
        xn = x - step
        if not (xn > lo and xn < hi):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) < 1e-14:
            x = xn
            break
        x = xn
    return x
