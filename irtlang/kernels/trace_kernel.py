"""The non-sequential Monte Carlo trace kernel (template).

``irtlang.compile.specialize`` writes a copy of this module with the ``F_*`` feature flags set for one
scene's feature set and imports it; Numba compiles the flags as constants, so a mirrors-only scene carries
no refraction, mesh or record code (DESIGN.md, "Skip what a scene doesn't need").  Imported as it is, all
features are on.

Conventions
-----------
* Positions are double-double world coordinates (hi, lo) when ``F_PRECISE``; a surface sees the ray in its
  own frame, computed as R^T ((p_hi - T_hi) + (p_lo - T_lo)) so an instrument 0.18 AU away is traced at
  full precision.  Directions are plain doubles (full relative precision everywhere).
* Random numbers: Philox4x32-10 keyed by the seed, counter (ray id, event, dim): a ray's path does not
  depend on the thread count, the batch size or the order rays are traced.
* Tallies are deterministic: rays are traced in chunks of ``CHUNK`` consecutive ids; each chunk has its own
  ledger and its own deposit list, and chunks are reduced in id order after the parallel loop.
* Interfaces choose reflection or transmission by Monte Carlo with probability R / (R + T) and keep the
  weight w (R + T): the absorbed share w A is booked exactly, so the ledger closes per event.
* Scattering: an object with SCATTER MODEL m scatters by the model's own sampling (``RAYS n`` splits into n
  paths).  With ``TOWARD target`` it also sends n rays toward the target's bounding sphere (next-event
  estimation, exact weights f |cos| Omega / n), and the continuing path no longer counts when it arrives at
  the target directly (straight through transmissions), since those rays already estimate that.  The
  IMPORTANCE ledger row books minus the flux sent toward targets plus the direct arrivals they replace, so
  the ledger still closes exactly; rays sent toward a target that miss it end where they end (ESCAPED, ...).
* Russian roulette below ``halt`` x the starting weight: survival probability w / (halt w0), survivors get
  halt w0.  The booked HALTED flux is the killed weight minus the survivors' gain, so the ledger closes
  exactly while the estimate stays unbiased.
"""
import math

import numba
import numpy as np

from .geometry import in_aperture, two_prod
from .layout import (AP_NONE, C_ABS, C_INC, C_REF, C_SCA, C_TRA, DIR_COLLIMATED,
                     DIR_LAMBERT, EV_A, EV_R, EV_S, EV_T, FL_ESCAPED, FL_HALTED, FL_LOST,
                     FL_REFLECTED, FL_SCATTERED, FL_TRANSMITTED, IF_ABSORB, IF_FRESNEL, IF_METAL,
                     IF_POLARIZER, IF_REFLECT, IF_RETARDER, IF_SPLIT, PHASE_HG, PHASE_RAYLEIGH,
                     SAMPLE_SPECTRAL, SF_AP, SP_CORRELATED, SP_DIRECTIONS, SP_GUIDE, SP_GUIDE_ROW, SP_GUIDE_T,
                     SP_HERO, SP_HERO_OFF, SP_PAIRED, SP_PILOT, SF_BS, SF_CL, SF_HOLE, SF_R, SF_SIZE, SF_TH, SF_TL, SI_APK,
                     SI_AXIS, SI_CLEND, SI_FAM, SI_FNEXT, SI_FOUT, SI_FPREV, SI_KIND, SI_OBJ, SPEC_CLASS_MAP,
                     SPEC_FRACTION_MAP, SPEC_GATE, SPEC_MODEL)
from .layout import Detectors, Media, Scatter, Sources, Surfaces
from .optics import fresnel_unpolarized, refract
from .polar import (azimuth_angle, diattenuate, frame, fresnel_mueller, metal_mueller, perpendicular, rayleigh_mueller,
                    rotate, scatter_stokes)
from .rng import uniform2
from .sampling import onb, systematic_keep

# ---- features (rewritten by irtlang.compile.specialize) ----
F_CONIC = True
F_QUADRIC = True
F_MESH = True
F_REFRACT = True
F_ABSORB_MEDIA = True
F_PRECISE = True
F_RECORDS = True
F_HISTORY = True
F_SCATTER = True
F_MAPS = True
F_VOLUME = True
F_IMPORTANCE = True
F_SHELLS = True
F_POLAR = True
F_CAMERA = True
F_HERO = True
# ---- end of features ----
# F_HERO: HERO K (a camera's hero wavelengths), only in a kernel whose scene has a camera source with HERO
# (compile.pack; a run's image and spectrum traces with HERO share one), switched per source at run time.  Its
# code is about a third of a camera kernel's first compile (camera_cassegrain.inr: 34 s without it, 52 s with it)

CHUNK = 1024
SMAX = 256          # pending paths per source ray (splitting, rays toward a target)
POOL = SMAX         # the stack's row after the last entry: the source ray's next-event roulette (_nee_roulette):
                    # [POOL, 0] the survival probabilities summed so far, [POOL, 1] the ray's one uniform
MAX_PATHS = 4096    # paths per source ray: past this, RAYS n no longer splits (still unbiased); without a
                    # bound, k scatterings make n^k paths and a closed scattering scene never ends
NEE_STRAIGHT_DN = 1e-3   # rays sent toward a target cross index steps smaller than this without bending
SW = 20             # stack entry: ph(3) pl(3) d(3) w w0 ev excl nee path flags jlast opl sx sy, [q u v e1(3)], history
SWP = SW + 6 if F_POLAR else SW     # where the history starts: after the Stokes state of a polarized trace
EPS_SELF = 1e-9
# HERO K (hero wavelengths): the rows of a chunk's scratch array HV (rows x K): per line t of the ray's block, its
# weight a_t = f_t / p_hero and density ratio s_t = p_t / p_hero (the ray's state, on the stack too); a hit's R,
# T, diffuse, slab keep and Fresnel R per line; the base and candidate weights of rays toward a target; the
# source ray's accumulated deposit per line; the block's lines; scratch; a slab's direct beam and delta probability
# at the hit (-1: not a slab's; _hero_shares)
# (the rows after the stack's POOL row: Numba cannot inline a helper of more than 30 arguments, so the hero state
# rides in the stack, with K and the hero's place in the POOL row's columns 2 and 3)
H_A, H_S, H_R, H_T, H_D, H_K, H_RF, H_B, H_C, H_ACC, H_L, H_F, H_P, H_E, H_Q = range(SMAX + 1, SMAX + 16)
N_HERO_ROWS = 15
# A HERO kernel (not polarized) takes every hit's shares from _hero_shares, a one-line ray's as a block of one,
# so that _specular, _nee_map_mix and _model_share are compiled into its event loop once, not twice
HERO_SHARES = F_HERO and not F_POLAR
SIDE_COS = 1e-7     # _nearest: a departure from a nested shell closer than this (cosine) to its tangent plane is
                    # grazing: its side is not trusted (its other root on that shell is then within ~2 R 1e-7)
TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------------- double-double
@numba.njit(cache=True, inline="always")
def _two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@numba.njit(cache=True, inline="always")
def _adv(h, l, t, d):
    """(h + l) + t d in double-double."""
    if not F_PRECISE:
        return h + t * d, 0.0
    p, pe = two_prod(t, d)
    s, se = _two_sum(h, p)
    lo = l + pe + se
    hi = s + lo
    return hi, lo - (hi - s)


@numba.njit(cache=True, inline="always")
def _sub(h, l, th, tl):
    """(h + l) - (th + tl) as one double (the offset is small near the surface: no loss)."""
    if not F_PRECISE:
        return h - th
    s, e = _two_sum(h, -th)
    return s + (e + (l - tl))


@numba.njit(cache=True, inline="always")
def _local(phx, phy, phz, plx, ply, plz, dx, dy, dz, f, si, j):
    qx = _sub(phx, plx, f[j, SF_TH], f[j, SF_TL])
    qy = _sub(phy, ply, f[j, SF_TH + 1], f[j, SF_TL + 1])
    qz = _sub(phz, plz, f[j, SF_TH + 2], f[j, SF_TL + 2])
    if si[j, SI_AXIS] == 1:
        # an axis-aligned surface (R = I): the rotation would only multiply by 1 and add zeros
        return qx, qy, qz, dx, dy, dz
    r = SF_R
    return (f[j, r] * qx + f[j, r + 3] * qy + f[j, r + 6] * qz, f[j, r + 1] * qx + f[j, r + 4] * qy + f[j, r + 7] * qz,
            f[j, r + 2] * qx + f[j, r + 5] * qy + f[j, r + 8] * qz, f[j, r] * dx + f[j, r + 3] * dy + f[j, r + 6] * dz,
            f[j, r + 1] * dx + f[j, r + 4] * dy + f[j, r + 7] * dz, f[j, r + 2] * dx + f[j, r + 5] * dy + f[j, r + 8] * dz)


@numba.njit(cache=True, inline="always")
def _rot(f, si, j, x, y, z):
    if si[j, SI_AXIS] == 1:
        return x, y, z
    r = SF_R
    return (f[j, r] * x + f[j, r + 1] * y + f[j, r + 2] * z, f[j, r + 3] * x + f[j, r + 4] * y + f[j, r + 5] * z,
            f[j, r + 6] * x + f[j, r + 7] * y + f[j, r + 8] * z)


@numba.njit(cache=True, inline="always")
def _aperture_ok(kind, f, j, x, y):
    if kind == AP_NONE:
        return True
    return in_aperture(kind, f[j, SF_AP], f[j, SF_AP + 1], x, y)


# ---------------------------------------------------------------------------------------------- intersection
@numba.njit(cache=True, inline="always")
def _nearest(phx, phy, phz, plx, ply, plz, dx, dy, dz, f, si, S, jlast):
    """Nearest surface hit: (t, surface, lx, ly, lz, face).  On `jlast`, the surface the ray has just
    left, the root nearest 0 (the departure point itself) is dropped first: at grazing departure the origin's
    rounding divided by the grazing angle can push that root past any tolerance."""
    best_t = np.inf
    best_j = -1
    blx = 0.0
    bly = 0.0
    blz = 0.0
    bface = -1
    fam_last = si[jlast, SI_FAM] if F_SHELLS and jlast >= 0 else -1
    # after a crossing of shell i of a family, only its neighbours i - 1, i, i + 1 can be met next (pack.shell_families)
    nb_lo = si[jlast, SI_FPREV] if fam_last >= 0 else -1
    nb_hi = si[jlast, SI_FNEXT] if fam_last >= 0 else -1
    nb_at = jlast
    if F_SHELLS and fam_last >= 0:
        # and which of them, from the side the ray leaves shell i to: outward (the shell's convex body behind
        # it) only i + 1; inward only i again or i - 1 (i + 1 lies beyond shell i).  A grazing departure
        # (|cos| <= SIDE_COS) keeps all three.  One normal instead of one or two intersections (-2: no surface)
        qx, qy, qz, qdx, qdy, qdz = _local(phx, phy, phz, plx, ply, plz, dx, dy, dz, f, si, jlast)
        snx, sny, snz = _surface_normal(si[jlast, SI_KIND], f, si, S, jlast, qx, qy, qz, -1)
        cs = snx * qdx + sny * qdy + snz * qdz
        if cs > SIDE_COS:
            nb_lo = -2
            nb_at = -2
        elif cs < -SIDE_COS:
            nb_hi = -2
    # a while loop that jumps over a skipped run (a for loop stepping through it cost about a tenth of an Earth
    # frame's trace: its ~60 surfaces, most of them skipped on every segment)
    nsurf = si.shape[0]
    jn = 0
    while jn < nsurf:
        j = jn
        jn += 1
        ce = si[j, SI_CLEND]
        if ce > j:
            # the first surface of a cluster (compile.pack.surface_clusters): one world bounding sphere for
            # the run; a ray that misses it, or meets it beyond the nearest hit so far, skips the whole run
            cr = f[j, SF_CL + 3]
            qx = (phx - f[j, SF_CL]) + plx
            qy = (phy - f[j, SF_CL + 1]) + ply
            qz = (phz - f[j, SF_CL + 2]) + plz
            bb = qx * dx + qy * dy + qz * dz
            cc = qx * qx + qy * qy + qz * qz - cr * cr
            if cc > 0.0:
                if bb > 0.0:
                    jn = ce
                    continue
                ex = qx - bb * dx
                ey = qy - bb * dy
                ez = qz - bb * dz
                disc = cr * cr - (ex * ex + ey * ey + ez * ez)
                if disc < 0.0 or (best_t < np.inf and -bb - math.sqrt(disc) > best_t):
                    jn = ce
                    continue
        if F_SHELLS and fam_last >= 0 and si[j, SI_FAM] == fam_last and j != nb_at and j != nb_lo and j != nb_hi:
            # a nested shell beyond the neighbours of the one just crossed: jump to the next neighbour or to the
            # first surface after this run of the family (the order of the tests, and so any tie, is unchanged)
            nxt = si[j, SI_FOUT]
            if nb_lo > j and nb_lo < nxt:
                nxt = nb_lo
            if nb_at > j and nb_at < nxt:
                nxt = nb_at
            if nb_hi > j and nb_hi < nxt:
                nxt = nb_hi
            jn = max(nxt, jn)
            continue
        ox, oy, oz, ldx, ldy, ldz = _local(phx, phy, phz, plx, ply, plz, dx, dy, dz, f, si, j)
        k = si[j, SI_KIND]
        # bounding-sphere cull (unit direction): skip a surface the ray cannot reach, or not before best_t
        br = f[j, SF_BS + 3]
        if j != jlast and br < np.inf:
            qx = ox - f[j, SF_BS]
            qy = oy - f[j, SF_BS + 1]
            qz = oz - f[j, SF_BS + 2]
            bb = qx * ldx + qy * ldy + qz * ldz
            cc = qx * qx + qy * qy + qz * qz - br * br
            if cc > 0.0:
                if bb > 0.0:
                    continue
                # br^2 minus the squared distance of closest approach, from q's part across the ray: bb^2 - cc
                # cancels for a small, far target (a 0.1 mm disk 100 km away was missed by a quarter of the
                # rays sent TOWARD it; benchmarks/bench_mitsuba.py)
                ex = qx - bb * ldx
                ey = qy - bb * ldy
                ez = qz - bb * ldz
                disc = br * br - (ex * ex + ey * ey + ez * ez)
                if disc < 0.0:
                    continue
                if best_t < np.inf and -bb - math.sqrt(disc) > best_t:
                    continue
        # central-hole cull: a ray through an annulus's hole (the light from a Cassegrain's secondary to its
        # focus, through the primary) crosses the slab that holds the surface within r_in of the axis at both
        # faces, so it cannot hit it: one division instead of the surface's quadratic
        hr2 = f[j, SF_HOLE]
        if hr2 > 0.0 and j != jlast and ldz != 0.0 and abs(ox) + abs(oy) + abs(oz) < f[j, SF_HOLE + 3]:
            iz = 1.0 / ldz
            ta = (f[j, SF_HOLE + 1] - oz) * iz
            tb = (f[j, SF_HOLE + 2] - oz) * iz
            xa = ox + ta * ldx
            ya = oy + ta * ldy
            xb = ox + tb * ldx
            yb = oy + tb * ldy
            if xa * xa + ya * ya < hr2 and xb * xb + yb * yb < hr2:
                continue
        tmin = EPS_SELF * max(f[j, SF_SIZE], abs(ox), abs(oy), abs(oz))
        # the kind's own crossings (its plugin's ``hit``; the dispatch is generated from the registry)
        t1, t2, face = _surface_hit(k, f, si, S, j, ox, oy, oz, ldx, ldy, ldz, tmin, j == jlast)
        apk = si[j, SI_APK]
        if t1 > tmin and t1 < best_t:
            x = ox + t1 * ldx
            y = oy + t1 * ldy
            if _aperture_ok(apk, f, j, x, y):
                best_t = t1
                best_j = j
                blx = x
                bly = y
                blz = oz + t1 * ldz
                bface = face
                continue
        if t2 > tmin and t2 < best_t:
            x = ox + t2 * ldx
            y = oy + t2 * ldy
            if _aperture_ok(apk, f, j, x, y):
                best_t = t2
                best_j = j
                blx = x
                bly = y
                blz = oz + t2 * ldz
                bface = face
    return best_t, best_j, blx, bly, blz, bface


