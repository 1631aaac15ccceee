"""Scene model -> packed arrays with integer kind codes (the tracer's only input besides scalars).

Everything is in metres.  World translations are stored as double-double pairs (``*_hi``, ``*_lo``):
an object 0.18 AU away keeps sub-nanometre placement, so a telescope far from the origin focuses exactly
as it does at the origin (DESIGN.md, "Precision across scales").  Compositions of group placements are
summed with ``math.fsum`` so the pair is the exact sum to double-double precision.

Kind codes, table columns and the kernel's argument structures are defined once, in
``irtlang.kernels.layout`` (surface codes: each kind's index in ``irtlang.plugins.surfaces.REGISTRY``).  Each
surface plugin packs its own parameters (``pack``, ``bounds``, ``size``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..io.spectra import band_edges
from ..core import diskcache
from ..core.diagnostics import Span, error
from ..model import scene as M

from ..kernels.layout import (AP_ANNULUS, APERTURE_CODES,  # noqa: F401
                              DIR_COLLIMATED, DIR_CONVERGE, DIR_DIVERGE, DIR_FIELD, DIR_LAMBERT, IF_ABSORB,
                              IF_FRESNEL, IF_METAL, IF_POLARIZER, IF_REFLECT, IF_RETARDER, IF_SPLIT, N_ASPH, N_PAR,
                              SF_AP, SF_ASPH, SF_BS, SF_CL, SF_HOLE, SF_N, SF_PAR, SF_R, SF_SIZE, SF_TH, SF_TL, SI_APK,
                              SI_AXIS, SI_CLEND, SI_FAM, SI_FIDX, SI_FNEXT, SI_FOUT, SI_FPREV, SI_KIND, SI_MESH,
                              SI_N, SI_NASPH, SI_OBJ, SAMPLE_SPECTRAL,
                              SAMPLE_STRATIFIED, SPEC_GATE)
from ..plugins.sources import EMITTER_CODES
from ..plugins.surfaces import CODES as SURFACE_CODES, REGISTRY as SURFACES

SK_PLANE, SK_CONIC, SK_SPHERE, SK_ELLIPSOID = (SURFACE_CODES[k] for k in ("PLANE", "CONIC", "SPHERE", "ELLIPSOID"))
# N_TERMINAL_ROWS: EMITTED, ESCAPED, HALTED, LOST, the ledger's last rows
from ..kernels.layout import (N_SRC_PAR, N_TERMINAL_ROWS, SP_CORRELATED, SP_DIRECTIONS, SP_ELLIPSE,  # noqa: E402
                              SP_GUIDE, SP_GUIDE_ROW, SP_GUIDE_T, SP_HERO, SP_HERO_OFF, SP_PAIRED,
                              SP_PILOT)


class MissingFeature(Exception):
    def __init__(self, span: Span, what: str, capability: str):
        self.span, self.what, self.capability = span, what, capability
        super().__init__(what)


@dataclass
class Features:
    """What a scene needs; the kernel is specialized on it (irtlang.compile.specialize)."""

    conic: bool = False
    quadric: bool = False      # sphere, ellipsoid, tube
    biconic: bool = False      # BICONIC (its own: its root finder is about a tenth of a small scene's first compile)
    mesh: bool = False
    refract: bool = False      # any transmitting interface
    absorb_media: bool = False
    precise: bool = False      # translations beyond 1e6 m: double-double positions
    records: bool = False
    history: bool = False
    scatter: bool = False
    maps: bool = False         # SCATTER MAP lookups (geodetic latitude, longitude)
    volume: bool = False       # scattering media (free-path sampling)
    importance: bool = False   # SCATTER ... TOWARD: next-event rays and the IMPORTANCE ledger row
    shells: bool = False       # nested concentric spheres/ellipsoids (atmosphere shells): test neighbours only
    polar: bool = False        # POLARIZATION (or a POLARIZER / RETARDER interface): Stokes vectors
    camera: bool = False       # a TRACE CAMERA's sources: spectral samples, DIRECTIONS pairs, GUIDE tables
    hero: bool = False         # a camera source with hero wavelengths (HERO K: its par[SP_HERO] > 1)
    bsdf_kinds: tuple = ()     # the scatter-model kinds the scene uses (their dispatch order)
    source_kinds: tuple = ()   # the source kinds its sources use (emitters and directions; () compiles them all)

    def key(self) -> str:
        flags = "".join("1" if getattr(self, f) else "0" for f in self.__dataclass_fields__ if f not in KIND_FIELDS)
        key = flags + ("_" + "-".join(k.lower() for k in self.bsdf_kinds) if self.bsdf_kinds else "")
        if self.source_kinds:   # by registry index (names would make the cache's file names too long)
            from ..plugins.sources import REGISTRY

            key += "_s" + "".join(f"{list(REGISTRY).index(k):02x}" for k in self.source_kinds)
        return key


KIND_FIELDS = ("bsdf_kinds", "source_kinds")   # Features' fields that list kinds (the others are flags)


def source_kinds_of(src_kind, src_dir) -> tuple:
    """The source kinds (registry order) that packed sources of emitter codes `src_kind` and direction codes
    `src_dir` dispatch to: the kernel compiles only these (a trace's first compile is about 10 % shorter than
    with every kind)."""
    from ..plugins.sources import EMITTER_CODES, REGISTRY

    emit = {int(k) for k in src_kind}
    dirs = {int(d) for d in src_dir}
    return tuple(k for k, m in REGISTRY.items()
                 if (k in EMITTER_CODES and EMITTER_CODES[k] in emit) or dirs & set(getattr(m, "DIRECTION_CODES", ())))


@dataclass
class Packed:
    lines_nm: np.ndarray
    line_width_nm: np.ndarray
    object_names: list
    medium_names: list
    absorbing_media: list          # medium indices that get a ledger row
    features: Features
    # surfaces
    s_obj: np.ndarray
    s_kind: np.ndarray
    s_par: np.ndarray               # (n, 6)
    s_asph: np.ndarray              # (n, 8) a4.. (metres)
    s_nasph: np.ndarray
    s_ap_kind: np.ndarray
    s_ap: np.ndarray                # (n, 2)
    s_R: np.ndarray                 # (n, 9) local -> world
    s_Th: np.ndarray                # (n, 3)
    s_Tl: np.ndarray
    s_size: np.ndarray              # characteristic size, for the self-hit tolerance
    s_mesh: np.ndarray              # index into the mesh table, -1
    s_bs: np.ndarray                # (n, 4) local bounding sphere: centre, radius (inf: unbounded)
    # meshes (concatenated BVHs; each mesh's child and tri indices are local to its slices)
    m_node_off: np.ndarray
    m_node_n: np.ndarray
    m_tri_off: np.ndarray
    m_tri_n: np.ndarray
    bvh_bmin: np.ndarray
    bvh_bmax: np.ndarray
    bvh_child: np.ndarray
    bvh_count: np.ndarray
    bvh_tris: np.ndarray
    bvh_ids: np.ndarray
    bvh_fn: np.ndarray
    # objects
    o_itf: np.ndarray
    o_coat: np.ndarray
    o_back: np.ndarray
    o_front: np.ndarray
    o_det: np.ndarray
    o_pol: np.ndarray               # (O, 2) a POLARIZER's or RETARDER's axis angle and retardance (rad)
    # media and coatings (per line)
    med_n: np.ndarray               # (M, L)
    med_alpha: np.ndarray           # (M, L) 1/m
    med_row: np.ndarray             # (M,) ledger row of an absorbing or scattering medium, -1
    med_sig: np.ndarray             # (M, L) extinction of a VOLUME medium, 1/m
    med_alb: np.ndarray             # (M, L) single-scattering albedo
    med_g: np.ndarray               # (M, L) HG asymmetry
    med_phase: np.ndarray           # (M,) 0 none, 1 Rayleigh, 2 HG
    med_depol: np.ndarray           # (M,)
    med_tgt: np.ndarray             # (M,) TOWARD object, -1
    med_nee: np.ndarray             # (M,) RAYS toward the target per event
    coat_R: np.ndarray              # (3, C, L): the module docstring's layout
    coat_T: np.ndarray
    # scattering: an object's SCATTER specs sc_first[o] .. + sc_count[o], tried in order
    o_sc_first: np.ndarray
    o_sc_cnt: np.ndarray
    sp_kind: np.ndarray             # 0 model, 1 class map, 2 fraction map, 3 OPAQUE WHERE gate (first)
    sp_model: np.ndarray            # model index (kinds 0 and 2)
    sp_map: np.ndarray              # map index (kinds 1 and 2)
    sp_cls_off: np.ndarray          # class -> model table (kind 1)
    sp_cls_n: np.ndarray
    sp_rays: np.ndarray
    sp_tgt: np.ndarray
    cls_models: np.ndarray
    map_data: np.ndarray            # concatenated LATLON grids (rows from +90, columns from -180)
    map_off: np.ndarray
    map_nlat: np.ndarray
    map_nlon: np.ndarray
    mod_kind: np.ndarray            # index into features.bsdf_kinds
    mod_P: np.ndarray               # (nM, L, PMAX): model m's (PMAX, L) block is mod_P[m].T (one line contiguous)
    mod_slab: np.ndarray
    model_names: list
    # detectors (pixel grid in the surface's local x, y)
    d_obj: np.ndarray
    d_nx: np.ndarray
    d_ny: np.ndarray
    d_ext: np.ndarray               # (D, 4) x0 x1 y0 y1 (metres)
    d_qe: np.ndarray                # (D, L) quantum efficiency applied to the image
    detector_names: list
    # sources
    src_kind: np.ndarray
    src_dir: np.ndarray
    src_par: np.ndarray             # (S, N_SRC_PAR)
    src_R: np.ndarray               # (S, 9)
    src_Th: np.ndarray
    src_Tl: np.ndarray
    src_n: np.ndarray               # rays per line
    src_off: np.ndarray             # first ray id
    src_w: np.ndarray               # (S, L) flux per ray, W
    src_random: np.ndarray
    src_toward: np.ndarray          # object index, -1
    src_pts: np.ndarray             # row tables of lattice GRID DISKs (concatenated (K, 2), disk_lattice_rows)
    src_pts_off: np.ndarray
    n_rays_total: int = 0
    emitted_W: np.ndarray = field(default_factory=lambda: np.zeros(0))   # per line
    nee_cut: float = 0.0            # roulette of rays sent toward targets (HALT ... IMPORTANCE c)
    d_filters: list = field(default_factory=list)   # per detector: None (an image per line) or
                                                    # (filter names, (L, B) transmission matrix)
    d_start: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))  # (D,) 1: binned by start point
    src_lmap: np.ndarray = field(default_factory=lambda: np.zeros((0, 1), np.int64))  # (S, L) traced lines, in order
    s_bounds: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))   # (n, 4) surface_bounds (unpadded)

    def _hole_bounds(self) -> np.ndarray:
        """(n, 4) per surface: the kernel's central-hole cull (trace_kernel SF_HOLE) for a plane or a conic
        without aspheric terms whose aperture is an ANNULUS: (r_in'^2, z_lo, z_hi, d_max).  Every point of the
        surface inside the aperture has z in [z_lo, z_hi] (the sag over [r_in, r_out], padded), so a ray whose
        line crosses that slab at both faces closer than r_in' (r_in less a margin) to the axis cannot hit it
        (r^2 is convex along a line).  Used only from origins within d_max (|o|_1), where the rounding of the
        slab points stays far below the margin.  Zeros (no cull) for every other surface."""
        n = len(self.s_kind)
        out = np.zeros((n, 4))
        for j in range(n):
            k, apk = int(self.s_kind[j]), int(self.s_ap_kind[j])
            if apk != AP_ANNULUS or k not in (SK_PLANE, SK_CONIC) or (k == SK_CONIC and self.s_nasph[j] > 0):
                continue
            rin, rout = float(self.s_ap[j, 0]), float(self.s_ap[j, 1])
            if not (0.0 < rin < rout < math.inf):
                continue
            if k == SK_PLANE:
                zs = [0.0]
            else:
                c, kk = float(self.s_par[j, 0]), float(self.s_par[j, 1])
                if 1.0 - (1.0 + kk) * c * c * rout * rout < 0.0:
                    continue        # the aperture reaches past the conic's domain: no cull
                zs = [c * r * r / (1.0 + math.sqrt(max(0.0, 1.0 - (1.0 + kk) * c * c * r * r))) for r in (rin, rout)]
            zlo, zhi = min(zs), max(zs)
            scale = rout + abs(zlo) + abs(zhi)
            pad = 1e-6 * (abs(zlo) + abs(zhi)) + 1e-9 * scale + 1e-12
            r_cut = rin - 1e-9 * scale
            if r_cut <= 0.0 or not math.isfinite(scale):
                continue
            out[j] = (r_cut * r_cut, zlo - pad, zhi + pad, 1e4 * scale)
        return out

    def surface_tables(self):
        """(s_f, s_i, mesh_i): the surface columns as the kernel reads them (irtlang.kernels.layout SF_*, SI_*)."""
        n = len(self.s_kind)
        f = np.zeros((n, SF_N))
        f[:, SF_PAR:SF_PAR + N_PAR] = self.s_par
        f[:, SF_ASPH:SF_ASPH + N_ASPH] = self.s_asph
        f[:, SF_AP:SF_AP + 2] = self.s_ap
        f[:, SF_R:SF_R + 9] = self.s_R
        f[:, SF_TH:SF_TH + 3] = self.s_Th
        f[:, SF_TL:SF_TL + 3] = self.s_Tl
        f[:, SF_SIZE] = self.s_size
        f[:, SF_BS:SF_BS + 4] = self.s_bs
        f[:, SF_HOLE:SF_HOLE + 4] = self._hole_bounds()
        # SI_AXIS: the surface's rotation is exactly the identity (the kernel then skips the frame rotation)
        axis = np.all(np.asarray(self.s_R, float).reshape(n, 9) == np.eye(3).ravel(), axis=1) if n else np.zeros(0, bool)
        fam, fidx = shell_families(self)
        i = np.zeros((n, SI_N), np.int64)
        for col, v in ((SI_KIND, self.s_kind), (SI_NASPH, self.s_nasph), (SI_APK, self.s_ap_kind),
                       (SI_MESH, self.s_mesh), (SI_OBJ, self.s_obj), (SI_AXIS, axis), (SI_FAM, fam), (SI_FIDX, fidx)):
            i[:, col] = v
        i[:, SI_FPREV], i[:, SI_FNEXT], i[:, SI_FOUT] = family_links(fam, fidx)
        f[:, SF_CL:SF_CL + 4], i[:, SI_CLEND] = surface_clusters(f, fam)
        m = np.stack([self.m_node_off, self.m_node_n, self.m_tri_off, self.m_tri_n], axis=1).astype(np.int64) \
            if len(self.m_node_n) else np.zeros((1, 4), np.int64)
        return np.ascontiguousarray(f), np.ascontiguousarray(i), m

    @property
    def r_importance(self) -> int:
        return len(self.object_names) + len(self.absorbing_media) if self.features.importance else -1

    @property
    def n_rows(self) -> int:
        return len(self.object_names) + len(self.absorbing_media) + int(self.features.importance) + N_TERMINAL_ROWS

    @property
    def row_names(self) -> list:
        return (list(self.object_names) + [f"MEDIUM {self.medium_names[m]}" for m in self.absorbing_media]
                + (["IMPORTANCE"] if self.features.importance else []) + ["EMITTED", "ESCAPED", "HALTED", "LOST"])


CLUSTER_MIN = 3        # surfaces in a run worth one bounding sphere
CLUSTER_SPREAD = 10.0  # a cluster's radius at most this many times its largest member's


def surface_clusters(f: np.ndarray, fam: np.ndarray) -> tuple:
    """(spheres (n, 4), ends (n,)): runs of consecutive bounded surfaces outside nested-shell families (an
    instrument's mirrors, baffles and detector, declared together), split where the run's sphere would grow
    past CLUSTER_SPREAD times its largest member, get one world bounding sphere, stored on the
    run's first surface with the index one past its last.  The kernel's nearest-hit search tests that sphere
    first and skips the whole run when the ray misses it or meets it beyond the nearest hit found so far: for
    the Earth's camera paths the telescope's 17 surfaces 0.18 AU away cost one test per event, not 17 frame
    changes.  The sphere holds every member's own bounding sphere with a margin (1e-9 relative and 1 mm), so the
    skip never drops a hit: the traces are bitwise the same.  A run holding every surface of the scene (a
    telescope alone) gets none: its rays live inside the sphere, so the test would only cost (5 % of the
    telescope benchmark).  ends 0: no cluster starts there."""
    n = len(f)
    out = np.zeros((n, 4))
    ends = np.zeros(n, np.int64)
    R = f[:, SF_R:SF_R + 9].reshape(n, 3, 3)
    T = f[:, SF_TH:SF_TH + 3] + f[:, SF_TL:SF_TL + 3]
    c_loc = f[:, SF_BS:SF_BS + 3]
    r = f[:, SF_BS + 3]
    ok = (fam < 0) & np.isfinite(r) & np.all(np.isfinite(c_loc), axis=1)
    j = 0
    while j < n:
        if not ok[j]:
            j += 1
            continue
        k = j
        while k < n and ok[k]:
            k += 1
        cw = np.einsum("nij,nj->ni", R[j:k], c_loc[j:k]) + T[j:k]
        a = 0
        while a < k - j:
            # grow the cluster while its sphere stays within CLUSTER_SPREAD of its largest member (a telescope,
            # not a telescope and the planet 100 km away that follows it in the script)
            b = a + 1
            centre, rad = cw[a], r[j + a]
            while b < k - j:
                lo, hi = cw[a:b + 1].min(axis=0), cw[a:b + 1].max(axis=0)
                c2 = 0.5 * (lo + hi)
                r2 = float(np.max(np.linalg.norm(cw[a:b + 1] - c2, axis=1) + r[j + a:j + b + 1]))
                if r2 > CLUSTER_SPREAD * float(np.max(r[j + a:j + b + 1])):
                    break
                centre, rad = c2, r2
                b += 1
            if CLUSTER_MIN <= b - a < n:     # a cluster that is the whole scene has nothing to be skipped for
                out[j + a, :3] = centre
                out[j + a, 3] = rad * (1.0 + 1e-9) + 1e-3 + 1e-15 * float(np.max(np.abs(centre)))
                ends[j + a] = j + b
            a = b
        j = k
    return out, ends


def shell_families(pk) -> tuple:
    """(family, index in family) per surface: spheres and ellipsoids with one centre and one orientation whose
    semi-axes grow strictly from one to the next are *nested shells* (an atmosphere); -1 elsewhere.  A ray that
    has just crossed shell i of a family can next meet only shells i - 1, i and i + 1 of it (a straight ray
    that leaves a convex shell never re-enters it, and cannot reach a farther shell without crossing a nearer
    one), so the kernel skips the others (feature `shells`); from the side the ray leaves shell i to, it also
    drops i and i - 1 (outward) or i + 1 (inward)."""
    n = len(pk.s_kind)
    fam = np.full(n, -1, np.int64)
    fidx = np.zeros(n, np.int64)
    groups: dict = {}
    for j in range(n):
        k = int(pk.s_kind[j])
        if k not in (SK_SPHERE, SK_ELLIPSOID) or pk.s_ap_kind[j] != 0:
            continue
        axes = (pk.s_par[j][0],) * 3 if k == SK_SPHERE else tuple(pk.s_par[j][:3])
        c = np.asarray(pk.s_R[j], float).ravel().tolist() + list(pk.s_Th[j]) + list(pk.s_Tl[j])
        groups.setdefault(tuple(c), []).append((axes, j))
    nf = 0
    for members in groups.values():
        if len(members) < 3:
            continue
        members.sort()
        ok = all(all(a < b for a, b in zip(members[q][0], members[q + 1][0])) for q in range(len(members) - 1))
        if not ok:
            continue
        for q, (_, j) in enumerate(members):
            fam[j], fidx[j] = nf, q
        nf += 1
    return fam, fidx


def family_links(fam: np.ndarray, fidx: np.ndarray) -> tuple:
    """(prev, next, out) per surface: for a member of a nested-shell family, the surfaces of index fidx - 1 and
    fidx + 1 in its family (-1: none) and the first surface after it that is not in its family (n: none); -1,
    -1, 0 elsewhere.  The kernel's nearest-hit search, after a crossing of shell i, jumps over the members it
    need not test (all but i - 1, i, i + 1; of these, one or two by the side the ray leaves to) instead of
    stepping through them one by one: the Earth's shells cost one or two tests per event and a handful of
    jumps."""
    n = len(fam)
    prev = np.full(n, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    out = np.zeros(n, np.int64)
    where = {(int(fam[j]), int(fidx[j])): j for j in range(n) if fam[j] >= 0}
    for j in range(n):
        if fam[j] < 0:
            continue
        prev[j] = where.get((int(fam[j]), int(fidx[j]) - 1), -1)
        nxt[j] = where.get((int(fam[j]), int(fidx[j]) + 1), -1)
        k = j + 1
        while k < n and fam[k] == fam[j]:
            k += 1
        out[j] = k
    return prev, nxt, out


_MODEL_PACKS: dict = {}


def _exact_key(v):
    """A hashable key that tells apart any two different parameter values (repr() would not: NumPy prints 8
    digits, so two tables differing in the 9th would share a packed block)."""
    if isinstance(v, np.ndarray):
        return ("ndarray", v.dtype.str, v.shape, v.tobytes())
    if isinstance(v, (list, tuple)):
        return (type(v).__name__,) + tuple(_exact_key(x) for x in v)
    if isinstance(v, dict):
        return ("dict",) + tuple(sorted((k, _exact_key(x)) for k, x in v.items()))
    if isinstance(v, float):
        return ("float", v.hex())
    return v


def _pack_disk_key(plugin, key) -> str:
    """A packed block's key in the disk cache: the model's parameters and the code that packs them (the
    plugin's module, every scatter-model module and the kernel helpers they call; not the trace kernel, which
    no model's pack calls and which changes most often)."""
    from pathlib import Path

    here = Path(__file__).resolve().parents[1]
    files = sorted({str(Path(plugin.__file__).resolve())} | {str(f) for f in (here / "plugins" / "bsdfs").glob("*.py")}
                   | {str(f) for f in (here / "kernels").glob("*.py") if f.name != "trace_kernel.py"})
    return diskcache.key("packs", 1, diskcache.code_hash(*files), key)


def _pack_model(kind: str, params, L: int) -> np.ndarray:
    """A scatter model's parameter block, remembered for the session (a script that traces many times, the
    Earth's hourly frames, packs its slab tables once) and on disk (irtlang.core.diskcache: the next run of the
    script reads them; the Earth's 152 models take 12 s to pack)."""
    from ..plugins.bsdfs import REGISTRY as BSDFS

    try:
        key = (kind, L, tuple(sorted((k, _exact_key(v)) for k, v in dict(params).items())))
        hash(key)
    except TypeError:
        return BSDFS[kind].pack(params, L)
    blk = _MODEL_PACKS.get(key)
    if blk is None:
        dkey = _pack_disk_key(BSDFS[kind], key)
        blk = diskcache.load("packs", dkey)
        if not isinstance(blk, np.ndarray):
            blk = BSDFS[kind].pack(params, L)
            diskcache.store("packs", dkey, blk)
        if len(_MODEL_PACKS) > 512:
            _MODEL_PACKS.clear()
        _MODEL_PACKS[key] = blk
    return blk.copy()


def _load_map(mdef: M.MapDef) -> np.ndarray:
    from ..io.maps import load_latlon
    from pathlib import Path

    if mdef.path is None:      # MAP name LATLON DEFAULT dataset: the default data tier (built at first use)
        from ..earth.data import load_dataset

        return load_dataset(mdef.dataset)
    return load_latlon(Path(mdef.path))


def _load_map_checked(mdef: M.MapDef) -> np.ndarray:
    """_load_map, with a default dataset this installation cannot build reported at the MAP line."""
    from ..earth.data import DatasetUnavailable

    try:
        return _load_map(mdef)
    except DatasetUnavailable as e:
        raise error(mdef.span, f"MAP {mdef.name} LATLON DEFAULT {mdef.dataset}: {e}") from None


def _gate_grid(scene: M.Scene, gate: tuple) -> np.ndarray:
    """An OPAQUE WHERE gate as a LATLON map: 1.0 where lo <= value < hi, 0.0 elsewhere (NaN: clear)."""
    _, key, lo, hi = gate
    g = np.asarray(_load_map_checked(scene.maps[key]), np.float64)
    with np.errstate(invalid="ignore"):
        return ((g >= lo) & (g < hi)).astype(np.float64)


def _dd_translate(R_parent, T_parent_hi, T_parent_lo, t_child):
    """(hi, lo) of T_parent + R_parent @ t_child, exact to double-double."""
    hi, lo = [], []
    for i in range(3):
        parts = [T_parent_hi[i], T_parent_lo[i]] + [R_parent[3 * i + k] * t_child[k] for k in range(3)]
        h = math.fsum(parts)
        hi.append(h)
        lo.append(math.fsum(parts + [-h]))
    return tuple(hi), tuple(lo)


def world_frame(scene: M.Scene, local: M.Transform, group: str | None):
    """(R, T_hi, T_lo) of a frame given in `group`'s coordinates."""
    R = local.R
    Th, Tl = tuple(local.T), (0.0, 0.0, 0.0)
    g = group
    while g is not None:
        grp = scene.groups[g]
        P = grp.placement
        Rn = M._matmul(P.R, R)
        Th2, Tl2 = _dd_translate(P.R, P.T, (0.0, 0.0, 0.0), Th)
        # carry the child's low part through the rotation too
        Tl2 = tuple(a + sum(P.R[3 * i + k] * Tl[k] for k in range(3)) for i, a in enumerate(Tl2))
        R, Th, Tl = Rn, Th2, Tl2
        g = grp.parent
    return R, Th, Tl


def surface_bounds(s: M.Surface) -> tuple:
    """The local sphere (cx, cy, cz, r) that holds the surface (its plugin's ``bounds``); r = inf if unbounded."""
    return tuple(float(x) for x in SURFACES[s.kind].bounds(s))


def _local_bounds(s: M.Surface) -> tuple:
    """surface_bounds widened by the plugin's BOUNDS_PAD: the kernel's cull."""
    cx, cy, cz, r = surface_bounds(s)
    rel, ab = getattr(SURFACES[s.kind], "BOUNDS_PAD", (1e-9, 0.0))
    return (cx, cy, cz, r * (1 + rel) + ab)


def _surface_size(s: M.Surface) -> float:
    if s.aperture is not None:
        from ..plugins.surfaces._aperture import outer_radius

        return outer_radius(s.aperture)
    return float(SURFACES[s.kind].size(s))


def pack(scene: M.Scene, *, records: bool = False, history: bool = False, floor: Features | None = None) -> Packed:
    """The scene's packed arrays.  `floor`: features to switch on even where this scene does not need them, so
    that it runs on the kernel another scene has already compiled (a camera GUIDE's pilot runs on its camera
    trace's kernel); its scatter-model dispatch is taken when this scene has no models of its own."""
    L = scene.n_lines
    lines = np.asarray(scene.wavelengths_nm, float)
    widths = (np.diff(band_edges(lines), axis=1)[:, 0] if L > 1 else np.ones(1))
    feats = Features(records=records, history=history, polar=bool(getattr(scene, "polarization", False)))

    obj_keys = list(scene.objects)
    obj_index = {k: i for i, k in enumerate(obj_keys)}
    med_keys = list(scene.media)
    med_index = {k: i for i, k in enumerate(med_keys)}
    coat_keys = list(scene.coatings)
    coat_index = {k: i for i, k in enumerate(coat_keys)}

    # media and coatings
    med_n = np.array([np.broadcast_to(np.asarray(scene.media[k].index, float), (L,)) for k in med_keys])
    med_alpha = np.array([np.broadcast_to(np.asarray(scene.media[k].absorb, float), (L,)) for k in med_keys])
    coat_R = np.zeros((3, max(1, len(coat_keys)), L))
    coat_T = np.zeros((3, max(1, len(coat_keys)), L))
    for k, i in coat_index.items():
        c = scene.coatings[k]
        if c.kind in ("rt", "metal"):      # a metal's n and k ride in the R and T rows (IF_METAL)
            coat_R[0, i], coat_T[0, i] = c.reflect, c.transmit
        if c.polarized is not None:        # COATING ... POLARIZED: (Rs - Rp)/2, (Ts - Tp)/2, delta_r, delta_t
            coat_R[1, i], coat_T[1, i], coat_R[2, i], coat_T[2, i] = c.polarized

    # objects
    nO = len(obj_keys)
    o_itf = np.zeros(nO, np.int32)
    o_coat = np.full(nO, -1, np.int32)
    o_back = np.zeros(nO, np.int32)
    o_front = np.zeros(nO, np.int32)
    o_pol = np.zeros((max(nO, 1), 2))
    o_det = np.full(nO, -1, np.int32)
    used_media = set()
    det_rows = []
    # scattering: the models objects use, packed per line; dispatch order = registry order
    from ..plugins.bsdfs import REGISTRY as BSDFS

    o_sc_first = np.zeros(nO, np.int32)
    o_sc_cnt = np.zeros(nO, np.int32)
    specs: list = []        # (kind, model, map, classes, rays, target)
    used_models: list = []
    used_maps: list = []

    def model_id(name):
        if name not in used_models:
            used_models.append(name)
        return used_models.index(name)

    for i, k in enumerate(obj_keys):
        obj = scene.objects[k]
        o_sc_first[i] = len(specs)
        o_sc_cnt[i] = len(obj.scatter)
        if obj.where is not None:
            # OPAQUE WHERE: a gate spec first, over the map's [lo, hi) as a 0/1 map (kernel: SPEC_GATE)
            wkey, lo, hi, _ = obj.where        # (TRACE checked that its models only reflect)
            gate = ("gate", wkey, lo, hi)
            if gate not in used_maps:
                used_maps.append(gate)
            specs.append((SPEC_GATE, -1, used_maps.index(gate), (), 1, -1))
            o_sc_cnt[i] += 1
        for sc in obj.scatter:
            tgt = obj_index[sc.toward] if sc.toward is not None else -1
            if tgt >= 0:
                feats.importance = True
            if sc.map is None:
                specs.append((0, model_id(sc.model), -1, (), sc.rays, tgt))
                continue
            mdef = scene.maps[sc.map]
            if mdef.path is None:
                dgrid = _load_map_checked(mdef)
                if np.issubdtype(dgrid.dtype, np.integer) and int(dgrid.max()) + 1 > len(sc.models):
                    raise error(sc.span, f"map {mdef.name} has {int(dgrid.max()) + 1} classes but MODELS names "
                                f"{len(sc.models)}", "name one model per class index 0 .. n-1")
            if sc.map not in used_maps:
                used_maps.append(sc.map)
            mi = used_maps.index(sc.map)
            grid = _load_map(mdef)
            if np.issubdtype(grid.dtype, np.integer) or len(sc.models) > 1:
                specs.append((1, -1, mi, tuple(model_id(m) for m in sc.models), sc.rays, tgt))
            else:
                if np.nanmin(grid) < 0 or np.nanmax(grid) > 1:
                    raise error(sc.span, f"map {mdef.name} is used as a fraction map (one model) but holds values "
                                f"outside [0, 1] ({np.nanmin(grid):g} .. {np.nanmax(grid):g})",
                                "give a class map one model per class, or scale the fractions to [0, 1]")
                specs.append((2, model_id(sc.models[0]), mi, (), sc.rays, tgt))
    nsp = max(1, len(specs))
    sp_kind = np.zeros(nsp, np.int32)
    sp_model = np.full(nsp, -1, np.int32)
    sp_map = np.full(nsp, -1, np.int32)
    sp_cls_off = np.zeros(nsp, np.int32)
    sp_cls_n = np.zeros(nsp, np.int32)
    sp_rays = np.ones(nsp, np.int32)
    sp_tgt = np.full(nsp, -1, np.int32)
    cls = []
    for q, (kd, mo, mp, classes, rays, tgt) in enumerate(specs):
        sp_kind[q], sp_model[q], sp_map[q], sp_rays[q], sp_tgt[q] = kd, mo, mp, rays, tgt
        sp_cls_off[q], sp_cls_n[q] = len(cls), len(classes)
        cls.extend(classes)
    cls_models = np.asarray(cls or [0], np.int32)
    grids = [_gate_grid(scene, m) if isinstance(m, tuple) else _load_map(scene.maps[m]).astype(np.float64)
             for m in used_maps]
    map_nlat = np.array([g.shape[0] for g in grids] or [1], np.int64)
    map_nlon = np.array([g.shape[1] for g in grids] or [1], np.int64)
    map_off = np.concatenate([[0], np.cumsum([g.size for g in grids])[:-1]]).astype(np.int64) if grids else np.zeros(1, np.int64)
    map_data = np.concatenate([g.ravel() for g in grids]) if grids else np.zeros(1)
    feats.maps = bool(grids)
    kinds = [kk for kk in BSDFS if any(scene.models[m].kind == kk for m in used_models)]
    feats.bsdf_kinds = tuple(kinds)
    feats.scatter = bool(used_models)
    blocks = [_pack_model(scene.models[m].kind, scene.models[m].params, L) for m in used_models]
    pmax = max([b.shape[0] for b in blocks] + [1])
    # stored line-major: a path reads one line's parameters and tables (P[:, k]), which are then one contiguous
    # run instead of one cache line per row (the kernel takes model m's (PMAX, L) block as mod_P[m].T)
    mod_P = np.zeros((max(1, len(blocks)), L, pmax))
    for j, b in enumerate(blocks):
        mod_P[j, :, :b.shape[0]] = b.T
    mod_kind = np.array([kinds.index(scene.models[m].kind) for m in used_models] or [0], np.int32)
    mod_slab = np.array([int(getattr(BSDFS[scene.models[m].kind], "SLAB", False)) for m in used_models] or [0], np.int32)

    for i, k in enumerate(obj_keys):
        obj = scene.objects[k]
        itf = obj.interface
        if itf is None or itf.kind == "absorb":
            o_itf[i] = IF_ABSORB
        elif itf.kind == "reflect":
            o_itf[i] = IF_REFLECT
        elif itf.kind in ("polarizer", "retarder"):
            o_itf[i] = IF_POLARIZER if itf.kind == "polarizer" else IF_RETARDER
            o_pol[i] = (itf.angle, itf.retardance)
            o_back[i], o_front[i] = med_index[itf.back], med_index[itf.front]
            used_media.update((itf.back, itf.front))
            feats.polar = True          # an ideal polarizer only means something to a polarized trace
        else:
            o_back[i], o_front[i] = med_index[itf.back], med_index[itf.front]
            used_media.update((itf.back, itf.front))
            if itf.kind == "transmit" or scene.coatings[itf.coating].kind == "fresnel":
                o_itf[i] = IF_FRESNEL
            elif scene.coatings[itf.coating].kind == "metal":
                o_itf[i] = IF_METAL         # reflects only: nothing to refract
                o_coat[i] = coat_index[itf.coating]
            else:
                o_itf[i] = IF_SPLIT
                o_coat[i] = coat_index[itf.coating]
            if np.any(coat_T[0, o_coat[i]] > 0) if o_itf[i] == IF_SPLIT else o_itf[i] == IF_FRESNEL:
                feats.refract = True
        if obj.detector is not None:
            o_det[i] = len(det_rows)
            det_rows.append((i, obj))
    # scattering volumes
    nM = len(med_keys)
    med_sig = np.zeros((nM, L))
    med_alb = np.ones((nM, L))
    med_g = np.zeros((nM, L))
    med_phase = np.zeros(nM, np.int32)
    med_depol = np.zeros(nM)
    med_tgt = np.full(nM, -1, np.int32)
    med_nee = np.ones(nM, np.int32)
    for k in med_keys:
        vol = scene.media[k].params.get("volume") if scene.media[k].params else None
        if vol is None or k not in used_media:
            continue
        m = med_index[k]
        med_sig[m] = vol["extinction"]
        med_alb[m] = vol["albedo"]
        med_g[m] = vol["g"]
        med_phase[m] = 1 if vol["phase"] == "RAYLEIGH" else 2
        med_depol[m] = vol["depol"]
        med_nee[m] = vol["rays"]
        if vol["toward"] is not None:
            med_tgt[m] = obj_index[vol["toward"]]
            feats.importance = True
        feats.volume = True
    absorbing = [med_index[m] for m in sorted(used_media, key=med_keys.index)
                 if np.any(med_alpha[med_index[m]] > 0) or np.any(med_sig[med_index[m]] > 0)]
    feats.absorb_media = any(np.any(med_alpha[m] > 0) for m in absorbing)
    med_row = np.full(len(med_keys), -1, np.int32)
    for j, m in enumerate(absorbing):
        med_row[m] = nO + j

    # surfaces
    rows = []
    meshes = []
    for i, k in enumerate(obj_keys):
        obj = scene.objects[k]
        for s in obj.surfaces:
            local = obj.transform
            frame = M.Transform(M._matmul(local.R, s.frame.R), local.apply(s.frame.T))
            R, Th, Tl = world_frame(scene, frame, obj.group)
            rows.append((i, s, R, Th, Tl))
    nS = len(rows)
    s_obj = np.zeros(nS, np.int32)
    s_kind = np.zeros(nS, np.int32)
    s_par = np.zeros((nS, N_PAR))
    s_asph = np.zeros((nS, N_ASPH))
    s_nasph = np.zeros(nS, np.int32)
    s_ap_kind = np.zeros(nS, np.int32)
    s_ap = np.zeros((nS, 2))
    s_R = np.zeros((nS, 9))
    s_Th = np.zeros((nS, 3))
    s_Tl = np.zeros((nS, 3))
    s_size = np.zeros(nS)
    s_mesh = np.full(nS, -1, np.int32)
    s_bs = np.zeros((nS, 4))
    s_bounds = np.zeros((nS, 4))
    for j, (i, s, R, Th, Tl) in enumerate(rows):
        s_obj[j] = i
        s_kind[j] = SURFACE_CODES[s.kind]
        plug = SURFACES[s.kind]
        if plug.FEATURE:
            setattr(feats, plug.FEATURE, True)
        sp = plug.pack(s)
        par, a = sp.get("par", ()), sp.get("asph", ())
        if len(par) > N_PAR or len(a) > N_ASPH:
            raise error(s.span, f"{s.kind} packs {len(par)} parameters and {len(a)} asphere terms: at most {N_PAR} "
                        f"and {N_ASPH}")
        s_par[j, :len(par)] = par
        s_asph[j, :len(a)] = a
        s_nasph[j] = len(a)
        if sp.get("mesh") is not None:
            s_mesh[j] = len(meshes)
            meshes.append(sp["mesh"])
        if s.aperture is not None:
            s_ap_kind[j] = APERTURE_CODES[s.aperture.kind]
            s_ap[j, :len(s.aperture.params)] = s.aperture.params
        s_R[j], s_Th[j], s_Tl[j] = R, Th, Tl
        s_size[j] = _surface_size(s)
        s_bs[j] = _local_bounds(s)
        s_bounds[j] = surface_bounds(s)
        if max(abs(x) for x in Th) > 1e6:
            feats.precise = True

    # meshes
    def cat(idx, dtype, shape):
        arrs = [m[idx] for m in meshes]
        return np.ascontiguousarray(np.concatenate(arrs).astype(dtype)) if arrs else np.zeros(shape, dtype)

    m_node_n = np.array([len(m[2]) for m in meshes], np.int64)
    m_tri_n = np.array([len(m[4]) for m in meshes], np.int64)
    m_node_off = np.concatenate([[0], np.cumsum(m_node_n)[:-1]]).astype(np.int64) if meshes else np.zeros(0, np.int64)
    m_tri_off = np.concatenate([[0], np.cumsum(m_tri_n)[:-1]]).astype(np.int64) if meshes else np.zeros(0, np.int64)

    # detectors: pixels tile the aperture's bounding rectangle in the first surface's local x, y
    nD = len(det_rows)
    d_obj = np.zeros(nD, np.int32)
    d_nx = np.zeros(nD, np.int32)
    d_ny = np.zeros(nD, np.int32)
    d_ext = np.zeros((nD, 4))
    d_qe = np.ones((max(nD, 1), L))
    d_start = np.zeros(nD, np.int32)
    d_filters = []
    for d, (i, obj) in enumerate(det_rows):
        f = obj.detector.filters
        d_filters.append(None if not f else ([n for n, _ in f], np.array([t for _, t in f], float).T.copy()))
        if obj.detector.qe is not None:
            d_qe[d] = obj.detector.qe
        d_obj[d], d_nx[d], d_ny[d] = i, obj.detector.nx, obj.detector.ny
        if obj.detector.start is not None:    # DETECTOR ... START: binned by the rays' start points, any object
            d_start[d] = 1
            d_ext[d] = obj.detector.start
            continue
        ap = next(s.aperture for s in obj.surfaces if s.aperture is not None)
        if ap.kind == "RECT":
            hx, hy = ap.params
        elif ap.kind == "ELLIPSE":
            hx, hy = ap.params
        else:
            hx = hy = ap.params[-1]
        d_ext[d] = (-hx, hx, -hy, hy)

    src = _pack_sources(scene, lines, widths, obj_index)
    feats.source_kinds = source_kinds_of(src["src_kind"], src["src_dir"])
    feats.camera = any(s.kind == "CAMERA" for s in scene.sources)
    hero = any(s.kind == "CAMERA" and int(s.params.get("hero") or 0) > 1 for s in scene.sources)
    if hero and (feats.polar or feats.volume):
        # the script's check rejects POLARIZATION and VOLUME media with HERO; a POLARIZER or RETARDER interface, or
        # a VOLUME medium reached only here, would carry one Stokes vector or free path for all the lines
        cam = next(s for s in scene.sources if s.kind == "CAMERA")
        raise error(cam.span, "TRACE CAMERA ... HERO: the scene " + ("polarizes (a POLARIZER or RETARDER interface)"
                    if feats.polar else "has a VOLUME medium") + ", which HERO does not carry per line",
                    "trace it without HERO")
    feats.hero = bool(np.any(src["src_par"][:, SP_HERO] > 1.0))
    for t in src["src_Th"]:
        if np.max(np.abs(t)) > 1e6:
            feats.precise = True
    pk = Packed(lines, widths, [scene.objects[k].name for k in obj_keys], [scene.media[k].name for k in med_keys],
                  absorbing, feats, s_obj, s_kind, s_par, s_asph, s_nasph, s_ap_kind, s_ap, s_R, s_Th, s_Tl, s_size,
                  s_mesh, s_bs, m_node_off, m_node_n, m_tri_off, m_tri_n,
                  cat(0, np.float64, (0, 3)), cat(1, np.float64, (0, 3)), cat(2, np.int64, (0,)),
                  cat(3, np.int64, (0,)), cat(4, np.float64, (0, 9)), cat(5, np.int64, (0,)),
                  cat(6, np.float64, (0, 3)),
                  o_itf, o_coat, o_back, o_front, o_det, o_pol, med_n, med_alpha, med_row, med_sig, med_alb, med_g, med_phase,
                  med_depol, med_tgt, med_nee, coat_R, coat_T,
                  o_sc_first, o_sc_cnt, sp_kind, sp_model, sp_map, sp_cls_off, sp_cls_n, sp_rays, sp_tgt, cls_models,
                  map_data, map_off, map_nlat, map_nlon,
                  mod_kind, mod_P, mod_slab, [scene.models[m].name for m in used_models],
                  d_obj, d_nx, d_ny, d_ext, d_qe, [scene.objects[obj_keys[i]].name for i, _ in det_rows],
                  d_filters=d_filters, d_start=d_start, s_bounds=s_bounds, nee_cut=float(getattr(scene, 'importance_cut', 0.0)), **src)
    feats.shells = bool(np.any(shell_families(pk)[0] >= 0))
    if floor is not None:
        for f in dataclasses.fields(Features):
            if f.name not in KIND_FIELDS:
                setattr(feats, f.name, bool(getattr(feats, f.name) or getattr(floor, f.name)))
        if not used_models:
            feats.bsdf_kinds = tuple(floor.bsdf_kinds)
        if floor.source_kinds:
            from ..plugins.sources import REGISTRY as SOURCES

            both = set(feats.source_kinds) | set(floor.source_kinds)
            feats.source_kinds = tuple(k for k in SOURCES if k in both)
    return pk


def _pack_sources(scene: M.Scene, lines, widths, obj_index) -> dict:
    from ..plugins.surfaces.plane import axis_frame

    L = len(lines)
    S = len(scene.sources)
    out = dict(src_kind=np.zeros(S, np.int32), src_dir=np.zeros(S, np.int32), src_par=np.zeros((S, N_SRC_PAR)),
               src_R=np.zeros((S, 9)), src_Th=np.zeros((S, 3)), src_Tl=np.zeros((S, 3)), src_n=np.zeros(S, np.int64),
               src_off=np.zeros(S, np.int64), src_w=np.zeros((S, L)), src_random=np.zeros(S, np.int32),
               src_toward=np.full(S, -1, np.int32))
    out["src_lmap"] = np.tile(np.arange(L, dtype=np.int64), (S, 1))
    pts, pts_off = [], []
    total = 0
    emitted = np.zeros(L)
    npts = 0
    for i, s in enumerate(scene.sources):
        p = s.params
        kind = s.kind
        par = out["src_par"][i]
        area = None          # the source's emitting area for FLUX SPECTRUM in W/m2/nm
        nl = L               # lines this source traces
        if kind == "CAMERA":
            # camera-side (adjoint) rays: s x s stratified points per pixel of the camera's window, Lambertian
            # toward the aim object, weighted by pi A_pix L_light(line) / s^2 (irtlang/model/camera.py)
            pts_off.append(npts)
            out["src_kind"][i] = EMITTER_CODES["GRID RECT"]
            out["src_dir"][i] = DIR_LAMBERT
            out["src_random"][i] = SAMPLE_STRATIFIED
            par[:4] = p["extent"]
            par[4:6] = p["nx"] * p["sub"], p["ny"] * p["sub"]
            par[8] = p["side"]
            out["src_toward"][i] = obj_index[p["aim"]]
            # DIRECTIONS m: each start point sends 2 m^2 rays, a pair in each of m x m strata of the aim cone
            m = int(p.get("directions") or 0)
            par[SP_DIRECTIONS] = m
            par[SP_ELLIPSE] = 1.0 if p.get("ellipse") else 0.0
            par[SP_CORRELATED] = 1.0 if p.get("correlated") else 0.0
            per = 2 * m * m if m else 1
            # the light's radiance per line, L = P / (4 pi R^2) / pi, times pi A_pix / s^2 per camera ray
            # (and / 2 m^2 with DIRECTIONS)
            P = _line_power(scene, p["light_flux"], SUN_AREA_1AU, widths)
            wl = P * p["pixel_area"] / (4 * math.pi * p["light_radius"] ** 2 * p["sub"] ** 2 * per)
            resp = np.asarray(p["response"], float)        # (L, B): each image's weight per line
            wl[~(resp.max(axis=1) > 0.0)] = 0.0
            emitted += wl * p["nx"] * p["ny"] * p["sub"] ** 2 * per    # the expected emission of every scheme below
            if p["spectral"] > 0 and np.any(wl > 0):
                # K spectral samples per pixel stratum, drawn from the images' weights, each image an equal share
                bw = resp * (wl / max(wl.max(), 1e-300))[:, None]
                tot = bw.sum(axis=0)
                pmf = (bw[:, tot > 0] / tot[tot > 0]).sum(axis=1)
                pmf /= pmf.sum()
                keep = np.nonzero(pmf > 0)[0]
                cdf = np.cumsum(pmf[keep])
                cdf[-1] = 1.0
                rows = np.column_stack([cdf, keep.astype(float)])
                pts.append(rows)
                npts += len(rows)
                K = int(p["spectral"])
                par[9], par[10] = len(rows), K
                par[SP_PAIRED] = 1.0 if p.get("paired") else 0.0   # K / 2 strata, two rays each (model.camera)
                out["src_random"][i] = SAMPLE_SPECTRAL
                wl = np.where(pmf > 0, wl / np.where(pmf > 0, pmf, 1.0) / K, 0.0)
                nl = K
                # HERO K: each ray carries one line from each stratum of its block of K strata (K strata, or
                # K / 2 paired; trace_kernel._hero_start); the blocks interleave, each spanning the spectrum
                strata = K // 2 if p.get("paired") else K
                hk = int(p.get("hero") or 0)
                par[SP_HERO] = min(hk, strata) if hk > 1 and strata > 1 else 0.0
            else:
                lines_used = [k for k in range(L) if wl[k] > 0.0]
                nl = len(lines_used)
                out["src_lmap"][i, :nl] = lines_used
                # HERO K: the ray of traced line q (lmap[q]) carries the lines of its block of K traced lines, the
                # blocks starting at traced line hero_offset (trace_kernel._hero_start)
                par[SP_HERO] = min(int(p.get("hero") or 0), nl) if int(p.get("hero") or 0) > 1 else 0.0
                if par[SP_HERO] > 0:
                    par[SP_HERO_OFF] = int(p.get("hero_offset") or 0) % int(par[SP_HERO])
            guide = p.get("guide")
            if guide is not None:
                # GUIDE: t x t tiles of the start lattice, each a table of the aim cone's g x g cells (rows (cdf,
                # 1 / (g^2 pmf)), irtlang/model/camera.py); the pilot tallies by cell and tile
                g, t, pmf = guide["g"], guide["t"], guide.get("pmf")
                par[SP_GUIDE_T] = t
                if guide.get("pilot"):
                    par[SP_PILOT] = 1.0
                else:
                    pmf = np.asarray(pmf, float).reshape(t * t, g * g)
                    cdf = np.cumsum(pmf, axis=1)
                    cdf[:, -1] = 1.0
                    rows = np.column_stack([cdf.ravel(), (1.0 / (g * g * pmf)).ravel()])
                    par[SP_GUIDE] = g
                    par[SP_GUIDE_ROW] = npts - pts_off[-1]
                    pts.append(rows)
                    npts += len(rows)
            n = p["nx"] * p["ny"] * p["sub"] ** 2 * per
            R, Th, Tl = world_frame(scene, p["frame"], s.group)
            out["src_R"][i], out["src_Th"][i], out["src_Tl"][i] = R, Th, Tl
            out["src_n"][i] = n
            out["src_off"][i] = total
            total += n * nl
            out["src_w"][i] = wl
            continue
        if kind.startswith("GRID"):
            g, d = p["grid"], p["direction"]
            frame = axis_frame(g["axis"], g["position"])
            if kind.startswith("GRID RECT"):
                out["src_kind"][i] = EMITTER_CODES["GRID RECT"]
                par[:4] = g["x_min"], g["x_max"], g["y_min"], g["y_max"]
                par[4:6] = g["nx"], g["ny"]
                n = g["nx"] * g["ny"]
                area = (g["x_max"] - g["x_min"]) * (g["y_max"] - g["y_min"])
            else:
                out["src_kind"][i] = EMITTER_CODES["GRID DISK"]
                par[0] = g["radius"]
                area = math.pi * g["radius"] ** 2
                if g["random"]:
                    n = g["rays"]
                else:
                    rows, h = disk_lattice_rows(g["radius"], g["rays"])
                    par[1], par[2] = h, len(rows) - 1
                    pts.append(rows)
                    n = int(rows[-1, 0])
            pts_off.append(npts)
            npts += len(pts[-1]) if (kind.startswith("GRID DISK") and not g["random"]) else 0
            out["src_random"][i] = int(g["random"])
            dk = kind.split("+")[1]
            if dk == "DIRECTION":
                out["src_dir"][i] = DIR_COLLIMATED
                dv = d["direction"]
                # the direction is given in the source's frame (the group's), not the grid plane's
                par[6:9] = _inv_rotate(frame.R, dv)
            elif dk == "POSITION":
                out["src_dir"][i] = DIR_CONVERGE if d["converge"] else DIR_DIVERGE
                par[6:9] = _inv_rotate(frame.R, tuple(a - b for a, b in zip(d["point"], frame.T)))
            else:
                out["src_dir"][i] = DIR_FIELD
                par[6:8] = d["angle_x"], d["angle_y"]
                par[8] = -1.0 if g["position"] > 0 else 1.0     # toward the plane (axis) = 0
        else:
            pts_off.append(npts)
            out["src_dir"][i] = DIR_LAMBERT
            if kind == "EMITTING SPHERE":
                out["src_kind"][i] = EMITTER_CODES[kind]
                frame = M.Transform(T=p["centre"])
                par[0] = p["radius"]
                area = SUN_AREA_1AU
            elif kind == "EMITTING DISK":
                out["src_kind"][i] = EMITTER_CODES[kind]
                frame = axis_frame(p["axis"], p["position"])
                par[0], par[1] = p["radius"], p["cone"]
                area = math.pi * p["radius"] ** 2
            else:
                out["src_kind"][i] = EMITTER_CODES[kind]
                frame = M.Transform(T=p["position"])
                par[1] = p["cone"]
                par[2:5] = p["axis"]
            n = p["rays"]
            if p.get("toward") is not None:
                out["src_toward"][i] = obj_index[p["toward"].upper()]
        R, Th, Tl = world_frame(scene, frame, s.group)
        out["src_R"][i], out["src_Th"][i], out["src_Tl"][i] = R, Th, Tl
        out["src_n"][i] = n
        out["src_off"][i] = total
        total += n * L
        per_line = _line_power(scene, s.flux, area, widths)     # flux per ray, per line
        out["src_w"][i] = per_line / n
        emitted += per_line
    out["src_pts"] = np.ascontiguousarray(np.concatenate(pts)) if pts else np.zeros((0, 2))
    out["src_pts_off"] = np.asarray(pts_off, np.int64) if pts_off else np.zeros(0, np.int64)
    out["n_rays_total"] = int(total)
    out["emitted_W"] = emitted
    return out


SUN_AREA_1AU = 4 * math.pi * (1.495978707e11) ** 2    # FLUX SPECTRUM on an EMITTING SPHERE: irradiance at 1 AU


def _line_power(scene: M.Scene, f: M.Flux, area, widths) -> np.ndarray:
    """A source's emitted power per line (W): FLUX TOTAL split evenly, or FLUX SPECTRUM times the line widths
    (times the emitting area for an irradiance in W/m2/nm)."""
    L = len(widths)
    if f.kind == "total":
        return np.full(L, f.value / L)
    sp = scene.spectra[f.spectrum]
    vals = np.asarray(sp.on_lines, float) * widths
    if sp.unit == "W/m2/nm":
        if area is None:
            raise error(f.span, f"FLUX SPECTRUM {sp.name} is an irradiance (W/m2/nm), but an EMITTING "
                        "POINT has no area", "use FLUX TOTAL, or a TABLE spectrum in W/nm")
        vals = vals * area
    return vals


def disk_lattice_rows(radius: float, rays: int):
    """The square lattice of a regular GRID DISK, as a table of its rows: ((K + 1, 2) array, spacing h).

    The lattice is the points (a h, b h), a and b integers, with (a h)^2 + (b h)^2 <= radius^2 and
    h = sqrt(pi radius^2 / rays), ordered by row (b ascending) and along a row (a ascending).  Row k holds
    b = table[k, 1] and its points start at ray table[k, 0]; the last entry's start is the number of points.
    A row is symmetric (-a_max .. a_max), so its start and the next one's give a_max: the kernel turns a ray
    index into its point in O(log K) with O(sqrt(rays)) memory (the points themselves are never stored, so
    memory does not grow with the ray count)."""
    h = math.sqrt(math.pi * radius ** 2 / rays)
    m = int(math.ceil(radius / h)) + 1
    xs = np.arange(-m, m + 1) * h
    r2 = radius ** 2
    counts = np.zeros(2 * m + 1, np.int64)
    xs2 = xs ** 2
    blk = max(1, (1 << 18) // (2 * m + 1))   # blocks of rows: temporaries of ~2 MB whatever the ray count
    for k0 in range(0, 2 * m + 1, blk):
        ys = xs[k0:k0 + blk]
        counts[k0:k0 + len(ys)] = np.count_nonzero(xs2[None, :] + (ys ** 2)[:, None] <= r2, axis=1)
    keep = counts > 0
    b = np.arange(-m, m + 1)[keep]
    c = counts[keep]
    table = np.zeros((len(c) + 1, 2))
    table[1:, 0] = np.cumsum(c)
    table[:-1, 1] = b
    return table, h


def _inv_rotate(R, v):
    """R^T v for a row-major 3x3 R."""
    return tuple(sum(R[3 * k + i] * v[k] for k in range(3)) for i in range(3))
