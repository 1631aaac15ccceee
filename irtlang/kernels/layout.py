"""The packed scene as the trace kernel reads it: every table, column and code, defined once.

``irtlang.compile.pack`` fills these tables and ``irtlang.kernels.trace_kernel`` reads them; both import the
names below, so a column or a code cannot mean one thing to the packer and another to the kernel.  The kernel's
entry, ``trace_batch(settings, surfaces, objects, scatter, media, detectors, sources, tallies, records)``, takes
nine of the structures defined here (namedtuples of NumPy arrays and scalars: Numba compiles their fields as it
compiles plain arguments, and caches them by type).

Units are metres, radians and watts.  With L wavelength lines, n surfaces, O objects, M media, C coatings,
D detectors, S sources and `chunks` chunks of ``CHUNK`` ray ids per batch:
"""
from __future__ import annotations

from collections import namedtuple

# ---------------------------------------------------------------------------------------------- surfaces
#: float columns of the surface table ``Surfaces.f`` (n, SF_N)
SF_PAR = 0          # 6 kind parameters (each surface plugin's ``pack``: its docstring says which)
N_PAR = 6
SF_ASPH = 6         # 8 even-asphere terms a4 .. a18 (metres), SI_NASPH of them in use
N_ASPH = 8
SF_AP = 14          # 2 aperture parameters (AP_*)
SF_R = 16           # 9: the local-to-world rotation, row-major
SF_TH = 25          # 3: the world translation, high part of a double-double
SF_TL = 28          # 3: its low part
SF_SIZE = 31        # the characteristic size (the self-hit tolerance scales with it)
SF_BS = 32          # 4: the local bounding sphere (centre, radius; inf: unbounded)
SF_HOLE = 36        # 4: the central-hole cull of an ANNULUS: r_in'^2, z_lo, z_hi, d_max (compile.pack._hole_bounds)
SF_CL = 40          # 4: on the first surface of a cluster, the cluster's world bounding sphere (centre, radius)
SF_N = 44
#: int columns of ``Surfaces.i`` (n, SI_N)
SI_KIND = 0         # the surface kind's code: its index in irtlang.plugins.surfaces.REGISTRY
SI_NASPH = 1        # asphere terms in use
SI_APK = 2          # aperture kind (AP_*)
SI_MESH = 3         # row of ``Surfaces.mesh`` (MESH), -1
SI_OBJ = 4          # the object it belongs to
SI_AXIS = 5         # 1: the rotation is exactly the identity (the kernel skips it)
SI_FAM = 6          # nested-shell family (compile.pack.shell_families), -1: none
SI_FIDX = 7         # the shell's index in its family
SI_CLEND = 8        # on the first surface of a cluster (compile.pack.surface_clusters), one past its last; else 0
SI_FPREV = 9        # a family member: the surface of index SI_FIDX - 1 in its family, -1: none (or not a member)
SI_FNEXT = 10       # a family member: the surface of index SI_FIDX + 1, -1: none
SI_FOUT = 11        # a family member: the first surface after it that is not in its family (n: none)
SI_N = 12
#: ``Surfaces.mesh`` (meshes, 4) columns: BVH node offset and count, triangle offset and count
MI_NODE_OFF, MI_NODE_N, MI_TRI_OFF, MI_TRI_N = range(4)

# apertures (in the surface's local x, y)
AP_NONE, AP_RECT, AP_DISK, AP_ANNULUS, AP_ELLIPSE = range(5)
APERTURE_CODES = {None: AP_NONE, "RECT": AP_RECT, "DISK": AP_DISK, "ANNULUS": AP_ANNULUS, "ELLIPSE": AP_ELLIPSE}

# ---------------------------------------------------------------------------------------------- objects
#: interface kinds (``Objects.itf``).  IF_SPLIT: R/T from a coating table; IF_FRESNEL: from the two media;
#: IF_POLARIZER, IF_RETARDER: ideal elements (``Objects.pol``: axis angle, retardance); IF_METAL: Fresnel with
#: the complex index n + i k held in coat_R, coat_T
IF_ABSORB, IF_REFLECT, IF_SPLIT, IF_FRESNEL, IF_POLARIZER, IF_RETARDER, IF_METAL = range(7)

# ---------------------------------------------------------------------------------------------- scattering
#: scatter-spec kinds (``Scatter.kind``): one model, a class map (class -> model), a fraction map; an OPAQUE
#: WHERE gate (an object's first spec, its map 1.0 where the object is present: opaque there, clear elsewhere)
SPEC_MODEL, SPEC_CLASS_MAP, SPEC_FRACTION_MAP, SPEC_GATE = range(4)
#: volume phase functions (``Media.phase``)
PHASE_NONE, PHASE_RAYLEIGH, PHASE_HG = range(3)