@numba.njit(cache=True, inline="always")
def _normal(j, k, lx, ly, lz, face, f, si, S):
    """World unit normal of surface j at local point (lx, ly, lz)."""
    nx, ny, nz = _surface_normal(k, f, si, S, j, lx, ly, lz, face)
    return _rot(f, si, j, nx, ny, nz)


# ---------------------------------------------------------------------------------------------- maps
WGS84_A = 6378137.0
WGS84_E2 = 6.69437999014e-3


@numba.njit(cache=True)
def _geodetic_deep(x, y, z):
    """geodetic() for points within 43 km of the centre, near or inside the ellipsoid's evolute, where the
    latitude is not unique and the closed form fails: Bowring's iteration (some latitude, finite)."""
    p = math.hypot(x, y)
    lon = math.atan2(y, x)
    if p == 0.0:
        return (math.pi / 2 if z >= 0 else -math.pi / 2), lon
    lat = math.atan2(z, p * (1.0 - WGS84_E2))
    for _ in range(6):
        s = math.sin(lat)
        N = WGS84_A / math.sqrt(1.0 - WGS84_E2 * s * s)
        c = math.cos(lat)
        h = p / c - N if abs(c) > 1e-12 else abs(z) - N * (1.0 - WGS84_E2)
        lat = math.atan2(z, p * (1.0 - WGS84_E2 * N / (N + h)))
    return lat, lon


@numba.njit(cache=True)
def geodetic(x, y, z):
    """Geodetic latitude and longitude (radians) on the WGS84 ellipsoid of a point in an Earth-centred frame
    (z the polar axis, x toward longitude 0), at any point outside the ellipsoid's evolute (farther than
    ~43 km from the centre, where the latitude is unique): Vermeille's closed form (J. Geodesy 76, 451-454, 2002), exact to rounding,
    one cube root and two atan2 (the Bowring iteration it replaced took six atan2, four sin and four cos: 400
    against 175 ns, 11 % of an Earth frame's trace time)."""
    e4 = WGS84_E2 * WGS84_E2
    rho2 = x * x + y * y
    p = rho2 / (WGS84_A * WGS84_A)
    q = (1.0 - WGS84_E2) / (WGS84_A * WGS84_A) * z * z
    if p + q <= e4:
        return _geodetic_deep(x, y, z)      # within 43 km of the centre: near or inside the evolute
    r = (p + q - e4) / 6.0
    s = e4 * p * q / (4.0 * r * r * r)
    t = np.cbrt(1.0 + s + math.sqrt(s * (2.0 + s)))
    u = r * (1.0 + t + 1.0 / t)
    v = math.sqrt(u * u + e4 * q)
    w = WGS84_E2 * (u + v - q) / (2.0 * v)
    k = math.sqrt(u + v + w * w) - w
    D = k * math.sqrt(rho2) / (k + WGS84_E2)
    return 2.0 * math.atan2(z, D + math.sqrt(D * D + z * z)), math.atan2(y, x)


@numba.njit(cache=True)
def map_value(map_data, off, nlat, nlon, lat, lon):
    """LATLON grid value: rows from +90 deg down, columns from -180 deg east."""
    r = int((0.5 - lat / math.pi) * nlat)
    q = int((lon / (2.0 * math.pi) + 0.5) * nlon)
    r = min(max(r, 0), nlat - 1)
    q = min(max(q, 0), nlon - 1)
    return map_data[off + r * nlon + q]


# ---------------------------------------------------------------------------------------------- sources
@numba.njit(cache=True)
def _cone_to(px, py, pz, cx, cy, cz, r):
    """Axis and 1 - cos(half-angle) of the cone from p that holds the sphere (c, r); 2: all around.
    1 - cos is computed as s^2 / (1 + sqrt(1 - s^2)): exact for the tiny cones of a far target."""
    ax = cx - px
    ay = cy - py
    az = cz - pz
    d = math.sqrt(ax * ax + ay * ay + az * az)
    if d <= r or d == 0.0:
        return 0.0, 0.0, 1.0, 2.0
    s = r / d
    return ax / d, ay / d, az / d, s * s / (1.0 + math.sqrt(max(0.0, 1.0 - s * s)))


@numba.njit(cache=True)
def _cone_dir(u0, u1, omc, kx, ky, kz):
    """A direction uniform in the cone about unit k with 1 - cos(half-angle) = omc."""
    v = u0 * omc
    ct = 1.0 - v
    st = math.sqrt(max(0.0, v * (2.0 - v)))
    ph = TWO_PI * u1
    x = st * math.cos(ph)
    y = st * math.sin(ph)
    t1x, t1y, t1z, t2x, t2y, t2z = onb(kx, ky, kz)
    return x * t1x + y * t2x + ct * kx, x * t1y + y * t2y + ct * ky, x * t1z + y * t2z + ct * kz


@numba.njit(cache=True, inline="always")
def _roulette(w, w0, halt, u):
    """Russian roulette below halt * w0: (new weight, flux to book as HALTED).  Survivors carry halt * w0 and
    their gain is booked negative, so the ledger closes exactly."""
    if w <= 0.0 or w >= halt * w0:
        return w, 0.0
    if u < w / (halt * w0):
        return halt * w0, -(halt * w0 - w)
    return 0.0, w


@numba.njit(cache=True, inline="always")
def _nee_roulette(stack, cw, ref, cut):
    """Russian roulette of a ray sent toward a target (HALT ... IMPORTANCE cut): below cut times ref (what a
    white Lambertian surface would send) it survives with probability cw / (cut ref), carrying cut ref;
    unbiased, and the flux it would have carried is simply not sent (the ledger books only what is sent).
    The decisions of one source ray's candidates (every path it spawns) are drawn systematically against one
    uniform (sampling.systematic_keep; the pool in the stack's row POOL): each survives with its own
    probability, but how many survive is the floor or ceiling of their summed probabilities, so a path that
    sends a weak ray at each of 15 thin layers sends one or two, not a Poisson number of them.  The callers
    count every candidate in the path ids (npath), kept or not, so that which candidates arise does not depend
    on that uniform."""
    p = cw / (cut * ref)
    if p >= 1.0:
        return cw
    kept, total = systematic_keep(stack[POOL, 0], p, stack[POOL, 1])
    stack[POOL, 0] = total
    return cut * ref if kept else 0.0


@numba.njit(cache=True, inline="always")
def _toward(phx, phy, phz, plx, ply, plz, o_bc, o_br, tgt, u0, u1):
    """A direction uniform in the cone from p that holds the target's bounding sphere, and that cone's solid
    angle."""
    kx, ky, kz, omc = _cone_to(0.0, 0.0, 0.0, o_bc[tgt, 0] - phx - plx, o_bc[tgt, 1] - phy - ply,
                               o_bc[tgt, 2] - phz - plz, o_br[tgt])
    x, y, z = _cone_dir(u0, u1, omc, kx, ky, kz)
    return x, y, z, TWO_PI * omc


@numba.njit(cache=True)
def _phase(kind, g, gamma, mu):
    """Phase function per steradian (normalized over 4 pi): Rayleigh with depolarization, or HG."""
    if kind == PHASE_RAYLEIGH:
        return 3.0 / (4.0 * (1.0 + 2.0 * gamma)) * ((1.0 + 3.0 * gamma) + (1.0 - gamma) * mu * mu) / (4.0 * math.pi)
    d = 1.0 + g * g - 2.0 * g * mu
    return (1.0 - g * g) / (4.0 * math.pi * d * math.sqrt(d))


@numba.njit(cache=True)
def _phase_sample(kind, g, gamma, u):
    """mu = cos(scattering angle) drawn from the phase function."""
    if kind == PHASE_HG:
        if abs(g) < 1e-6:
            return 2.0 * u - 1.0
        q = (1.0 - g * g) / (1.0 - g + 2.0 * g * u)
        return max(-1.0, min(1.0, (1.0 + g * g - q * q) / (2.0 * g)))
    # Rayleigh: CDF(mu) = [a (mu + 1) + b (mu^3 + 1) / 3] / (2 a + 2 b / 3), Newton from a good start
    a = 1.0 + 3.0 * gamma
    b = 1.0 - gamma
    target = u * (2.0 * a + 2.0 * b / 3.0)
    mu = 2.0 * u - 1.0
    for _ in range(30):
        f = a * (mu + 1.0) + b * (mu * mu * mu + 1.0) / 3.0 - target
        df = a + b * mu * mu
        step = f / df
        mu -= step
        mu = max(-1.0, min(1.0, mu))
        if abs(step) < 1e-15:
            break
    return mu


@numba.njit(cache=True)
def _turn(dx, dy, dz, mu, u):
    """The direction at angle acos(mu) from d, azimuth 2 pi u."""
    st = math.sqrt(max(0.0, 1.0 - mu * mu))
    ph = TWO_PI * u
    t1x, t1y, t1z, t2x, t2y, t2z = onb(dx, dy, dz)
    x = st * math.cos(ph)
    y = st * math.sin(ph)
    return x * t1x + y * t2x + mu * dx, x * t1y + y * t2y + mu * dy, x * t1z + y * t2z + mu * dz


@numba.njit(cache=True, inline="always")
def _spectral_line(SRC, s, u):
    """A camera's spectral sample: the line whose interval of the bands' cumulative weight holds u (rows (cdf,
    line) in SRC.pts, binary search)."""
    r0 = SRC.pts_off[s]
    lo = 0
    hi = int(SRC.par[s, 9]) - 1
    while lo < hi:
        mid = (lo + hi) >> 1
        if SRC.pts[r0 + mid, 0] < u:
            lo = mid + 1
        else:
            hi = mid
    return int(SRC.pts[r0 + lo, 1])


@numba.njit(cache=True, inline="always")
def _gen(i, total, seed, SRC, o_bc, o_br, src_dw):
    """Ray i: (source, line, phx, phy, phz, plx, ply, plz, dx, dy, dz, w, sx, sy, pm, key); (sx, sy) is the
    start point in the source's own frame (the pupil coordinates of a GRID); pm is 0, or for a camera with
    DIRECTIONS m (par[SP_DIRECTIONS] = m) 1 or 2: the first or second ray of a pair drawn in the same one of
    the m x m strata of the aim cone (its rays 2k and 2k + 1; the tallies take the variance from their
    difference); key is the ray's random stream: i, or for a CORRELATED camera (par[SP_CORRELATED] = 1) the id
    of its start point's first line, so that every line of a start point draws the same numbers.  Ids past
    `total` start another pass over the sources (TRACE UNTIL ERROR) with fresh random numbers."""
    ii = i if i < total else i % total          # (integer divisions cost ~40 cycles: only when needed)
    s = 0
    while s + 1 < SRC.off.shape[0] and ii >= SRC.off[s + 1]:
        s += 1
    j = ii - SRC.off[s]
    n = SRC.n[s]
    slot = 0 if j < n else j // n
    q = j - slot * n
    if F_CAMERA and SRC.par[s, SP_CORRELATED] > 0.0:
        i -= slot * n
    pm = 0
    st = 0
    nd = int(SRC.par[s, SP_DIRECTIONS]) if F_CAMERA else 0
    if F_CAMERA and nd > 0:
        # DIRECTIONS m: 2 m^2 rays per start point, two in each stratum (consecutive ids: the pair)
        per = 2 * nd * nd
        pos = q // per
        r = q - pos * per
        st = r >> 1
        pm = 1 + (r & 1)
        q = pos
    if F_CAMERA and SRC.random[s] == SAMPLE_SPECTRAL:
        # a camera's spectral samples: slot k of K draws its line from the bands' weights, stratified over
        # their cumulative distribution (rows (cdf, line) in SRC.pts; SRC.w holds weight / (pmf K))
        ul, _ul = uniform2(seed, i, 0, 2)
        if SRC.par[s, SP_PAIRED] > 0.0:
            # paired: K / 2 strata, two independent rays in each (ids 2p and 2p + 1; p = stratum * n + point),
            # so the tallies take the variance from the pairs' differences
            pr = j >> 1
            pm = 1 + (j & 1)
            slot = pr // n
            q = pr - slot * n
            u = (slot + ul) / (0.5 * SRC.par[s, 10])
        else:
            u = (slot + ul) / SRC.par[s, 10]
        line = _spectral_line(SRC, s, u)
    else:
        line = SRC.lmap[s, slot]     # the source's traced lines (all of them, or a camera's band lines)
    w = SRC.w[s, line]
    kind = SRC.kind[s]
    u0, u1 = uniform2(seed, i, 0, 0)
    # the start point in the source's frame and its axis of Lambertian emission (the kind's plugin ``emit``)
    lx, ly, lz, ax, ay, az = _source_emit(kind, SRC, s, q, u0, u1)
    # to world
    wx = SRC.R[s, 0] * lx + SRC.R[s, 1] * ly + SRC.R[s, 2] * lz
    wy = SRC.R[s, 3] * lx + SRC.R[s, 4] * ly + SRC.R[s, 5] * lz
    wz = SRC.R[s, 6] * lx + SRC.R[s, 7] * ly + SRC.R[s, 8] * lz
    phx, plx = _two_sum(SRC.Th[s, 0], wx)
    phy, ply = _two_sum(SRC.Th[s, 1], wy)
    phz, plz = _two_sum(SRC.Th[s, 2], wz)
    plx += SRC.Tl[s, 0]
    ply += SRC.Tl[s, 1]
    plz += SRC.Tl[s, 2]
    dk = SRC.dir[s]
    if dk == DIR_COLLIMATED:  # the world direction is the source's own (_collimated_dirs), the same every ray
        return s, line, phx, phy, phz, plx, ply, plz, src_dw[s, 0], src_dw[s, 1], src_dw[s, 2], w, lx, ly, pm, i
    if dk != DIR_LAMBERT:   # the direction plugin's, per ray
        ldx, ldy, ldz = _source_direction(dk, SRC, s, lx, ly, lz)
        dwx, dwy, dwz = _dir_to_world(SRC.R, s, ldx, ldy, ldz)
        return s, line, phx, phy, phz, plx, ply, plz, dwx, dwy, dwz, w, lx, ly, pm, i
    # a Lambertian emitter (sphere, disk, point, a camera's pixels)
    u2, u3 = uniform2(seed, i, 0, 1)      # the direction's numbers: drawn only by the sources that use them
    nwx = SRC.R[s, 0] * ax + SRC.R[s, 1] * ay + SRC.R[s, 2] * az
    nwy = SRC.R[s, 3] * ax + SRC.R[s, 4] * ay + SRC.R[s, 5] * az
    nwz = SRC.R[s, 6] * ax + SRC.R[s, 7] * ay + SRC.R[s, 8] * az
    tgt = SRC.toward[s]
    if tgt >= 0:
        # sample the cone that holds the target's bounding sphere; exact weight = pdf_emitter / pdf_cone
        cx = o_bc[tgt, 0] - SRC.Th[s, 0] - SRC.Tl[s, 0]
        cy = o_bc[tgt, 1] - SRC.Th[s, 1] - SRC.Tl[s, 1]
        cz = o_bc[tgt, 2] - SRC.Th[s, 2] - SRC.Tl[s, 2]
        kx, ky, kz, omc = _cone_to(wx, wy, wz, cx, cy, cz, o_br[tgt])
        if F_CAMERA and nd > 0:      # the pair's stratum: m bands of equal solid angle in cos(angle) by m in azimuth
            u2 = (st % nd + u2) / nd
            u3 = (st // nd + u3) / nd
            if SRC.par[s, SP_PILOT] > 0.0:
                # a GUIDE's pilot: its tally bins by stratum and tile (DETECTOR ... START)
                lx = st + 0.5
                ly = _guide_tile(SRC.par, s, q, int(SRC.par[s, SP_GUIDE_T])) + 0.5
        elif F_CAMERA and SRC.par[s, SP_GUIDE] > 0.0:
            u2, u3, gw = _guide(SRC, s, q, u2, u3)
            w *= gw
        dwx, dwy, dwz = _cone_dir(u2, u3, omc, kx, ky, kz)
        omega = TWO_PI * omc
        w *= _source_toward(kind, SRC, s, dwx * nwx + dwy * nwy + dwz * nwz, omega)
        return s, line, phx, phy, phz, plx, ply, plz, dwx, dwy, dwz, w, lx, ly, pm, i
    x, y, z, wf = _source_lambert(kind, SRC, s, u2, u3)
    w *= wf
    t1x, t1y, t1z, t2x, t2y, t2z = onb(nwx, nwy, nwz)
    dwx = x * t1x + y * t2x + z * nwx
    dwy = x * t1y + y * t2y + z * nwy
    dwz = x * t1z + y * t2z + z * nwz
    return s, line, phx, phy, phz, plx, ply, plz, dwx, dwy, dwz, w, lx, ly, pm, i


@numba.njit(cache=True, inline="always")
def _guide_tile(par, s, q, t):
    """The tile (of t x t over the source's start lattice, par[4] x par[5] points) that start point q lies in."""
    nxs = int(par[s, 4])
    nys = int(par[s, 5])
    iy = q // nxs
    ix = q - iy * nxs
    return (iy * t // nys) * t + ix * t // nxs


@numba.njit(cache=True, inline="always")
def _guide(SRC, s, q, u2, u3):
    """A camera's GUIDE (irtlang/model/camera.py): the cell of the g x g strata of the aim cone drawn from start
    point q's tile's table (rows (cdf, 1 / (g^2 pmf)) in SRC.pts), u2 reused within the cell (its place between
    the cell's cumulative bounds), u3 across it.  Returns the cone's (u2, u3) and the weight factor: the uniform
    density over the guided one, so every cell (the pmf mixes in a uniform share) keeps its expected value."""
    g = int(SRC.par[s, SP_GUIDE])
    tile = _guide_tile(SRC.par, s, q, int(SRC.par[s, SP_GUIDE_T]))
    r0 = SRC.pts_off[s] + int(SRC.par[s, SP_GUIDE_ROW]) + tile * g * g
    lo = 0
    hi = g * g - 1
    while lo < hi:
        mid = (lo + hi) >> 1
        if SRC.pts[r0 + mid, 0] <= u2:
            lo = mid + 1
        else:
            hi = mid
    c0 = SRC.pts[r0 + lo - 1, 0] if lo > 0 else 0.0
    f = (u2 - c0) / (SRC.pts[r0 + lo, 0] - c0)
    f = min(max(f, 0.0), 0.9999999999999999)
    return (lo % g + f) / g, (lo // g + u3) / g, SRC.pts[r0 + lo, 1]


@numba.njit(cache=True, inline="always")
def _dir_to_world(src_R, s, ldx, ldy, ldz):
    """A source-frame direction rotated to the world and normalized."""
    dwx = src_R[s, 0] * ldx + src_R[s, 1] * ldy + src_R[s, 2] * ldz
    dwy = src_R[s, 3] * ldx + src_R[s, 4] * ldy + src_R[s, 5] * ldz
    dwz = src_R[s, 6] * ldx + src_R[s, 7] * ldy + src_R[s, 8] * ldz
    m = math.sqrt(dwx * dwx + dwy * dwy + dwz * dwz)
    return dwx / m, dwy / m, dwz / m


@numba.njit(cache=True)
def _collimated_dirs(SRC):
    """(S, 3): each collimated source's world unit direction, computed once per batch (bitwise what a per-ray
    computation would give); zeros for the other sources."""
    out = np.zeros((SRC.dir.shape[0], 3))
    for s in range(SRC.dir.shape[0]):
        if SRC.dir[s] == DIR_COLLIMATED:
            ldx, ldy, ldz = _source_direction(DIR_COLLIMATED, SRC, s, 0.0, 0.0, 0.0)
            x, y, z = _dir_to_world(SRC.R, s, ldx, ldy, ldz)
            out[s, 0] = x
            out[s, 1] = y
            out[s, 2] = z
    return out


# ---- source dispatch (rewritten by irtlang.compile.specialize from the source registry; this copy, the
# template's, has GRID RECT and SOURCE DIRECTION only) ----
from irtlang.plugins.sources._common import lambert as _lambert_default
from irtlang.plugins.sources._common import toward as _toward_default
from irtlang.plugins.sources.grid_rect import emit as _emit_0
from irtlang.plugins.sources.direction import direction as _direction_0


@numba.njit(cache=True, inline="always")
def _source_emit(kind, SRC, s, q, u0, u1):
    return _emit_0(SRC, s, q, u0, u1)


@numba.njit(cache=True, inline="always")
def _source_direction(dk, SRC, s, x, y, z):
    return _direction_0(SRC, s, x, y, z)


@numba.njit(cache=True, inline="always")
def _source_lambert(kind, SRC, s, u2, u3):
    return _lambert_default(SRC, s, u2, u3)


@numba.njit(cache=True, inline="always")
def _source_toward(kind, SRC, s, c, omega):
    return _toward_default(SRC, s, c, omega)
# ---- end of source dispatch ----


# ---- surface dispatch (rewritten by irtlang.compile.specialize for the surface kinds a kernel has; this copy, the
# template's, has PLANE only) ----
from irtlang.plugins.surfaces.plane import hit as _hit_0
from irtlang.plugins.surfaces.plane import normal as _normal_0


@numba.njit(cache=True, inline="always")
def _surface_hit(k, f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    return _hit_0(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving)


@numba.njit(cache=True, inline="always")
def _surface_normal(k, f, si, S, j, x, y, z, face):
    return _normal_0(f, si, S, j, x, y, z, face)
# ---- end of surface dispatch ----


# ---- bsdf dispatch (rewritten by irtlang.compile.specialize for the models a scene uses) ----
from irtlang.plugins.bsdfs.lambertian import sample as _sample_0
from irtlang.plugins.bsdfs.lambertian import eval as _eval_0
from irtlang.plugins.bsdfs.lambertian import albedo as _albedo_0
from irtlang.plugins.bsdfs.lambertian import direct_transmission as _direct_0
from irtlang.plugins.bsdfs._common import depolarize as _mueller_0
from irtlang.plugins.bsdfs.lambertian import pdf as _pdf_0
from irtlang.plugins.bsdfs._common import no_delta as _delta_0


@numba.njit(cache=True)
def _parts_0(P, k, cos_i):
    a_, b_ = _albedo_0(P, k, cos_i)
    return a_, b_, _direct_0(P, k, cos_i), _delta_0(P, k, cos_i)


@numba.njit(cache=True)
def _bsdf_sample(kind, P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2):
    return _sample_0(P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2)


@numba.njit(cache=True)
def _bsdf_eval(kind, P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    return _eval_0(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz)


@numba.njit(cache=True)
def _bsdf_albedo(kind, P, k, cos_i):
    return _albedo_0(P, k, cos_i)


@numba.njit(cache=True)
def _bsdf_direct(kind, P, k, cos_i):
    return _direct_0(P, k, cos_i)


@numba.njit(cache=True)
def _bsdf_mueller(kind, P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz, q, u, v, ex, ey, ez):
    return _mueller_0(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz, q, u, v, ex, ey, ez)


@numba.njit(cache=True)
def _bsdf_pdf(kind, P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz):
    return _pdf_0(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz)


@numba.njit(cache=True)
def _bsdf_delta(kind, P, k, cos_i):
    return _delta_0(P, k, cos_i)


@numba.njit(cache=True)
def _bsdf_parts(kind, P, k, cos_i):
    return _parts_0(P, k, cos_i)
# ---- end of bsdf dispatch ----

# ---------------------------------------------------------------------------------------------- the trace
@numba.njit(cache=True, inline="always")
def _push(stack, sp, phx, phy, phz, plx, ply, plz, dx, dy, dz, w, w0, ev, excl, nee, path, flags, jlast, opl, sx, sy,
          hist, H, stq, stu, stv, ex, ey, ez):
    stack[sp, 0] = phx
    stack[sp, 1] = phy
    stack[sp, 2] = phz
    stack[sp, 3] = plx
    stack[sp, 4] = ply
    stack[sp, 5] = plz
    stack[sp, 6] = dx
    stack[sp, 7] = dy
    stack[sp, 8] = dz
    stack[sp, 9] = w
    stack[sp, 10] = w0
    stack[sp, 11] = ev
    stack[sp, 12] = excl
    stack[sp, 13] = nee
    stack[sp, 14] = path
    stack[sp, 15] = flags
    stack[sp, 16] = jlast
    stack[sp, 17] = opl
    stack[sp, 18] = sx
    stack[sp, 19] = sy
    if F_POLAR:
        stack[sp, 20] = stq
        stack[sp, 21] = stu
        stack[sp, 22] = stv
        stack[sp, 23] = ex
        stack[sp, 24] = ey
        stack[sp, 25] = ez
    for h in range(H):
        stack[sp, SWP + h] = hist[h]


@numba.njit(cache=True, inline="always")
def _pop(stack, sp, hist, H, stq, stu, stv, ex, ey, ez):
    """Stack entry sp as _push wrote it: ph(3), pl(3), d(3), w, w0, ev, excl, nee, path, flags, jlast, opl, sx,
    sy, q, u, v, e1(3); its history goes into hist.  An unpolarized trace keeps its (unused) q .. e1."""
    if F_POLAR:
        stq = stack[sp, 20]
        stu = stack[sp, 21]
        stv = stack[sp, 22]
        ex = stack[sp, 23]
        ey = stack[sp, 24]
        ez = stack[sp, 25]
    for h in range(H):
        hist[h] = stack[sp, SWP + h]
    return (stack[sp, 0], stack[sp, 1], stack[sp, 2], stack[sp, 3], stack[sp, 4], stack[sp, 5], stack[sp, 6],
            stack[sp, 7], stack[sp, 8], stack[sp, 9], stack[sp, 10], int(stack[sp, 11]), int(stack[sp, 12]),
            stack[sp, 13] > 0.0, int(stack[sp, 14]), int(stack[sp, 15]), int(stack[sp, 16]), stack[sp, 17],
            stack[sp, 18], stack[sp, 19], stq, stu, stv, ex, ey, ez)


# ---------------------------------------------------------------------------------------------- event helpers
# Inlined into trace_batch's parallel loop.  Numba loses a parallel loop's writes to an array reached through a tuple, so a
# helper may READ a layout structure (S, SC, MD, D) but writes only into arrays passed to it as such.
@numba.njit(cache=True, inline="always")
def _deposit(D, dd, dep_idx, dep_w, dep_d, c, ndep, cap, line, L, w, lx, ly, sx0, sy0, s_f, j, dx, dy, dz, ex, ey,
             ez, stq, stu, stv):
    """A hit on detector dd: its pixel's deposit (and in a polarized trace the Q, U, V deposits, in the detector's
    frame); dep_d, the deposit the variance squares, starts equal to dep_w (the second ray of a stratified pair
    negates its own).  Returns the deposit count and the ray's Stokes frame (made perpendicular to d)."""
    x0 = D.ext[dd, 0]
    x1 = D.ext[dd, 1]
    y0 = D.ext[dd, 2]
    y1 = D.ext[dd, 3]
    # DETECTOR ... START: the pixel of where the ray started (its source's own frame), the image of an adjoint
    # (detector-side) trace; else the pixel of the hit point
    ux = sx0 if D.start[dd] else lx
    uy = sy0 if D.start[dd] else ly
    if ux >= x0 and ux <= x1 and uy >= y0 and uy <= y1:
        nx = D.nx[dd]
        ny = D.ny[dd]
        ix = min(nx - 1, int((ux - x0) / (x1 - x0) * nx))
        iy = min(ny - 1, int((uy - y0) / (y1 - y0) * ny))
        if ndep < cap:
            dep_idx[c, ndep] = D.off[dd] + (line * ny + iy) * nx + ix
            dep_w[c, ndep] = w * D.qe[dd, line]
            dep_d[c, ndep] = dep_w[c, ndep]
        ndep += 1
        if F_POLAR:
            # Q, U, V in the detector's frame (e1: its local x, projected across the ray), deposited as images
            # 1, 2, 3 of the detector's Stokes stack
            fx, fy, fz = frame(dx, dy, dz, s_f[j, SF_R], s_f[j, SF_R + 3], s_f[j, SF_R + 6])
            ex, ey, ez = frame(dx, dy, dz, ex, ey, ez)
            dq, du = rotate(dx, dy, dz, ex, ey, ez, stq, stu, fx, fy, fz)
            stride = L * ny * nx
            wd = w * D.qe[dd, line]
            for comp in range(1, 4):
                if ndep < cap:
                    dep_idx[c, ndep] = D.off[dd] + comp * stride + (line * ny + iy) * nx + ix
                    dep_w[c, ndep] = wd * (dq if comp == 1 else (du if comp == 2 else stv))
                    dep_d[c, ndep] = dep_w[c, ndep]
                ndep += 1
    return ndep, ex, ey, ez


@numba.njit(cache=True, inline="always")
def _specular(MD, it, cc, line, ci, m1, m2):
    """The interface's specular reflectance R and transmittance T (absorbed: 1 - R - T), and in a polarized
    trace its Mueller coefficients (Ar, Br, xr, yr) for reflection and (At, Bt, xt, yt) for transmission."""
    Ar = Br = xr = yr = At = Bt = xt = yt = 0.0
    if it == IF_ABSORB:
        R = 0.0
        T = 0.0
    elif it == IF_REFLECT:
        R = 1.0
        T = 0.0
    elif it == IF_SPLIT:
        R = MD.coat_R[0, cc, line]
        T = MD.coat_T[0, cc, line]
        tir = False
        if F_REFRACT and T > 0.0:
            # a coated boundary between two media refracts; beyond the critical angle its transmitted share
            # cannot leave and is reflected (total internal reflection)
            n1 = MD.n[m1, line]
            n2 = MD.n[m2, line]
            if n1 > n2 and n1 * n1 * (1.0 - ci * ci) >= n2 * n2:
                R += T
                T = 0.0
                tir = True
        if F_POLAR:
            # Mueller coefficients from (Rs + Rp)/2, (Rs - Rp)/2 and the retardance beyond an ideal mirror's
            # (reflection: x + i y = -sqrt(Rs Rp) exp(i delta_r)) or a bare transmission's (x + i y = sqrt(Ts Tp)
            # exp(i delta_t)); the coatings' layout (irtlang.kernels.layout.Media)
            Ar = R
            At = T
            if not tir:
                Br = MD.coat_R[1, cc, line]
                Bt = MD.coat_T[1, cc, line]
            a = math.sqrt(max(Ar * Ar - Br * Br, 0.0))
            xr = -a * math.cos(MD.coat_R[2, cc, line])
            yr = -a * math.sin(MD.coat_R[2, cc, line])
            a = math.sqrt(max(At * At - Bt * Bt, 0.0))
            xt = a * math.cos(MD.coat_T[2, cc, line])
            yt = a * math.sin(MD.coat_T[2, cc, line])
    elif it == IF_METAL:
        # a metal: Fresnel with the complex index n + i k (coat_R, coat_T hold n and k), no T
        Ar, Br, xr, yr = metal_mueller(abs(ci), MD.n[m1, line], MD.coat_R[0, cc, line], MD.coat_T[0, cc, line])
        R = Ar
        T = 0.0
    elif not F_POLAR or it == IF_FRESNEL:
        if F_POLAR:
            Ar, Br, xr, yr, At, Bt, xt = fresnel_mueller(abs(ci), MD.n[m1, line], MD.n[m2, line])
            R = 0.0
        else:
            R = fresnel_unpolarized(abs(ci), MD.n[m1, line], MD.n[m2, line])
        T = 1.0 - R
    else:
        R = 0.0
        T = 1.0
    return R, T, Ar, Br, xr, yr, At, Bt, xt, yt


@numba.njit(cache=True, inline="always")
def _interface_frame(it, o_pol, o, s_f, j, dx, dy, dz, nwx, nwy, nwz, ex, ey, ez, stq, stu, R, T, Ar, Br, At, Bt):
    """A polarized trace at an interface: the Stokes vector into the interface's frame (e1 = s, normal to the
    plane of incidence, or a polarizer's or retarder's axis: the object's local x turned by its angle about z),
    and R, T for that state.  Returns (R, T, q, u, e1)."""
    ex, ey, ez = frame(dx, dy, dz, ex, ey, ez)
    if it == IF_POLARIZER or it == IF_RETARDER:
        ca = math.cos(o_pol[o, 0])
        sa = math.sin(o_pol[o, 0])
        r = SF_R
        snx, sny, snz = frame(dx, dy, dz, ca * s_f[j, r] + sa * s_f[j, r + 1], ca * s_f[j, r + 3] + sa * s_f[j, r + 4],
                              ca * s_f[j, r + 6] + sa * s_f[j, r + 7])
    else:
        snx, sny, snz = perpendicular(dx, dy, dz, nwx, nwy, nwz, ex, ey, ez)
    stq, stu = rotate(dx, dy, dz, ex, ey, ez, stq, stu, snx, sny, snz)
    if it == IF_FRESNEL:
        R = Ar + Br * stq
        T = 1.0 - R
    elif it == IF_METAL:
        R = Ar + Br * stq
    elif it == IF_SPLIT:
        R = Ar + Br * stq
        T = At + Bt * stq
    elif it == IF_POLARIZER:
        T = 0.5 * (1.0 + stq)
    return R, T, stq, stu, snx, sny, snz


@numba.njit(cache=True, inline="always")
def _gate(SC, scf, scn, ll, R, T):
    """OPAQUE WHERE (the object's first SCATTER spec is a gate map): the object is present (opaque: its models,
    the rest absorbed) where its gate map is 1 at the hit (lx, ly, lz), and clear air elsewhere (its TRANSMIT
    interface, no scattering).  ll: the hit's geodetic (latitude, longitude).  Returns (R, T, first spec, spec
    count) for what follows."""
    glat, glon = ll
    gm = SC.map[scf]
    scf += 1
    scn -= 1
    if map_value(SC.map_data, SC.map_off[gm], SC.map_nlat[gm], SC.map_nlon[gm], glat, glon) > 0.5:
        R = 0.0
        T = 0.0
    else:
        scn = 0
    return R, T, scf, scn


@numba.njit(cache=True, inline="always")
def _scatter_spec(SC, first, cnt, ll, seed, i, ev, path):
    """Which scatter model applies at this hit: the object's SCATTER specs tried in order (a class map picks by
    the class under the point, a fraction map draws against the fraction; ll: the hit's geodetic latitude and
    longitude).  (model, RAYS n, TOWARD target); model -1: none."""
    sc = -1
    sc_n = 1
    sc_tgt = -1
    if F_SCATTER and cnt > 0:
        for qq in range(cnt):
            spn = first + qq
            kd = SC.kind[spn]
            if F_MAPS and kd != SPEC_MODEL:
                lat, lon = ll
                # a class map's model (-1: a class without one), or a fraction map's with its fraction v
                mq, v, _rest = _spec_share(SC, spn, lat, lon, 1.0)
                if kd != SPEC_CLASS_MAP:
                    uc, _u = uniform2(seed, i, ev, path * 64 + 59 - qq)
                    if uc >= v:
                        continue
                sc = mq
            else:
                sc = SC.model[spn]
            sc_n = SC.rays[spn]
            sc_tgt = SC.tgt[spn]
            break
    return sc, sc_n, sc_tgt


@numba.njit(cache=True, inline="always")
def _volume_toward(stack, sp, npath, led, c, r_imp, line, key, nr, pk, gg, gam, depol, tgt, w, nee_cut, o_bc, o_br,
                   pos, d, pol, opl, sx0, sy0, hist, H):
    """Next-event estimation at a volume scattering: nr rays toward the target's bounding sphere with the exact
    weights w p(mu) Omega / nr (polarized Rayleigh: the Mueller matrix in the plane through d and the target),
    pushed on the stack and booked negative on the IMPORTANCE row.  The ray's state as in _bsdf_toward.  Returns
    (sp, npath)."""
    seed, i, ev, path = key
    phx, phy, phz, plx, ply, plz = pos
    dx, dy, dz = d
    stq, stu, stv, ex, ey, ez = pol
    for q in range(nr):
        v0, v1 = uniform2(seed, i, ev, path * 64 + 8 + 2 * q)
        ox_, oy_, oz_, om = _toward(phx, phy, phz, plx, ply, plz, o_bc, o_br, tgt, v0, v1)
        mu_ = dx * ox_ + dy * oy_ + dz * oz_
        pf = 1.0
        nq = 0.0
        nu = 0.0
        nv = 0.0
        nex = 0.0
        ney = 0.0
        nez = 0.0
        if F_POLAR:
            if pk == PHASE_RAYLEIGH:
                nex, ney, nez = perpendicular(dx, dy, dz, ox_, oy_, oz_, ex, ey, ez)
                qs, us = rotate(dx, dy, dz, ex, ey, ez, stq, stu, nex, ney, nez)
                p11, p12, p22, p33, p44 = rayleigh_mueller(mu_, depol)
                i1, nq, nu, nv = scatter_stokes(qs, us, stv, p11, p12, p22, p33, p44)
                pf = i1 / p11
            else:
                nex, ney, nez = frame(ox_, oy_, oz_, ex, ey, ez)   # HG depolarizes
        cw = w * _phase(pk, gg, gam, mu_) * pf * om / nr
        cand = cw > 0.0
        if nee_cut > 0.0 and cand:
            cw = _nee_roulette(stack, cw, w * om / (math.pi * nr), nee_cut)
        if cw > 0.0 and sp < SMAX:
            _push(stack, sp, phx, phy, phz, plx, ply, plz, ox_, oy_, oz_, cw, cw, ev, -1.0, 1.0, npath, FL_SCATTERED,
                  -1.0, opl, sx0, sy0, hist, H, nq, nu, nv, nex, ney, nez)
            sp += 1
            npath += 1
            led[c, r_imp, C_ABS, line] -= cw
        elif nee_cut > 0.0 and cand:
            npath += 1      # a candidate the roulette dropped keeps its path id (_nee_roulette)
    return sp, npath


@numba.njit(cache=True, inline="always")
def _phase_turn(pk, gg, gam, depol, v0, v1, dx, dy, dz, ex, ey, ez, stq, stu, stv):
    """The direction after a volume scattering, drawn from the phase function, with the Stokes state and frame
    after it.  Polarized Rayleigh: mu from the phase function (the marginal of the Mueller matrix's I row), then
    the azimuth from its density given mu, 1 - A cos 2(phi - phi0): the joint density exactly, the weight
    unchanged.  HG depolarizes (docs/tracer.md)."""
    mu_ = _phase_sample(pk, gg, gam, v0)
    if F_POLAR and pk == PHASE_RAYLEIGH:
        p11, p12, p22, p33, p44 = rayleigh_mueller(mu_, depol)
        A = p12 / p11 * math.sqrt(stq * stq + stu * stu)
        phi = 0.5 * math.atan2(stu, stq) + azimuth_angle(A, v1)
        cph = math.cos(phi)
        sph = math.sin(phi)
        e2x = dy * ez - dz * ey
        e2y = dz * ex - dx * ez
        e2z = dx * ey - dy * ex
        st = math.sqrt(max(0.0, 1.0 - mu_ * mu_))
        nsx = cph * e2x - sph * ex      # the scattering plane's normal
        nsy = cph * e2y - sph * ey
        nsz = cph * e2z - sph * ez
        qs, us = rotate(dx, dy, dz, ex, ey, ez, stq, stu, nsx, nsy, nsz)
        _i1, stq, stu, stv = scatter_stokes(qs, us, stv, p11, p12, p22, p33, p44)
        dx = mu_ * dx + st * (cph * ex + sph * e2x)
        dy = mu_ * dy + st * (cph * ey + sph * e2y)
        dz = mu_ * dz + st * (cph * ez + sph * e2z)
        ex, ey, ez = frame(dx, dy, dz, nsx, nsy, nsz)
    else:
        dx, dy, dz = _turn(dx, dy, dz, mu_, v1)
        if F_POLAR:
            stq = 0.0
            stu = 0.0
            stv = 0.0
            ex, ey, ez = frame(dx, dy, dz, ex, ey, ez)
    return dx, dy, dz, ex, ey, ez, stq, stu, stv


# ---------------------------------------------------------------------------------------------- hero wavelengths
# TRACE CAMERA ... HERO K (docs/tracer.md, "Hero wavelengths"): a camera ray of traced line h (the hero) carries
# the K lines of h's block.  Every random choice is the hero's; per line t the ray keeps a_t = f_t / p_h (its
# integrand over the hero's path density) and s_t = p_t / p_h (the density its path would have had with t as the
# hero), and a deposit adds a_t / sum(s) to line t: the balance heuristic over the block's K heroes (Veach's
# multi-sample MIS with one sample per line; Wilkie et al. 2014).  The roulettes decide on the lines' combined
# weight, which is the same whichever line is the hero, so they drop out of the density ratios.  The hero's own
# scalar weight w still books the ledger, as a one-line trace would.
@numba.njit(cache=True, inline="always")
def _hero_start(SRC, s, i0, total, seed, line, w, HV):
    """A HERO source ray: its block's lines (HV row H_L), weights a_t = w W_t / W_h (W the source's weight per
    line; the start's other factors are common) and ratios s_t = 1.  Returns (K of this block, the hero's
    place in it).
    Every line traced (a spectrum): the blocks of K traced lines start at line par[SP_HERO_OFF] (the trace's
    seed picks it, so that frames of different seeds put the blocks' edges elsewhere); the ones before it and
    at the end are shorter.
    SPECTRAL n (band images): the ray of stratum k (of the S strata of the bands' cumulative weight: n, or n / 2
    paired) carries one line from each stratum of k's block, all drawn with the ray's own uniform (u = (k' + ul) / S
    for stratum k', _gen's draw for k' = k).  The blocks interleave, so that each spans the whole spectrum:
    with nb = ceil(S / K) blocks, block r holds strata r, r + nb, r + 2 nb, ... (K or fewer).  Each stratum's
    line is a draw from that stratum, and the hero is uniform over the block (every stratum has the same
    rays), so the balance heuristic over the block's lines is unbiased with the same per-line weights as one
    line per ray (docs/tracer.md)."""
    K = int(SRC.par[s, SP_HERO])
    ii = i0 if i0 < total else i0 % total
    n = SRC.n[s]
    if F_CAMERA and SRC.random[s] == SAMPLE_SPECTRAL:
        j = ii - SRC.off[s]
        ns = SRC.par[s, 10]
        if SRC.par[s, SP_PAIRED] > 0.0:
            j = j >> 1
            ns = 0.5 * ns
        k = j // n
        ul, _ul = uniform2(seed, i0, 0, 2)
        S = int(ns)
        nb = (S + K - 1) // K
        r = k % nb
        kb = (S - r + nb - 1) // nb
        ws = SRC.w[s, line]
        for t in range(kb):
            kt = r + t * nb
            lt = line if kt == k else _spectral_line(SRC, s, (kt + ul) / ns)
            HV[H_L, t] = lt
            HV[H_A, t] = w * SRC.w[s, lt] / ws if ws > 0.0 else 0.0
            HV[H_S, t] = 1.0
            HV[H_ACC, t] = 0.0
        return kb, k // nb
    off = int(SRC.par[s, SP_HERO_OFF])
    slot = (ii - SRC.off[s]) // n
    end = SRC.off[s + 1] if s + 1 < SRC.off.shape[0] else total
    nl = (end - SRC.off[s]) // n
    b0 = max(0, ((slot + K - off) // K) * K - (K - off))
    kb = min(((slot + K - off) // K) * K - (K - off) + K, nl) - b0
    ws = SRC.w[s, line]
    for t in range(kb):
        lt = SRC.lmap[s, b0 + t]
        HV[H_L, t] = lt
        HV[H_A, t] = w * SRC.w[s, lt] / ws if ws > 0.0 else 0.0
        HV[H_S, t] = 1.0
        HV[H_ACC, t] = 0.0
    return kb, slot - b0


@numba.njit(cache=True, inline="always")
def _hero_alive(HV, K):
    """Whether any of the ray's lines still carries weight (the hero's own may be 0 where another's is not)."""
    for t in range(K):
        if HV[H_A, t] > 0.0:
            return True
    return False


@numba.njit(cache=True, inline="always")
def _hero_combined(HV, K):
    """The lines' combined weight sum(a) / sum(s): the same whichever line is the hero (the roulettes' measure)."""
    a = 0.0
    r = 0.0
    for t in range(K):
        a += HV[H_A, t]
        r += HV[H_S, t]
    return a / r


@numba.njit(cache=True, inline="always")
def _hero_shares(HV, K, SC, MD, itf, cc, ci, gz, fm_nee, specs, ll, sc, cos_i, nee):
    """Each line's R, T, diffuse share, slab keep and the boundary's Fresnel R at this hit, as the scalar code
    computes the hero's: the interface (_specular), an opaque gate (gz), then the map's expected value for a ray
    aimed at a target (fm_nee) or the chosen model's share.  itf (interface, m1, m2), specs (first, count)."""
    it, m1, m2 = itf
    scf, scn = specs
    for t in range(K):
        lt = int(HV[H_L, t])
        R, T, _a, _b, _c, _d, _e, _f, _g, _h = _specular(MD, it, cc, lt, ci, m1, m2)
        Rf = R
        if gz:
            R = 0.0
            T = 0.0
        D = 0.0
        kp = 1.0
        HV[H_E, t] = -1.0
        if F_MAPS and fm_nee:
            R, T = _nee_map_mix(SC, MD, scf, scn, ll, lt, cos_i, itf, R, T, Rf)
        elif F_SCATTER and sc >= 0 and SC.mod_slab[sc] == 1 and not nee:
            # _model_share's slab, with the direct beam and the delta's probability from the same call (the
            # plugin's albedo_parts), kept for _hero_diffuse
            Rb, Tb, e, pd = _bsdf_parts(SC.mod_kind[sc], SC.mod_P[sc].T, lt, cos_i)
            R = 0.0
            T = 0.0
            D = Rb + Tb
            if F_REFRACT and it == IF_FRESNEL and MD.n[m1, lt] != MD.n[m2, lt]:
                R = Rf
                D *= 1.0 - Rf
                kp = 1.0 - Rf
            HV[H_E, t] = e
            HV[H_Q, t] = pd
        elif F_SCATTER and sc >= 0:
            R, T, D, kp, _mk, _P = _model_share(SC, MD, sc, lt, cos_i, itf, R, T, Rf, nee)
        HV[H_R, t] = R
        HV[H_T, t] = T
        HV[H_D, t] = D
        HV[H_K, t] = kp
        HV[H_RF, t] = Rf


@numba.njit(cache=True, inline="always")
def _hero_choose(HV, K, hi, row):
    """The hero took the specular part `row` (H_R or H_T) with probability E_h / tot_h: each line's weight
    times E_t / that, its ratio times (E_t / tot_t) / that."""
    th = HV[H_R, hi] + HV[H_T, hi] + HV[H_D, hi]
    ph = HV[row, hi] / th
    for t in range(K):
        e = HV[row, t]
        tt = HV[H_R, t] + HV[H_T, t] + HV[H_D, t]
        HV[H_A, t] *= e / ph
        HV[H_S, t] *= (e / tt if tt > 0.0 else 0.0) / ph


@numba.njit(cache=True, inline="always")
def _hero_diffuse(HV, K, hi, mk, Pm, wi, wo, nv, cos_i, delta):
    """The hero took the diffuse part (probability D_h / tot_h) and its model drew wo (its pdf), or the model's
    delta (its unscattered beam, with the model's delta_prob): per line the integrand keep_t f_t |cos| (a delta:
    keep_t times the direct transmission) and the density (D_t / tot_t) pdf_t, over the hero's."""
    wix, wiy, wiz = wi
    wox, woy, woz = wo
    nvx, nvy, nvz = nv
    co = abs(wox * nvx + woy * nvy + woz * nvz)
    for t in range(K):
        lt = int(HV[H_L, t])
        tt = HV[H_R, t] + HV[H_T, t] + HV[H_D, t]
        f = 0.0
        p = 0.0
        if tt > 0.0 and HV[H_D, t] > 0.0:
            if delta and HV[H_E, t] >= 0.0:     # a slab's, from _hero_shares
                f = HV[H_K, t] * HV[H_E, t]
                p = HV[H_D, t] / tt * HV[H_Q, t]
            elif delta:
                f = HV[H_K, t] * _bsdf_direct(mk, Pm, lt, cos_i)
                p = HV[H_D, t] / tt * _bsdf_delta(mk, Pm, lt, cos_i)
            else:
                f = HV[H_K, t] * _bsdf_eval(mk, Pm, lt, wix, wiy, wiz, wox, woy, woz, nvx, nvy, nvz) * co
                p = HV[H_D, t] / tt * _bsdf_pdf(mk, Pm, lt, wix, wiy, wiz, wox, woy, woz, nvx, nvy, nvz)
        HV[H_F, t] = f
        HV[H_P, t] = p
    ph = HV[H_P, hi]
    for t in range(K):
        if ph > 0.0:
            HV[H_A, t] *= HV[H_F, t] / ph
            HV[H_S, t] *= HV[H_P, t] / ph
        else:       # (not for a sample the hero's model drew: a guard)
            HV[H_A, t] = 0.0


@numba.njit(cache=True, inline="always")
def _hero_toward(stack, sp, npath, led, c, r_imp, line, key, kc, mk, P, tgt, nr, nee_cut, o_bc, o_br, pos, d, nv,
                 o, j, opl, sx0, sy0, hist, H):
    """_bsdf_toward for a HERO ray: per line the candidate a_t (its base weight in row H_B) f_t |cos| Omega / nr,
    pushed with every line's weight (the stack's hero columns) and ratios, the hero's own weight as its scalar.
    The roulette below `nee_cut` must not depend on which line is the hero: it keeps a candidate with
    probability pi f_0 |cos| / cut, f_0 the model at the block's first line (what the one-line rule gives a ray
    of unit weight against a white Lambertian's), so the other lines' models are evaluated only for the
    candidates it keeps (most are not: a camera path sends one at every shell); where f_0 = 0 it decides on the
    lines' combined weight sum(a f) / sum(s) against sum(a) / sum(s) instead."""
    seed, i, ev, path = key
    phx, phy, phz, plx, ply, plz = pos
    dx, dy, dz = d
    nvx, nvy, nvz = nv
    K = int(stack[POOL, 2])
    hi = int(stack[POOL, 3])
    HB = SWP + H        # the stack's hero columns: a_t (KH), then s_t (KH)
    KH = (stack.shape[1] - HB) // 2
    bsum = 0.0
    ssum = 0.0
    for t in range(K):
        bsum += stack[H_B, t]
        ssum += stack[H_S, t]
    for q in range(nr):
        qd = kc + q
        v0, v1 = uniform2(seed, i, ev, path * 64 + 8 + 2 * qd)
        ox_, oy_, oz_, om = _toward(phx, phy, phz, plx, ply, plz, o_bc, o_br, tgt, v0, v1)
        co = abs(ox_ * nvx + oy_ * nvy + oz_ * nvz)
        g = co * om / nr
        kf = 1.0
        done = False
        if nee_cut > 0.0 and bsum > 0.0:
            f0 = _bsdf_eval(mk, P, int(stack[H_L, 0]), -dx, -dy, -dz, ox_, oy_, oz_, nvx, nvy, nvz)
            if f0 > 0.0:
                pk = math.pi * f0 * co / nee_cut
                if pk < 1.0:
                    kept, total = systematic_keep(stack[POOL, 0], pk, stack[POOL, 1])
                    stack[POOL, 0] = total
                    kf = 1.0 / pk if kept else 0.0
                done = True
        csum = 0.0
        if kf > 0.0:
            for t in range(K):
                f = _bsdf_eval(mk, P, int(stack[H_L, t]), -dx, -dy, -dz, ox_, oy_, oz_, nvx, nvy, nvz)
                stack[H_C, t] = stack[H_B, t] * f * g
                csum += stack[H_C, t]
            if nee_cut > 0.0 and not done and csum > 0.0:
                cs = csum / ssum
                kf = _nee_roulette(stack, cs, bsum / ssum * om / (math.pi * nr), nee_cut) / cs
        if kf > 0.0 and csum > 0.0 and sp < SMAX:
            if F_HISTORY and ev - 1 < H:
                hist[ev - 1] = o * 8 + EV_S
            cw = stack[H_C, hi] * kf
            _push(stack, sp, phx, phy, phz, plx, ply, plz, ox_, oy_, oz_, cw, csum * kf / ssum, ev, -1.0, 1.0, npath,
                  FL_SCATTERED, j, opl, sx0, sy0, hist, H, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            for t in range(K):
                stack[sp, HB + t] = stack[H_C, t] * kf
                stack[sp, HB + KH + t] = stack[H_S, t]
            sp += 1
            npath += 1
            led[c, r_imp, C_ABS, line] -= cw
        elif nee_cut > 0.0 and (done or csum > 0.0):
            npath += 1      # a candidate the roulette dropped keeps its path id (_nee_roulette)
    return sp, npath


@numba.njit(cache=True, inline="always")
def _hero_deposit(D, dd, HV, K, sx0, sy0):
    """A HERO ray reaches the camera trace's light (a DETECTOR ... START): line t of the block gains
    a_t / sum(s) times its QE, for the source ray's pixel (its start point's: the same for all its paths), added
    up over the source ray (_hero_emit writes them).  Returns the pixel (ix, iy), or (-1, -1) outside."""
    x0 = D.ext[dd, 0]
    x1 = D.ext[dd, 1]
    y0 = D.ext[dd, 2]
    y1 = D.ext[dd, 3]
    if not (sx0 >= x0 and sx0 <= x1 and sy0 >= y0 and sy0 <= y1):
        return -1, -1
    ix = min(D.nx[dd] - 1, int((sx0 - x0) / (x1 - x0) * D.nx[dd]))
    iy = min(D.ny[dd] - 1, int((sy0 - y0) / (y1 - y0) * D.ny[dd]))
    r = 0.0
    for t in range(K):
        r += HV[H_S, t]
    for t in range(K):
        HV[H_ACC, t] += HV[H_A, t] / r * D.qe[dd, int(HV[H_L, t])]
    return ix, iy


@numba.njit(cache=True, inline="always")
def _hero_emit(D, dd, ix, iy, HV, K, dep_idx, dep_w, dep_d, c, ndep, cap):
    """The end of a HERO source ray: its deposits, one per line of its block that gained any (then cleared)."""
    nx = D.nx[dd]
    ny = D.ny[dd]
    for t in range(K):
        v = HV[H_ACC, t]
        if v != 0.0:
            if ndep < cap:
                dep_idx[c, ndep] = D.off[dd] + (int(HV[H_L, t]) * ny + iy) * nx + ix
                dep_w[c, ndep] = v
                dep_d[c, ndep] = v
            ndep += 1
        HV[H_ACC, t] = 0.0
    return ndep


@numba.njit(cache=True, inline="always")
def _bsdf_toward(stack, sp, npath, led, c, r_imp, line, key, kc, mk, P, tgt, nr, w, nee_cut, o_bc, o_br, pos, d, nv,
                 pol, o, j, opl, sx0, sy0, hist, H):
    """Next-event estimation at a surface: nr rays toward the target's bounding sphere with the exact weights
    w f |cos| Omega / nr (w: the path's weight times the model's probability here), pushed on the stack and
    booked negative on the IMPORTANCE row.  Random stream path * 64 + 8 + 2 (kc + q) (+ 9 unused since the
    roulette became systematic, _nee_roulette: (event 0, dimension 7) of the source ray).  The ray's state
    comes as tuples: key (seed, ray, event, path), pos (double-double position), d, nv (the normal on the
    incoming side), pol (q, u, v, e1).  A HERO ray (K = stack[POOL, 2] > 0): each line's base weight in the
    stack's row H_B; _hero_toward sends the rays.  Returns (sp, npath)."""
    seed, i, ev, path = key
    phx, phy, phz, plx, ply, plz = pos
    dx, dy, dz = d
    nvx, nvy, nvz = nv
    stq, stu, stv, ex, ey, ez = pol
    if F_HERO and stack[POOL, 2] > 0.0:
        return _hero_toward(stack, sp, npath, led, c, r_imp, line, key, kc, mk, P, tgt, nr, nee_cut, o_bc, o_br, pos,
                            d, nv, o, j, opl, sx0, sy0, hist, H)
    for q in range(nr):
        qd = kc + q
        v0, v1 = uniform2(seed, i, ev, path * 64 + 8 + 2 * qd)
        ox_, oy_, oz_, om = _toward(phx, phy, phz, plx, ply, plz, o_bc, o_br, tgt, v0, v1)
        co = ox_ * nvx + oy_ * nvy + oz_ * nvz
        f = _bsdf_eval(mk, P, line, -dx, -dy, -dz, ox_, oy_, oz_, nvx, nvy, nvz)
        nq = nu = nv = nex = ney = nez = 0.0
        if F_POLAR:
            pf, nq, nu, nv, nex, ney, nez = _bsdf_mueller(mk, P, line, -dx, -dy, -dz, ox_, oy_, oz_, nvx, nvy, nvz,
                                                          stq, stu, stv, ex, ey, ez)
            f *= pf
        cw = w * f * abs(co) * om / nr
        cand = cw > 0.0
        if nee_cut > 0.0 and cand:
            cw = _nee_roulette(stack, cw, w * om / (math.pi * nr), nee_cut)
        if cw > 0.0 and sp < SMAX:
            if F_HISTORY and ev - 1 < H:
                hist[ev - 1] = o * 8 + EV_S
            _push(stack, sp, phx, phy, phz, plx, ply, plz, ox_, oy_, oz_, cw, cw, ev, -1.0, 1.0, npath, FL_SCATTERED, j,
                  opl, sx0, sy0, hist, H, nq, nu, nv, nex, ney, nez)
            sp += 1
            npath += 1
            led[c, r_imp, C_ABS, line] -= cw
        elif nee_cut > 0.0 and cand:
            npath += 1      # a candidate the roulette dropped keeps its path id (_nee_roulette)
    return sp, npath


@numba.njit(cache=True, inline="always")
def _volume_event(stack, sp, npath, led, c, rows, key, line, MD, m1, t, w, w0, cut, nee, o_bc, o_br, pos, d, pol,
                  opl, sx0, sy0, hist, H, state):
    """A ray crossing a scattering medium (VOLUME) of medium m1 toward a surface t away.  A ray aimed at a
    target is only attenuated.  Any other draws a free path; when it ends before the surface the ray scatters
    there: the albedo, rays toward the medium's target (_volume_toward), a new direction from the phase function,
    roulette.  rows (IMPORTANCE, HALTED), key (seed, ray, path), cut (halt, nee_cut), state (ev, excl, jlast,
    flags).  Returns (scattered, w, position (6), d (3), Stokes state (6), opl, ev, excl, jlast, flags, sp,
    npath)."""
    r_imp, r_halt = rows
    seed, i, path = key
    halt, nee_cut = cut
    phx, phy, phz, plx, ply, plz = pos
    dx, dy, dz = d
    stq, stu, stv, ex, ey, ez = pol
    ev, excl, jlast, flags = state
    scattered = False
    sig = MD.sig[m1, line]
    rm = MD.row[m1]
    if nee:
        keep = math.exp(-sig * t)      # rays aimed at a target are only attenuated
        led[c, rm, C_INC, line] += w
        led[c, rm, C_ABS, line] += w * (1.0 - keep)
        led[c, rm, C_TRA, line] += w * keep
        w *= keep
    else:
        uf, ua = uniform2(seed, i, ev, path * 64 + 60)
        sdist = -math.log(uf) / sig
        if sdist < t:
            # a scattering event inside the volume, before the surface
            scattered = True
            opl += MD.n[m1, line] * sdist
            phx, plx = _adv(phx, plx, sdist, dx)
            phy, ply = _adv(phy, ply, sdist, dy)
            phz, plz = _adv(phz, plz, sdist, dz)
            alb = MD.alb[m1, line]
            led[c, rm, C_INC, line] += w
            led[c, rm, C_SCA, line] += w * alb
            led[c, rm, C_ABS, line] += w * (1.0 - alb)
            w *= alb
            ev += 1
            if F_POLAR:
                ex, ey, ez = frame(dx, dy, dz, ex, ey, ez)
            pk = MD.phase[m1]
            gg = MD.g[m1, line]
            depol = MD.depol[m1]
            gam = depol / (2.0 - depol)
            tgt = MD.tgt[m1]
            if F_IMPORTANCE and tgt >= 0:
                sp, npath = _volume_toward(stack, sp, npath, led, c, r_imp, line, (seed, i, ev, path), MD.nee[m1],
                                           pk, gg, gam, depol, tgt, w, nee_cut, o_bc, o_br,
                                           (phx, phy, phz, plx, ply, plz), (dx, dy, dz), (stq, stu, stv, ex, ey, ez),
                                           opl, sx0, sy0, hist, H)
            v0, v1 = uniform2(seed, i, ev, path * 64 + 61)
            dx, dy, dz, ex, ey, ez, stq, stu, stv = _phase_turn(pk, gg, gam, depol, v0, v1, dx, dy, dz, ex, ey, ez,
                                                                stq, stu, stv)
            excl = tgt
            jlast = -1
            flags |= FL_SCATTERED
            if F_HISTORY and ev - 1 < H:
                hist[ev - 1] = -2      # a volume event
            # roulette on the volume path too
            if w > 0.0 and w < halt * w0:
                ur, _u = uniform2(seed, i, ev, path * 64 + 62)
                w, booked = _roulette(w, w0, halt, ur)
                led[c, r_halt, C_ABS, line] += booked
                if w == 0.0:
                    flags |= FL_HALTED
    return (scattered, w, phx, phy, phz, plx, ply, plz, dx, dy, dz, stq, stu, stv, ex, ey, ez, opl, ev, excl, jlast,
            flags, sp, npath)


@numba.njit(cache=True, inline="always")
def _has_fraction_map(SC, scf, scn):
    """Whether the SCATTER specs scf .. scf + scn - 1 include a fraction map (whose choice is random)."""
    for qq in range(scn):
        if SC.kind[scf + qq] == SPEC_FRACTION_MAP:
            return True
    return False


@numba.njit(cache=True, inline="always")
def _spec_share(SC, spn, lat, lon, preach):
    """The model that SCATTER spec spn gives at (lat, lon) and the probability that a hit uses it: preach is the
    probability that the specs before it passed the hit on.  A class map takes the whole rest (model -1: a class
    without a model), a fraction map the share v of it.  Returns (model, its probability, the rest's)."""
    kd = SC.kind[spn]
    pmix = preach
    mq = -1
    if kd != SPEC_MODEL:
        mp = SC.map[spn]
        vq = map_value(SC.map_data, SC.map_off[mp], SC.map_nlat[mp], SC.map_nlon[mp], lat, lon)
        if kd == SPEC_CLASS_MAP:
            cl = int(vq)
            if cl >= 0 and cl < SC.cls_n[spn]:
                mq = SC.cls_models[SC.cls_off[spn] + cl]
            preach = 0.0
        else:
            vq = min(max(vq, 0.0), 1.0)
            pmix = preach * vq
            mq = SC.model[spn]
            preach *= 1.0 - vq
    else:
        mq = SC.model[spn]
        preach = 0.0
    return mq, pmix, preach


@numba.njit(cache=True, inline="always")
def _model_share(SC, MD, sc, line, cos_i, geo, R, T, Rf, nee):
    """How scatter model sc shares a hit's light: the specular R and T it leaves and its diffuse part.  A slab
    model is the whole interaction (R = T = 0; for a ray aimed at a target T is its unscattered beam); on an index
    step (an atmosphere shell) the boundary's Fresnel reflection Rf comes first and the slab gets keep = 1 - Rf.
    A surface model of albedo rho leaves (1 - rho) of R and T.  A ray aimed at a target follows only the specular
    parts (diffuse 0).  geo (interface, m1, m2).  Returns (R, T, diffuse, keep, kind, P)."""
    it, m1, m2 = geo
    mk = SC.mod_kind[sc]
    Pm = SC.mod_P[sc].T       # (PMAX, L), line-major in memory (compile.pack)
    keep = 1.0
    if SC.mod_slab[sc] == 1:
        # a slab model is the whole interaction; its own sampling includes the direct beam.  A ray aimed at a
        # target takes only that beam: its albedo (a table interpolation) would not be used
        R = 0.0
        T = 0.0
        if nee:
            diffuse = 0.0
            T = _bsdf_direct(mk, Pm, line, cos_i)
        else:
            Rb, Tb = _bsdf_albedo(mk, Pm, line, cos_i)
            diffuse = Rb + Tb
        if F_REFRACT and it == IF_FRESNEL and MD.n[m1, line] != MD.n[m2, line]:
            # a slab on a boundary between two media (atmosphere shells): Fresnel reflection at the boundary
            # first, the slab takes the rest: its sampled scattering (_diffuse_scatter) and its rays toward
            # the target
            R = Rf
            T *= 1.0 - Rf
            diffuse *= 1.0 - Rf
            keep = 1.0 - Rf
    else:
        Rb, Tb = _bsdf_albedo(mk, Pm, line, cos_i)
        rho = min(1.0, Rb + Tb)
        R *= (1.0 - rho)
        T *= (1.0 - rho)
        diffuse = rho
    if nee:
        diffuse = 0.0      # rays aimed at a target follow only the specular parts
    return R, T, diffuse, keep, mk, Pm


@numba.njit(cache=True, inline="always")
def _nee_map_mix(SC, MD, scf, scn, ll, line, cos_i, geo, R, T, Rf):
    """A ray aimed at a target (next-event estimation) meets a hit whose SCATTER specs include a fraction map (a
    partly cloudy cell of a cloud shell): it takes the expected value over the map's choice, R = sum p_q R_q and
    T = sum p_q T_q over the models the hit may use (each as _model_share gives it for such a ray) and the
    interface alone for the rest, instead of drawing one (which made its transmission all or nothing: a cloud's
    unscattered beam or the clear sky).  Every choice continues the same way (the specular reflection or the
    transmission of the boundary, the same refraction and Mueller matrix): only the weight differs, so the mean
    is the same and the ledger books the expected shares.  ll (latitude, longitude), geo (interface, m1, m2),
    R and T the interface's, Rf the boundary's Fresnel reflectance.  Returns (R, T)."""
    lat, lon = ll
    preach = 1.0
    Rm = 0.0
    Tm = 0.0
    for qq in range(scn):
        mq, pmix, preach = _spec_share(SC, scf + qq, lat, lon, preach)
        if pmix > 0.0:
            if mq >= 0:
                Rq, Tq, _d, _k, _mk, _P = _model_share(SC, MD, mq, line, cos_i, geo, R, T, Rf, True)
            else:
                Rq = R
                Tq = T
            Rm += pmix * Rq
            Tm += pmix * Tq
        if preach <= 0.0:
            break
    return Rm + preach * R, Tm + preach * T


@numba.njit(cache=True, inline="always")
def _next_events(stack, sp, npath, led, c, r_imp, key, line, SC, MD, specs, chosen, nee, w, nee_cut, o_bc, o_br,
                 fres, ll, pos, d, nv, pol, o, j, opl, sx0, sy0, hist, H):
    """A hit's rays toward its targets (next-event estimation, exact weights), from the one call site of
    _bsdf_toward in the event loop (each inlined copy of it, HERO's per-line code included, costs the Earth's
    camera kernel about 14 s of its first compile).  Not for a ray itself aimed at a target.
    * Over a fraction map (the hit's SCATTER specs include one): every model the hit may use sends its rays
      toward its target, weighted by the probability that the hit uses it (the random choice in _scatter_spec
      still decides the path's continuation, which then sends none): the same expectation, without the variance
      of the choice (a partly cloudy pixel: cloud or not).
    * Otherwise the chosen model (chosen: its spec sc, RAYS n, TOWARD target, and _model_share's keep).
    A slab model on an index step (an atmosphere shell) sends w keep, keep = 1 - R_Fresnel (0 under total
    internal reflection): what the boundary lets in.  specs (first, count) of the hit's SCATTER specs, fres
    (interface, m1, m2, cos_i, Ar, Br, the boundary's unpolarized Fresnel R from _specular), ll: the hit's
    geodetic (latitude, longitude); o_bc, o_br: the objects' bounding spheres (apart, not as a tuple:
    docs/architecture.md).  Returns (sp, npath)."""
    if not F_IMPORTANCE or nee:
        return sp, npath
    scf, scn = specs
    sc, sc_n, sc_tgt, keep_m = chosen
    it, m1, m2, cos_i, Ar, Br, Rfr = fres
    ev_nee = F_MAPS and _has_fraction_map(SC, scf, scn)
    njobs = 0
    keep = 1.0      # over a map: a slab's share behind the boundary's Fresnel reflection
    if ev_nee:
        njobs = scn
        if F_REFRACT and it == IF_FRESNEL and MD.n[m1, line] != MD.n[m2, line]:
            if F_POLAR:
                keep = 1.0 - (Ar + Br * pol[0])
            else:
                keep = 1.0 - Rfr    # _specular's fresnel_unpolarized(cos_i, n1, n2), the same call
    elif F_SCATTER and sc >= 0 and sc_tgt >= 0:
        njobs = 1
    preach = 1.0
    kc = 0
    wq = 0.0
    for qq in range(njobs):
        if ev_nee:
            lat, lon = ll
            spn = scf + qq
            mq, pmix, preach = _spec_share(SC, spn, lat, lon, preach)
            tq = SC.tgt[spn]
            nr = SC.rays[spn]
            send = mq >= 0 and tq >= 0 and pmix > 0.0
            if send:
                wq = w * pmix * keep if SC.mod_slab[mq] == 1 else w * pmix
                if F_HERO and stack[POOL, 2] > 0.0:
                    # each line's share: its own Fresnel keep behind an index step (row H_RF)
                    for t in range(int(stack[POOL, 2])):
                        kt = 1.0
                        if SC.mod_slab[mq] == 1 and F_REFRACT and it == IF_FRESNEL:
                            lt = int(stack[H_L, t])
                            if MD.n[m1, lt] != MD.n[m2, lt]:
                                kt = 1.0 - stack[H_RF, t]
                        stack[H_B, t] = stack[H_A, t] * pmix * kt
        else:
            mq = sc
            tq = sc_tgt
            nr = sc_n
            send = True
            wq = w * keep_m
            if F_HERO and stack[POOL, 2] > 0.0:
                for t in range(int(stack[POOL, 2])):
                    stack[H_B, t] = stack[H_A, t] * stack[H_K, t]
        if send:
            sp, npath = _bsdf_toward(stack, sp, npath, led, c, r_imp, line, key, kc, SC.mod_kind[mq],
                                     SC.mod_P[mq].T, tq, nr, wq, nee_cut, o_bc, o_br, pos, d, nv, pol, o, j, opl,
                                     sx0, sy0, hist, H)
            kc += nr
        if ev_nee and preach <= 0.0:
            break
    return sp, npath


@numba.njit(cache=True, inline="always")
def _specular_turn(led, c, line, o, reflect, w, tot, ci, nw, d, pol, mueller, it, o_pol, MD, m12, nee, flags, excl):
    """The specular part chosen at a hit on object o: a mirror reflection, or a transmission (Snell refraction
    across an index step); the weight becomes w (R + T + diffuse) and the absorbed share is booked.  A polarized
    trace's Stokes state (q, u, v) goes through the interface's Mueller coefficients (mueller: Ar, Br, xr, yr
    for reflection, At, Bt, xt, yt for transmission, as _specular gives them).  Returns (w, d (3), q, u, v,
    flags, excl, event kind)."""
    nwx, nwy, nwz = nw
    dx, dy, dz = d
    stq, stu, stv = pol
    Ar, Br, xr, yr, At, Bt, xt, yt = mueller
    if reflect:
        led[c, o, C_REF, line] += w * tot
        led[c, o, C_ABS, line] += w * (1.0 - tot)
        w *= tot
        dx = dx + 2.0 * ci * nwx
        dy = dy + 2.0 * ci * nwy
        dz = dz + 2.0 * ci * nwz
        flags |= FL_REFLECTED
        evkind = EV_R
        excl = -1
        if F_POLAR:
            if it == IF_FRESNEL or it == IF_METAL or it == IF_SPLIT:
                _f, stq, stu, stv = diattenuate(stq, stu, stv, Ar, Br, xr, yr)
            else:
                stu = -stu      # INTERFACE REFLECT: a perfect mirror, Rs = Rp = 1, no
                stv = -stv      # retardance (Jones diag(1, -1) in the frames s, d x s)
    else:
        led[c, o, C_TRA, line] += w * tot
        led[c, o, C_ABS, line] += w * (1.0 - tot)
        w *= tot
        flags |= FL_TRANSMITTED
        evkind = EV_T
        if F_POLAR:
            if it == IF_FRESNEL:
                _f, stq, stu, stv = diattenuate(stq, stu, stv, At, Bt, xt, 0.0)
            elif it == IF_SPLIT:
                _f, stq, stu, stv = diattenuate(stq, stu, stv, At, Bt, xt, yt)
            elif it == IF_POLARIZER:
                stq = 1.0
                stu = 0.0
                stv = 0.0
            elif it == IF_RETARDER:
                cd = math.cos(o_pol[o, 1])
                sd = math.sin(o_pol[o, 1])
                stu, stv = stu * cd - stv * sd, stu * sd + stv * cd
        if F_REFRACT and it >= IF_SPLIT:
            m1, m2 = m12
            n1 = MD.n[m1, line]
            n2 = MD.n[m2, line]
            # rays aimed at a target cross weak index steps (gas layers) straight: their bending
            # (< NEE_STRAIGHT_DN tan(incidence)) would make them miss a target a few picoradians wide
            # (docs/tracer.md)
            if n1 != n2 and not (nee and abs(n1 - n2) < NEE_STRAIGHT_DN):
                dx, dy, dz, _tir = refract(dx, dy, dz, nwx, nwy, nwz, n1, n2)
                excl = -1
    return w, dx, dy, dz, stq, stu, stv, flags, excl, evkind


@numba.njit(cache=True, inline="always")
def _diffuse_scatter(stack, sp, npath, led, c, r_lost, key, line, MD, mk, Pm, spec, geo, nw, nv, wts, pos, d, pol,
                     opl, sx0, sy0, hist, H, state):
    """The diffuse part chosen at a hit: the model's own sampling (a slab's unscattered beam refracts at a shell's
    boundary); RAYS n without TOWARD splits into n paths, the first continuing here and the others pushed on the
    stack (no split once the source ray has MAX_PATHS paths or the stack has no room for the extra ones: going on
    as one ray is just as unbiased, and loses nothing).  spec (RAYS n, TOWARD target), geo (object, surface,
    interface, m1, m2), nw and nv (the normal and the normal on the incoming side), wts (w, w0, R + T + diffuse,
    diffuse, keep: the share of a slab model on an index step behind the boundary's Fresnel reflection, else 1),
    state (flags, excl).  Books the scattered, unscattered and absorbed flux.  Returns (w, w0, d (3), Stokes
    state (6), flags, excl, event kind, sp, npath)."""
    seed, i, ev, path = key
    sc_n, sc_tgt = spec
    o, j, it, m1, m2 = geo
    nwx, nwy, nwz = nw
    nvx, nvy, nvz = nv
    w, w0, tot, diffuse, keep = wts
    phx, phy, phz, plx, ply, plz = pos
    dx, dy, dz = d
    stq, stu, stv, ex, ey, ez = pol
    flags, excl = state
    nsplit = sc_n if sc_tgt < 0 and npath < MAX_PATHS and sp + sc_n <= SMAX + 1 else 1
    wi_x = -dx
    wi_y = -dy
    wi_z = -dz
    wout = 0.0
    wdelta = 0.0
    fq = fu = fv = fex = fey = fez = 0.0
    w_first = 0.0
    first_delta = False
    for q in range(nsplit):
        v0, v1 = uniform2(seed, i, ev, path * 64 + 1 + 2 * q)
        v2, _v = uniform2(seed, i, ev, path * 64 + 2 + 2 * q)
        sx, sy, sz, sw, sdelta = _bsdf_sample(mk, Pm, line, wi_x, wi_y, wi_z, nvx, nvy, nvz, v0, v1, v2)
        if F_REFRACT and sdelta and it == IF_FRESNEL and MD.n[m1, line] != MD.n[m2, line]:
            # a slab's unscattered beam crosses the boundary: Snell refraction
            sx, sy, sz, _tir = refract(sx, sy, sz, nwx, nwy, nwz, MD.n[m1, line], MD.n[m2, line])
        cw = w * sw * tot / diffuse / nsplit
        if keep != 1.0:
            cw *= keep      # a slab on an index step: diffuse = (its albedo) keep, its samples' weights too
        nq = stq
        nu = stu
        nv_ = stv
        nex = ney = nez = 0.0
        if F_POLAR:
            if sdelta:      # a slab's unscattered beam keeps its state
                nex, ney, nez = frame(sx, sy, sz, ex, ey, ez)
            else:           # the model's Mueller matrix (depolarizing unless it has one)
                pf, nq, nu, nv_, nex, ney, nez = _bsdf_mueller(mk, Pm, line, wi_x, wi_y, wi_z, sx, sy, sz, nvx, nvy,
                                                               nvz, stq, stu, stv, ex, ey, ez)
                cw *= pf
        wout += cw
        if sdelta:
            wdelta += cw
        if q == 0:
            dx = sx
            dy = sy
            dz = sz
            w_first = cw
            first_delta = sdelta
            fq = nq
            fu = nu
            fv = nv_
            fex = nex
            fey = ney
            fez = nez
        elif cw > 0.0 and sp < SMAX:
            if F_HISTORY and ev - 1 < H:
                hist[ev - 1] = o * 8 + EV_S
            _push(stack, sp, phx, phy, phz, plx, ply, plz, sx, sy, sz, cw, w0 / nsplit, ev, sc_tgt, 0.0, npath,
                  flags | FL_SCATTERED, j, opl, sx0, sy0, hist, H, nq, nu, nv_, nex, ney, nez)
            sp += 1
            npath += 1
        elif cw > 0.0:
            led[c, r_lost, C_ABS, line] += cw   # no room on the stack: counted as lost
    led[c, o, C_SCA, line] += wout - wdelta
    led[c, o, C_TRA, line] += wdelta     # a slab's unscattered beam
    led[c, o, C_ABS, line] += w - wout
    w = w_first
    w0 = w0 / nsplit
    if F_POLAR:
        stq = fq
        stu = fu
        stv = fv
        ex = fex
        ey = fey
        ez = fez
    if first_delta:
        flags |= FL_TRANSMITTED
        evkind = EV_T
    else:
        flags |= FL_SCATTERED
        evkind = EV_S
        excl = sc_tgt
    # a model's sample is made unit here (a reflection off a unit normal and `refract`, which normalizes, keep
    # |d| = 1 to rounding: 1e-16 per event, not renormalized)
    dd2 = dx * dx + dy * dy + dz * dz
    if dd2 > 0.0 and dd2 != 1.0:
        g = 1.0 / math.sqrt(dd2)
        dx *= g
        dy *= g
        dz *= g
    if F_POLAR:
        ex, ey, ez = frame(dx, dy, dz, ex, ey, ez)
    return w, w0, dx, dy, dz, stq, stu, stv, ex, ey, ez, flags, excl, evkind, sp, npath


@numba.njit(cache=True, inline="always")
def _record(rec_pos, rec_dir, rec_w, rec_line, rec_src, rec_obj, rec_ev, rec_flags, rec_hist, rec_opl, rec_start, c,
            nrec, hit, adir, aw, line, s, last, ev, flags, opl, sx0, sy0, hist, H):
    """A path's record (its last hit, or its start when it hit nothing; `hit` its double-double position (hi,
    lo parts), `adir` the direction there): the Records layout."""
    hx, hy, hz, hlx, hly, hlz = hit
    adx, ady, adz = adir
    rec_pos[c, nrec, 0] = hx
    rec_pos[c, nrec, 1] = hy
    rec_pos[c, nrec, 2] = hz
    if rec_pos.shape[2] >= 6:
        # the low part of the double-double position: hx + hlx is exact to ~1e-16 relative
        rec_pos[c, nrec, 3] = hlx
        rec_pos[c, nrec, 4] = hly
        rec_pos[c, nrec, 5] = hlz
    rec_dir[c, nrec, 0] = adx
    rec_dir[c, nrec, 1] = ady
    rec_dir[c, nrec, 2] = adz
    rec_w[c, nrec] = aw
    rec_line[c, nrec] = line
    rec_src[c, nrec] = s
    rec_obj[c, nrec] = last
    rec_ev[c, nrec] = ev
    rec_flags[c, nrec] = flags
    rec_opl[c, nrec] = opl
    rec_start[c, nrec, 0] = sx0
    rec_start[c, nrec, 1] = sy0
    for h in range(H):
        rec_hist[c, nrec, h] = int(hist[h])


@numba.njit(cache=True, inline="always")
def _close_source_ray(inc_sq, c, line, acc, touched, nt):
    """The squares of the whole source ray's incident flux per object (its split paths and rays toward targets
    are correlated: squaring each incidence alone would underestimate the standard error)."""
    for q in range(nt):
        inc_sq[c, touched[q], line] += acc[touched[q]] * acc[touched[q]]
        acc[touched[q]] = 0.0


@numba.njit(cache=True, inline="always")
def _close_pair(inc_sq, c, line0, line, acc0, acc, touched, nt):
    """The second ray of a stratified pair (camera DIRECTIONS): the squares of the pair's difference per object
    (E (a - b)^2 = 2 var within the stratum, so the sum over pairs estimates the variance of the total without
    the spread between strata); rays of different lines are different tallies (a - 0 and 0 - b).  `touched` may
    name an object twice (once per ray): the second time finds it zeroed."""
    for q in range(nt):
        o = touched[q]
        a = acc0[o]
        b = acc[o]
        if line0 == line:
            inc_sq[c, o, line] += (a - b) * (a - b)
        else:
            inc_sq[c, o, line0] += a * a
            inc_sq[c, o, line] += b * b
        acc0[o] = 0.0
        acc[o] = 0.0


@numba.njit(cache=True, inline="always")
def _merge_deposits(dep_idx, dep_w, dep_d, c, dep0, ndep):
    """One deposit per pixel and source ray, or per stratified pair (reduce_batch adds dep_w and squares dep_d):
    merge entries dep0 .. ndep - 1 that share a pixel, in first-seen order.  Returns the new count."""
    kk = dep0
    for qa in range(dep0, ndep):
        qb = dep0
        while qb < kk and dep_idx[c, qb] != dep_idx[c, qa]:
            qb += 1
        if qb < kk:
            dep_w[c, qb] += dep_w[c, qa]
            dep_d[c, qb] += dep_d[c, qa]
        else:
            dep_idx[c, kk] = dep_idx[c, qa]
            dep_w[c, kk] = dep_w[c, qa]
            dep_d[c, kk] = dep_d[c, qa]
            kk += 1
    return kk



@numba.njit(cache=True, parallel=True)
def trace_batch(settings, S, O, SC, MD, D, SRC, T, REC):
    """Trace source rays first .. first+n-1 with every path they spawn.  Per chunk c: led[c] (rows, 5, L),
    inc_sq[c] (rows, L), deposits dep_idx/dep_w[c, :dep_n[c]] and records rec_*[c, :rec_n[c]] (one per
    path end); a count of -1 marks a chunk that overflowed its list (the caller retries with more room).
    Rows: objects, absorbing media, [IMPORTANCE], EMITTED, ESCAPED, HALTED, LOST (the last four).
    The arguments are the structures of ``irtlang.kernels.layout`` (Settings, Surfaces, Objects, Scatter, Media,
    Detectors, Sources, Tallies, Records).  Their fields become locals before the parallel loop, so that the loop
    takes plain arrays: writes into an array reached through a tuple inside a parallel loop are lost, and a
    parallel loop over tuples of arrays ran 20 % slower.  The structures the helpers read are rebuilt per chunk
    from these locals."""
    first = settings.first; n = settings.n; total = settings.total; seed = settings.seed; level = settings.level
    halt = settings.halt; nee_cut = settings.nee_cut; r_imp = settings.r_imp
    s_f = S.f; s_i = S.i; s_mesh = S.mesh; s_bmin = S.bmin; s_bmax = S.bmax; s_child = S.child; s_count = S.count
    s_tris = S.tris; s_ids = S.ids; s_fn = S.fn
    o_itf = O.itf; o_coat = O.coat; o_back = O.back; o_front = O.front; o_det = O.det; o_pol = O.pol; o_bc = O.bc
    o_br = O.br; o_sc_first = O.sc_first; o_sc_cnt = O.sc_cnt
    sp_kind = SC.kind; sp_model = SC.model; sp_map = SC.map; sp_cls_off = SC.cls_off; sp_cls_n = SC.cls_n
    sp_rays = SC.rays; sp_tgt = SC.tgt; cls_models = SC.cls_models; map_data = SC.map_data; map_off = SC.map_off
    map_nlat = SC.map_nlat; map_nlon = SC.map_nlon; mod_kind = SC.mod_kind; mod_P = SC.mod_P; mod_slab = SC.mod_slab
    med_n = MD.n; med_alpha = MD.alpha; med_row = MD.row; med_sig = MD.sig; med_alb = MD.alb; med_g = MD.g
    med_phase = MD.phase; med_depol = MD.depol; med_tgt = MD.tgt; med_nee = MD.nee; md_coat_R = MD.coat_R
    md_coat_T = MD.coat_T
    d_nx = D.nx; d_ny = D.ny; d_ext = D.ext; d_off = D.off; d_qe = D.qe; d_start = D.start
    src_kind = SRC.kind; src_dir = SRC.dir; src_par = SRC.par; src_R = SRC.R; src_Th = SRC.Th; src_Tl = SRC.Tl
    src_n = SRC.n; src_off = SRC.off; src_w = SRC.w; src_random = SRC.random; src_toward = SRC.toward
    src_pts = SRC.pts; src_pts_off = SRC.pts_off; src_lmap = SRC.lmap
    led = T.led; inc_sq = T.inc_sq; dep_idx = T.dep_idx; dep_w = T.dep_w; dep_d = T.dep_d; dep_n = T.dep_n
    rec_pos = REC.pos; rec_dir = REC.dir; rec_w = REC.w; rec_line = REC.line; rec_src = REC.src; rec_obj = REC.obj
    rec_ev = REC.ev; rec_flags = REC.flags; rec_hist = REC.hist; rec_opl = REC.opl; rec_start = REC.start
    rec_n = REC.n
    nrows = led.shape[1]
    r_emit = nrows - 4
    r_esc = nrows - 3
    r_halt = nrows - 2
    r_lost = nrows - 1
    nchunks = (n + CHUNK - 1) // CHUNK
    cap = dep_idx.shape[1]
    rcap = rec_w.shape[1]
    H = rec_hist.shape[2]
    src_dw = _collimated_dirs(SRC)
    # HERO K: the largest block a source's rays carry (the scratch rows and the stack's hero columns)
    KH = 1
    if F_HERO:
        for s_ in range(src_par.shape[0]):
            KH = max(KH, int(src_par[s_, SP_HERO]))
    HB = SWP + H        # the stack's hero columns: a_t (KH), then s_t (KH)
    # Numba's parallel loop gives each thread one contiguous block of its indices (its set_parallel_chunksize
    # changed nothing here), while neighbouring chunks cost alike and far ones not (an image's upper and lower
    # rows, a spectrum's short and long lines): the loop index is spread over the chunks by a stride coprime
    # with their number.  Each chunk keeps its own slots and the reduction adds them in chunk order, so the
    # results do not depend on which thread traces which chunk.
    stride = _spread_stride(nchunks)
    for cc in numba.prange(nchunks):
        c = (cc * stride) % nchunks
        # the structures the helpers read, rebuilt from the locals above (see the docstring)
        S = Surfaces(s_f, s_i, s_mesh, s_bmin, s_bmax, s_child, s_count, s_tris, s_ids, s_fn)
        SC = Scatter(sp_kind, sp_model, sp_map, sp_cls_off, sp_cls_n, sp_rays, sp_tgt, cls_models, map_data,
            map_off, map_nlat, map_nlon, mod_kind, mod_P, mod_slab)
        MD = Media(med_n, med_alpha, med_row, med_sig, med_alb, med_g, med_phase, med_depol, med_tgt, med_nee,
            md_coat_R, md_coat_T)
        D = Detectors(d_nx, d_ny, d_ext, d_off, d_qe, d_start)
        SRC = Sources(src_kind, src_dir, src_par, src_R, src_Th, src_Tl, src_n, src_off, src_w, src_random,
            src_toward, src_pts, src_pts_off, src_lmap)
        ndep = 0
        nrec = 0
        # + the row POOL; HERO: the hero columns (a_t, s_t of each entry) and the rows H_A ..
        stack = np.empty((SMAX + 1 + (N_HERO_ROWS if F_HERO else 0), SWP + H + (2 * KH if F_HERO else 0)))
        HV = stack
        hist = np.full(max(H, 1), -1.0)
        Pm = mod_P[0].T
        # per source ray: incident flux per object, so that inc_sq and the images' squares sum the squares of
        # whole source-ray contributions (split paths, rays sent toward a target and repeated hits of one
        # source ray are correlated: squaring each incidence alone underestimates the standard error)
        acc = np.zeros(nrows)
        touched = np.empty(2 * nrows, np.int64)     # twice: a stratified pair's two rays
        acc0 = np.zeros(nrows)      # a pair's first ray's (camera DIRECTIONS)
        line0 = 0
        dep1 = 0
        nt = 0
        dep0 = 0
        for ii in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            i = first + ii
            # i: from here on the ray's random stream (its id, or a CORRELATED camera's shared one)
            s, line, phx, phy, phz, plx, ply, plz, dx, dy, dz, w, sx0, sy0, pm, i = _gen(i, total, seed, SRC, o_bc,
                                                                                         o_br, src_dw)
            led[c, r_emit, C_INC, line] += w
            HK = 0      # HERO: the lines this source ray carries (0: one, `line`), the hero's place among them
            hi = 0
            hdd = -1    # and the detector and pixel of its deposits (_hero_deposit)
            hix = 0
            hiy = 0
            if F_HERO and src_par[s, SP_HERO] > 1.0:
                HK, hi = _hero_start(SRC, s, first + ii, total, seed, line, w, HV)
            if F_HERO:
                stack[POOL, 2] = HK
                stack[POOL, 3] = hi
            if pm != 2:         # a pair's second ray adds to its first's tallies (_close_pair)
                nt = 0
                dep0 = ndep
            for h in range(H):
                hist[h] = -1.0
            if F_IMPORTANCE and nee_cut > 0.0:
                # the source ray's next-event roulette: nothing drawn yet, and its one uniform (_nee_roulette)
                stack[POOL, 0] = 0.0
                stack[POOL, 1] = uniform2(seed, i, 0, 7)[0]
            # the source ray's own path starts from these locals; split paths and rays sent toward a target
            # wait on the stack (the same state a push/pop would give, without the 2 x 20 memory moves)
            w0 = w
            if F_HERO and HK > 0:
                w0 = _hero_combined(HV, HK)     # the roulette's reference: the lines' combined weight
            ev = 0
            excl = -1
            nee = False
            path = 0
            flags = 0
            jlast = -1
            opl = 0.0
            # Stokes: unpolarized light, any reference vector perpendicular to d
            stq = 0.0
            stu = 0.0
            stv = 0.0
            ex = 0.0
            ey = 0.0
            ez = 0.0
            if F_POLAR:
                ex, ey, ez = frame(dx, dy, dz, 0.0, 0.0, 0.0)
            sp = 0
            npath = 1
            from_stack = False
            while not from_stack or sp > 0:
                if not from_stack:
                    from_stack = True
                else:
                    sp -= 1
                    (phx, phy, phz, plx, ply, plz, dx, dy, dz, w, w0, ev, excl, nee, path, flags, jlast, opl, sx0,
                     sy0, stq, stu, stv, ex, ey, ez) = _pop(stack, sp, hist, H, stq, stu, stv, ex, ey, ez)
                    if F_HERO and HK > 0:
                        for tq_ in range(HK):
                            HV[H_A, tq_] = stack[sp, HB + tq_]
                            HV[H_S, tq_] = stack[sp, HB + KH + tq_]
                last = -1
                hx = phx + plx
                hy = phy + ply
                hz = phz + plz
                hlx = plx - (hx - phx)      # what the double hx leaves out: records keep it (far scenes)
                hly = ply - (hy - phy)
                hlz = plz - (hz - phz)
                adx = dx
                ady = dy
                adz = dz
                aw = w
                if w == 0.0 and not (F_HERO and HK > 0 and _hero_alive(HV, HK)):
                    flags |= FL_ESCAPED
                while w > 0.0 or (F_HERO and HK > 0 and _hero_alive(HV, HK)):
                    if ev >= level:
                        led[c, r_halt, C_ABS, line] += w
                        flags |= FL_HALTED
                        break
                    t, j, lx, ly, lz, face = _nearest(phx, phy, phz, plx, ply, plz, dx, dy, dz, s_f, s_i, S, jlast)
                    if j < 0:
                        led[c, r_esc, C_ABS, line] += w
                        flags |= FL_ESCAPED
                        break
                    k = s_i[j, SI_KIND]
                    nwx, nwy, nwz = _normal(j, k, lx, ly, lz, face, s_f, s_i, S)
                    o = s_i[j, SI_OBJ]
                    ci = -(dx * nwx + dy * nwy + dz * nwz)
                    if not (math.isfinite(t) and math.isfinite(ci)):
                        led[c, r_lost, C_ABS, line] += w
                        flags |= FL_LOST
                        break
                    front = ci > 0.0            # arriving on the side the normal points to
                    it = o_itf[o]
                    m1 = o_front[o] if front else o_back[o]
                    m2 = o_back[o] if front else o_front[o]
                    if F_VOLUME and it >= IF_SPLIT and med_sig[m1, line] > 0.0:
                        # a scattering medium: attenuation, or a scattering event before the surface
                        (scattered, w, phx, phy, phz, plx, ply, plz, dx, dy, dz, stq, stu, stv, ex, ey, ez, opl, ev,
                         excl, jlast, flags, sp, npath) = _volume_event(
                            stack, sp, npath, led, c, (r_imp, r_halt), (seed, i, path), line, MD, m1, t, w, w0,
                            (halt, nee_cut), nee, o_bc, o_br, (phx, phy, phz, plx, ply, plz), (dx, dy, dz),
                            (stq, stu, stv, ex, ey, ez), opl, sx0, sy0, hist, H, (ev, excl, jlast, flags))
                        if scattered:
                            continue
                    if F_ABSORB_MEDIA and it >= IF_SPLIT:
                        a = med_alpha[m1, line]
                        if F_HERO and HK > 0:
                            for tt_ in range(HK):
                                HV[H_A, tt_] *= math.exp(-med_alpha[m1, int(HV[H_L, tt_])] * t)
                        if a > 0.0:
                            keep = math.exp(-a * t)
                            led[c, med_row[m1], C_INC, line] += w
                            led[c, med_row[m1], C_ABS, line] += w * (1.0 - keep)
                            led[c, med_row[m1], C_TRA, line] += w * keep
                            w *= keep
                    phx, plx = _adv(phx, plx, t, dx)
                    phy, ply = _adv(phy, ply, t, dy)
                    phz, plz = _adv(phz, plz, t, dz)
                    opl += med_n[m1, line] * t
                    if not (math.isfinite(phx) and math.isfinite(phy) and math.isfinite(phz)):
                        led[c, r_lost, C_ABS, line] += w
                        flags |= FL_LOST
                        break
                    if F_IMPORTANCE and excl == o:
                        # a path whose direct arrival here is already counted by the rays sent TOWARD it
                        led[c, r_imp, C_ABS, line] += w
                        w = 0.0
                        break
                    led[c, o, C_INC, line] += w
                    # (a HERO ray goes on where its hero's own weight is 0: it adds nothing, and must not take a
                    # second place in `touched`)
                    if not (F_HERO and w == 0.0):
                        if acc[o] == 0.0:
                            touched[nt] = o
                            nt += 1
                        acc[o] += w
                    hx = phx + plx
                    hy = phy + ply
                    hz = phz + plz
                    hlx = plx - (hx - phx)
                    hly = ply - (hy - phy)
                    hlz = plz - (hz - phz)
                    adx = dx
                    ady = dy
                    adz = dz
                    aw = w
                    last = o
                    dd = o_det[o]
                    if F_HERO and HK > 0 and dd >= 0:
                        hix, hiy = _hero_deposit(D, dd, HV, HK, sx0, sy0)
                        if hix >= 0:
                            hdd = dd
                    elif dd >= 0:
                        ndep, ex, ey, ez = _deposit(D, dd, dep_idx, dep_w, dep_d, c, ndep, cap, line, led.shape[3], w,
                                                    lx, ly, sx0, sy0, s_f, j, dx, dy, dz, ex, ey, ez, stq, stu, stv)
                    # the interface: specular R and T, absorbed A (HERO_SHARES: from _hero_shares below)
                    if HERO_SHARES:
                        R = T = Ar = Br = xr = yr = At = Bt = xt = yt = 0.0
                    else:
                        R, T, Ar, Br, xr, yr, At, Bt, xt, yt = _specular(MD, it, o_coat[o], line, ci, m1, m2)
                    Rfr = R     # an IF_FRESNEL boundary's unpolarized R, kept for its slab model's share
                    if F_POLAR:
                        R, T, stq, stu, ex, ey, ez = _interface_frame(it, o_pol, o, s_f, j, dx, dy, dz, nwx, nwy, nwz,
                                                                      ex, ey, ez, stq, stu, R, T, Ar, Br, At, Bt)
                    ev += 1
                    evkind = EV_A
                    scf = o_sc_first[o]
                    scn = o_sc_cnt[o]
                    # the hit's geodetic latitude and longitude, once, when a map of the object is looked up
                    glat = 0.0
                    glon = 0.0
                    if F_MAPS and scn > 0:
                        for qq in range(scn):
                            if sp_kind[scf + qq] != SPEC_MODEL:
                                glat, glon = geodetic(lx, ly, lz)
                                break
                    gz = False      # HERO: an opaque gate zeroes every line's R and T
                    if F_MAPS and scn > 0 and sp_kind[scf] == SPEC_GATE:
                        if HERO_SHARES:
                            gm_ = sp_map[scf]
                            gz = map_value(map_data, map_off[gm_], map_nlat[gm_], map_nlon[gm_], glat, glon) > 0.5
                            scf += 1        # _gate's: the gate's models where it is 1, clear air elsewhere
                            scn = scn - 1 if gz else 0
                        else:
                            if F_HERO and HK > 0:
                                gm_ = sp_map[scf]
                                gz = map_value(map_data, map_off[gm_], map_nlat[gm_], map_nlon[gm_], glat, glon) > 0.5
                            R, T, scf, scn = _gate(SC, scf, scn, (glat, glon), R, T)
                    # which scatter model applies here: an object's SCATTER specs, tried in order
                    mk = 0
                    cos_i = abs(ci)
                    fm_nee = F_MAPS and nee and _has_fraction_map(SC, scf, scn)
                    if fm_nee:
                        # a ray aimed at a target: the expected value over the map's choice (_nee_map_mix)
                        if not HERO_SHARES:
                            R, T = _nee_map_mix(SC, MD, scf, scn, (glat, glon), line, cos_i, (it, m1, m2), R, T,
                                                Ar + Br * stq if F_POLAR else Rfr)
                        sc = -1
                        sc_n = 1
                        sc_tgt = -1
                    else:
                        sc, sc_n, sc_tgt = _scatter_spec(SC, scf, scn, (glat, glon), seed, i, ev, path)
                    nvx = nwx if front else -nwx      # the normal on the incoming side
                    nvy = nwy if front else -nwy
                    nvz = nwz if front else -nwz
                    diffuse = 0.0
                    slab_keep = 1.0
                    if HERO_SHARES:
                        # every line's shares, the ray's own (its hero's, or its one line's) among them: the
                        # same calls as below, bit for bit
                        k1 = HK
                        h1 = hi
                        if HK == 0:
                            HV[H_L, 0] = line
                            k1 = 1
                            h1 = 0
                        _hero_shares(HV, k1, SC, MD, (it, m1, m2), o_coat[o], ci, gz, fm_nee, (scf, scn),
                                     (glat, glon), sc, cos_i, nee)
                        R = HV[H_R, h1]
                        T = HV[H_T, h1]
                        Rfr = HV[H_RF, h1]
                        if F_SCATTER and sc >= 0:
                            diffuse = HV[H_D, h1]
                            slab_keep = HV[H_K, h1]
                            mk = SC.mod_kind[sc]
                            Pm = SC.mod_P[sc].T
                    else:
                        if F_HERO and HK > 0:
                            _hero_shares(HV, HK, SC, MD, (it, m1, m2), o_coat[o], ci, gz, fm_nee, (scf, scn),
                                         (glat, glon), sc, cos_i, nee)
                        if F_SCATTER and sc >= 0:
                            # the model's share of the light (R, T and diffuse); the boundary's Fresnel R first (a
                            # slab on an index step takes only what the boundary lets in)
                            R, T, diffuse, slab_keep, mk, Pm = _model_share(SC, MD, sc, line, cos_i, (it, m1, m2),
                                                                            R, T, Ar + Br * stq if F_POLAR else Rfr,
                                                                            nee)
                    # the rays toward the targets: the chosen model's, or over a fraction map every model's
                    sp, npath = _next_events(stack, sp, npath, led, c, r_imp, (seed, i, ev, path), line, SC, MD,
                                             (scf, scn), (sc, sc_n, sc_tgt, slab_keep), nee, w, nee_cut, o_bc, o_br,
                                             (it, m1, m2, cos_i, Ar, Br, Rfr), (glat, glon),
                                             (phx, phy, phz, plx, ply, plz), (dx, dy, dz), (nvx, nvy, nvz),
                                             (stq, stu, stv, ex, ey, ez), o, j, opl, sx0, sy0, hist, H)
                    tot = R + T + diffuse
                    if tot <= 0.0:
                        led[c, o, C_ABS, line] += w
                        w = 0.0
                        if F_HERO and HK > 0:
                            for tq_ in range(HK):
                                HV[H_A, tq_] = 0.0
                    else:
                        u, _u = uniform2(seed, i, ev, path * 64) if (R > 0.0) + (T > 0.0) + (diffuse > 0.0) > 1 \
                            else (0.5, 0.5)
                        x_ = u * tot
                        if x_ < R + T:
                            if F_HERO and HK > 0:
                                _hero_choose(HV, HK, hi, H_R if x_ < R else H_T)
                            w, dx, dy, dz, stq, stu, stv, flags, excl, evkind = _specular_turn(
                                led, c, line, o, x_ < R, w, tot, ci, (nwx, nwy, nwz), (dx, dy, dz), (stq, stu, stv),
                                (Ar, Br, xr, yr, At, Bt, xt, yt), it, o_pol, MD, (m1, m2), nee, flags, excl)
                        else:
                            odx = dx
                            ody = dy
                            odz = dz
                            (w, w0, dx, dy, dz, stq, stu, stv, ex, ey, ez, flags, excl, evkind, sp,
                             npath) = _diffuse_scatter(stack, sp, npath, led, c, r_lost, (seed, i, ev, path), line, MD,
                                                       mk, Pm, (sc_n, sc_tgt), (o, j, it, m1, m2), (nwx, nwy, nwz),
                                                       (nvx, nvy, nvz), (w, w0, tot, diffuse, slab_keep),
                                                       (phx, phy, phz, plx, ply, plz), (dx, dy, dz),
                                                       (stq, stu, stv, ex, ey, ez), opl, sx0, sy0, hist, H,
                                                       (flags, excl))
                            if F_HERO and HK > 0:
                                _hero_diffuse(HV, HK, hi, mk, Pm, (-odx, -ody, -odz), (dx, dy, dz), (nvx, nvy, nvz),
                                              cos_i, evkind == EV_T)
                    if F_HISTORY and ev - 1 < H:
                        hist[ev - 1] = o * 8 + evkind
                    jlast = j      # the surface just left: its departure root is dropped on the next search
                    # Russian roulette
                    if F_HERO and HK > 0:
                        # on the lines' combined weight (the same whichever line is the hero): the survivors'
                        # weights, the hero's included, grow by 1 / p; the ratios s_t do not change
                        wc = _hero_combined(HV, HK)
                        if wc > 0.0 and wc < halt * w0:
                            ur, _u = uniform2(seed, i, ev, path * 64 + 63)
                            pq = wc / (halt * w0)
                            if ur < pq:
                                for tq_ in range(HK):
                                    HV[H_A, tq_] /= pq
                                led[c, r_halt, C_ABS, line] -= w / pq - w
                                w /= pq
                            else:
                                for tq_ in range(HK):
                                    HV[H_A, tq_] = 0.0
                                led[c, r_halt, C_ABS, line] += w
                                w = 0.0
                                flags |= FL_HALTED
                    elif w > 0.0 and w < halt * w0:
                        ur, _u = uniform2(seed, i, ev, path * 64 + 63)
                        w, booked = _roulette(w, w0, halt, ur)
                        led[c, r_halt, C_ABS, line] += booked
                        if w == 0.0:
                            flags |= FL_HALTED
                if F_RECORDS:
                    if nrec < rcap:
                        _record(rec_pos, rec_dir, rec_w, rec_line, rec_src, rec_obj, rec_ev, rec_flags, rec_hist,
                                rec_opl, rec_start, c, nrec, (hx, hy, hz, hlx, hly, hlz), (adx, ady, adz), aw, line,
                                s, last, ev, flags, opl, sx0, sy0, hist, H)
                    nrec += 1
            if F_HERO and HK > 0 and hdd >= 0:
                ndep = _hero_emit(D, hdd, hix, hiy, HV, HK, dep_idx, dep_w, dep_d, c, ndep, cap)
            if F_CAMERA and pm == 1:
                # the first ray of a stratified pair: its tallies wait for the second's
                for q in range(nt):
                    acc0[touched[q]] = acc[touched[q]]
                    acc[touched[q]] = 0.0
                line0 = line
                dep1 = ndep
                continue
            if F_CAMERA and pm == 2:
                _close_pair(inc_sq, c, line0, line, acc0, acc, touched, nt)
                for q in range(dep1, min(ndep, cap)):
                    dep_d[c, q] = -dep_d[c, q]
            else:
                _close_source_ray(inc_sq, c, line, acc, touched, nt)
            if ndep - dep0 > 1 and ndep <= cap:
                ndep = _merge_deposits(dep_idx, dep_w, dep_d, c, dep0, ndep)
                if F_CAMERA and (pm == 2 or HK > 0):
                    # one group: reduce_batch squares the pair's difference per image, summed over its lines
                    # (a HERO source ray without a pair: its own lines' sum per image, they share its path)
                    for q in range(dep0 + 1, ndep):
                        dep_idx[c, q] = -dep_idx[c, q] - 1
        dep_n[c] = ndep if ndep <= cap else -1
        rec_n[c] = nrec if nrec <= rcap else -1


@numba.njit(cache=True)
def _spread_stride(n):
    """The smallest odd integer not below floor(0.618 n) that is coprime with n (1 for n <= 2): c = (k stride)
    mod n is then a permutation of 0 .. n - 1 that scatters every run of consecutive k over the whole range."""
    if n <= 2:
        return 1
    s = int(0.6180339887498949 * n) | 1
    while math.gcd(s, n) != 1:
        s += 2
    return s