# ---------------------------------------------------------------------------------------------- sources
# a source's kind (Sources.kind): its index among the source plugins that start rays
# (irtlang.plugins.sources.EMITTER_CODES); its direction kind (Sources.dir):
DIR_COLLIMATED, DIR_DIVERGE, DIR_CONVERGE, DIR_FIELD, DIR_LAMBERT = range(5)
#: ``Sources.random``: lattice points, random points, stratified (one random point per cell), a camera's
#: spectral samples (lines drawn from the bands' cumulative weights in ``Sources.pts``)
SAMPLE_LATTICE, SAMPLE_RANDOM, SAMPLE_STRATIFIED, SAMPLE_SPECTRAL = range(4)
#: ``Sources.par`` columns: a kind's own (0-10), DIRECTIONS m of a camera (11), 1 for a camera's one elliptical
#: pixel (12: a DISK or ELLIPSE aperture), 1 for a camera whose lines share their random numbers (13: CORRELATED),
#: a camera's GUIDE: g (14: g x g cells of the aim cone, as the DIRECTIONS strata), t (15: t x t tiles of its start
#: lattice, each with its own table), the first row of the tables in ``Sources.pts`` after the source's
#: ``pts_off`` (16: t^2 tables of g^2 rows (cdf, 1 / (g^2 pmf))); 1 for the guide's pilot (17: a DIRECTIONS
#: camera whose rays report (stratum + 1/2, tile + 1/2) as their start point, for a DETECTOR ... START tally);
#: 1 for a camera's paired spectral samples (18: SPECTRAL k, k even, without DIRECTIONS: k / 2 strata of the
#: bands' cumulative weight, two independent rays in each, consecutive ids); a camera's HERO K (19: each ray
#: carries the K traced lines of its line's block, irtlang/kernels/trace_kernel.py "hero wavelengths"), and the
#: line at which its first full block starts (20: 0 .. K - 1; the blocks before and after it are cut short)
N_SRC_PAR = 21
SP_DIRECTIONS = 11
SP_ELLIPSE = 12
SP_CORRELATED = 13
SP_GUIDE = 14
SP_GUIDE_T = 15
SP_GUIDE_ROW = 16
SP_PILOT = 17
SP_PAIRED = 18
SP_HERO = 19
SP_HERO_OFF = 20

# ---------------------------------------------------------------------------------------------- tallies
#: ledger columns
C_INC, C_REF, C_TRA, C_SCA, C_ABS = range(5)
N_TERMINAL_ROWS = 4     # EMITTED, ESCAPED, HALTED, LOST: the ledger's last rows
#: record flags
FL_SCATTERED, FL_TRANSMITTED, FL_REFLECTED, FL_HALTED, FL_ESCAPED, FL_LOST = 1, 2, 4, 8, 16, 32
#: event kinds in a path's history (entry = object * 8 + kind; -2 a volume event)
EV_R, EV_T, EV_S, EV_A = 1, 2, 3, 4

# ---------------------------------------------------------------------------------------------- the structures
#: scalars of one batch: ray ids first .. first + n - 1 of `total` per pass; event limit, roulette threshold,
#: the roulette of rays sent toward targets, the IMPORTANCE ledger row (-1: none)
Settings = namedtuple("Settings", "first n total seed level halt nee_cut r_imp")
#: f (n, SF_N), i (n, SI_N), mesh (meshes, 4); the concatenated BVHs: bmin, bmax (nodes, 3), child (nodes, 2),
#: count (nodes,), tris (triangles, 9), ids (triangles,), fn (triangles, 3) face normals
Surfaces = namedtuple("Surfaces", "f i mesh bmin bmax child count tris ids fn")
#: per object: itf, coat, back and front media, det (detector, -1), pol (O, 2), bc (O, 3) and br (O,) its world
#: bounding sphere (for TOWARD), sc_first and sc_cnt: its SCATTER specs
Objects = namedtuple("Objects", "itf coat back front det pol bc br sc_first sc_cnt")
#: the scatter specs (kind, model, map, cls_off, cls_n, rays, tgt), the class tables (cls_models), the
#: LATLON maps (data, off, nlat, nlon), the models: kind (the kernel's dispatch index), P (models, L, PMAX; model m's
#: (PMAX, L) block is P[m].T), slab
Scatter = namedtuple("Scatter", "kind model map cls_off cls_n rays tgt cls_models map_data map_off map_nlat map_nlon "
                                "mod_kind mod_P mod_slab")
#: per medium and line: n, alpha, row (ledger row, -1), sig, alb, g, phase, depol, tgt, nee; the coatings
#: coat_R, coat_T (3, C, L): [0] R and T (a METAL: n and k), [1] (Rs - Rp)/2 and (Ts - Tp)/2, [2] retardances
Media = namedtuple("Media", "n alpha row sig alb g phase depol tgt nee coat_R coat_T")
#: per detector: nx, ny, ext (D, 4) x0 x1 y0 y1, off (first deposit index), qe (D, L), start (1: binned by
#: the ray's start point)
Detectors = namedtuple("Detectors", "nx ny ext off qe start")
#: per source: kind, dir, par (S, N_SRC_PAR), R (S, 9), Th, Tl (S, 3), n (rays per line), off (first ray id),
#: w (S, L), random (SAMPLE_*), toward, pts and pts_off (row tables), lmap (S, L) its traced lines
Sources = namedtuple("Sources", "kind dir par R Th Tl n off w random toward pts pts_off lmap")
#: per chunk: led (chunks, rows, 5, L), inc_sq (chunks, rows, L), the deposit lists idx, w, d (chunks, cap; d the
#: deposit the variance squares: w, or a stratified pair's difference), n
Tallies = namedtuple("Tallies", "led inc_sq dep_idx dep_w dep_d dep_n")
#: per chunk and path end: pos (6: double-double), dir, w, line, src, obj, ev, flags, hist (H), opl, start (2);
#: n their count (-1: the chunk overflowed its room)
Records = namedtuple("Records", "pos dir w line src obj ev flags hist opl start n")
