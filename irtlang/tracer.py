"""The trace driver: pack the scene, pick the specialized kernel, run batches, reduce tallies.

Memory stays flat in the number of rays for image runs: detector images and the ledger are sums; per-ray
records are kept only when a later command needs them (SPOTS, FOCUS, STATS POSITION/DIRECTION, SAVE RAYS,
SELECT).  Results are bitwise identical for any thread count and batch size (see the kernel's docstring).
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from .compile.pack import Packed, pack
from .core.stats import standard_error, total_standard_error  # noqa: F401  (re-exported: irtlang.tracer.standard_error)
from .compile.specialize import kernel_cached, kernel_lock, kernel_module
from .kernels.reduce import reduce_batch
from .kernels.layout import SP_HERO, Detectors, Media, Objects, Records, Scatter, Settings, Sources, Surfaces, Tallies

HISTORY_CAP = 16


@dataclass
class TraceResult:
    packed: Packed
    ledger: np.ndarray          # (rows, 5, L): incident, reflected, transmitted, scattered, absorbed
    ledger_sq: np.ndarray       # (rows, L): sum over source rays of (incident flux that ray brought)^2
    images: dict                # detector name -> (sum (L, ny, nx), sum2)
    records: dict | None        # per-ray final states (see docs/rayfile.md)
    n_traced: int               # source rays traced
    seed: int
    interrupted: bool = False
    passes: int = 1
    stokes: dict | None = None  # POLARIZATION: detector name -> (sum (4, planes, ny, nx) of I, Q, U, V, sum2)
    paired: bool = False        # camera DIRECTIONS or paired SPECTRAL: the sums of squares are pairs' (a - b)^2
    correlated: bool = False    # a CORRELATED camera trace: its lines share random numbers (total_standard_error)

    @property
    def rows(self) -> list:
        return self.packed.row_names

    def flux_on(self, obj_index: int) -> tuple[float, float]:
        """Total incident flux on an object and its Monte Carlo standard error."""
        s1 = float(self.ledger[obj_index, 0].sum())
        return s1, total_standard_error(self, self.ledger[obj_index, 0], self.ledger_sq[obj_index])




def _object_bounds(pk: Packed) -> tuple[np.ndarray, np.ndarray]:
    """World bounding sphere of each object (for TOWARD), from its surfaces' (their plugins' ``bounds``);
    radius inf for an object with an unbounded surface."""
    nO = len(pk.object_names)
    spheres = [[] for _ in range(nO)]
    for j in range(len(pk.s_kind)):
        c, r = np.asarray(pk.s_bounds[j, :3], float), float(pk.s_bounds[j, 3])
        R = pk.s_R[j].reshape(3, 3)
        wc = R @ c + pk.s_Th[j] + pk.s_Tl[j]
        spheres[pk.s_obj[j]].append((wc, r))
    bc = np.zeros((nO, 3))
    br = np.full(nO, np.inf)
    for o, sph in enumerate(spheres):
        if not sph or any(not np.isfinite(r) for _, r in sph):
            continue
        cs = np.array([c for c, _ in sph])
        centre = cs.mean(0)
        bc[o] = centre
        br[o] = max(float(np.linalg.norm(c - centre)) + r for c, r in sph)
    return bc, br


class Progress:
    """A one-line progress display on a terminal: rays traced, rate, time left."""

    def __init__(self, total: int, enabled: bool | None = None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.total = total
        self.t0 = time.perf_counter()
        self.last = 0.0

    def update(self, done: int, force: bool = False) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self.last < 0.2:
            return
        self.last = now
        dt = max(now - self.t0, 1e-9)
        rate = done / dt
        left = (self.total - done) / rate if rate > 0 and self.total > done else 0.0
        self.stream.write(f"\rirt: traced {done:,}/{self.total:,} rays  {rate / 1e6:6.2f} Mrays/s  "
                          f"{left:6.1f} s left ")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


@dataclass
class BatchTally:
    """One batch's raw chunk tallies, before reduction (what a worker sends back)."""

    first: int
    n: int
    led: np.ndarray
    inc_sq: np.ndarray
    dep_idx: np.ndarray
    dep_w: np.ndarray
    dep_d: np.ndarray
    dep_n: np.ndarray
    records: dict | None


COMPILING = ("irt: compiling the tracer for this kind of scene (once per machine, a minute or more; "
             "`irt warmup FILE` does it ahead)")
_REDUCE_AHEAD = []         # not empty once this process has looked (_reduce_ahead)
# callables run once, before this process first compiles a trace kernel that Numba's cache lacks: `irt run`
# (irtlang.api.execute) puts here the start of irtlang.ahead, which compiles the run's later kernels meanwhile
COMPILE_AHEAD: list = []


def _reduce_ahead() -> None:
    """Where Numba's cache lacks reduce_batch (a machine's first trace), compile it in a background process
    (``python -m irtlang.kernels.reduce``) while this one compiles its trace kernel, the other core's share of a
    first run: 4-6 s (docs/architecture.md, "Compiled ahead").  Once per process; ``IRT_COMPILE_AHEAD=0`` turns
    it off.  This process never waits for it (it compiles reduce_batch itself if the other has not finished)."""
    from .core.background import start_python
    from .kernels import reduce as _reduce

    if _REDUCE_AHEAD:
        return
    _REDUCE_AHEAD.append(True)
    if not _reduce.cached():
        start_python("irtlang.kernels.reduce")


class TraceContext:
    """A packed scene with its specialized kernel, ready to trace any batch of ray ids (built once per worker)."""

    def __init__(self, pk: Packed, *, seed: int, level: int, halt: float, records: bool, history: bool):
        self.pk, self.seed, self.level, self.halt = pk, seed, level, halt
        self.records, self.history = records, history
        self.mod = kernel_module(pk.features)
        self.o_bc, self.o_br = _object_bounds(pk)
        # the scene's model kinds in the kernel's dispatch order (the all-features kernel dispatches over every
        # registered kind, a specialized one over the scene's own)
        disp = list(getattr(self.mod, 'BSDF_KINDS', pk.features.bsdf_kinds))
        used = list(pk.features.bsdf_kinds)
        self.mod_kind = (np.array([disp.index(used[q]) for q in pk.mod_kind], np.int32) if used
                         else np.asarray(pk.mod_kind, np.int32))
        self.s_f, self.s_i, self.mesh_i = pk.surface_tables()
        self.L = len(pk.lines_nm)
        self.rows = pk.n_rows
        self.total = pk.n_rays_total
        self.H = min(level, HISTORY_CAP) if history else 0
        # a polarized trace keeps four stacks per detector, I, Q, U, V (the kernel's deposit index runs over
        # (component, line, pixel)); images stay the I stack
        self.ns = 4 if pk.features.polar else 1
        self.d_sizes = [self.ns * self.L * int(ny) * int(nx) for nx, ny in zip(pk.d_nx, pk.d_ny)]
        self.d_off = (np.concatenate([[0], np.cumsum(self.d_sizes)[:-1]]).astype(np.int64) if self.d_sizes
                      else np.zeros(0, np.int64))
        # the images: one per line, or one per filter (DETECTOR ... FILTERS; reduce_batch applies the matrix)
        filt = list(pk.d_filters) or [None] * len(self.d_sizes)
        self.d_planes = [self.L if f is None else len(f[0]) for f in filt]
        self.i_sizes = [self.ns * b * int(ny) * int(nx) for b, nx, ny in zip(self.d_planes, pk.d_nx, pk.d_ny)]
        self.i_off = (np.concatenate([[0], np.cumsum(self.i_sizes)[:-1]]).astype(np.int64) if self.i_sizes
                      else np.zeros(0, np.int64))
        self.d_npix = np.array([int(ny) * int(nx) for nx, ny in zip(pk.d_nx, pk.d_ny)], np.int64)
        self.d_nb = np.array([0 if f is None else len(f[0]) for f in filt], np.int64)
        mats = [np.zeros(0) if f is None else np.ascontiguousarray(f[1], float).ravel() for f in filt]
        self.d_fm = np.concatenate(mats) if mats else np.zeros(0)
        self.d_fm_off = (np.concatenate([[0], np.cumsum([m.size for m in mats])[:-1]]).astype(np.int64) if mats
                         else np.zeros(0, np.int64))
        # room for each chunk's deposits: about two per source ray, K with HERO K (one per line it carries)
        hero = int(pk.src_par[:, SP_HERO].max()) if pk.src_par.shape[0] and pk.src_par.shape[1] > SP_HERO else 0
        self.cap = 2 * self.mod.CHUNK * max(1, hero)
        self._dep_buf = None
        # the kernel's argument structures (irtlang.kernels.layout), built once per context
        self.surfaces = Surfaces(self.s_f, self.s_i, self.mesh_i, pk.bvh_bmin, pk.bvh_bmax, pk.bvh_child,
                                 pk.bvh_count, pk.bvh_tris, pk.bvh_ids, pk.bvh_fn)
        self.objects = Objects(pk.o_itf, pk.o_coat, pk.o_back, pk.o_front, pk.o_det, pk.o_pol, self.o_bc, self.o_br,
                               pk.o_sc_first, pk.o_sc_cnt)
        self.scatter = Scatter(pk.sp_kind, pk.sp_model, pk.sp_map, pk.sp_cls_off, pk.sp_cls_n, pk.sp_rays, pk.sp_tgt,
                               pk.cls_models, pk.map_data, pk.map_off, pk.map_nlat, pk.map_nlon, self.mod_kind,
                               pk.mod_P, pk.mod_slab)
        self.media = Media(pk.med_n, pk.med_alpha, pk.med_row, pk.med_sig, pk.med_alb, pk.med_g, pk.med_phase,
                           pk.med_depol, pk.med_tgt, pk.med_nee, pk.coat_R, pk.coat_T)
        self.detectors = Detectors(pk.d_nx, pk.d_ny, pk.d_ext, self.d_off, pk.d_qe, pk.d_start)
        self.sources = Sources(pk.src_kind, pk.src_dir, pk.src_par, pk.src_R, pk.src_Th, pk.src_Tl, pk.src_n,
                               pk.src_off, pk.src_w, pk.src_random, pk.src_toward, pk.src_pts, pk.src_pts_off,
                               pk.src_lmap)
        self.rcap = 2 * self.mod.CHUNK if records else 1

    def compile(self) -> None:
        """Compile the kernel (or load it from Numba's cache) once per process, under kernel_lock: a batch of
        no rays has the same argument types as any other, so it makes the compiled code for them."""
        if getattr(self.mod, "_irt_ready", False):
            return
        _reduce_ahead()
        if COMPILE_AHEAD and not kernel_cached(self.mod):
            hooks = list(COMPILE_AHEAD)
            COMPILE_AHEAD.clear()
            for h in hooks:
                h()
        with kernel_lock(self.mod):
            self.run_batch(0, 0, _compiled=True)
        self.mod._irt_ready = True

    def run_batch(self, first: int, n: int, reuse: bool = False, _compiled: bool = False) -> BatchTally:
        """Trace one batch.  With `reuse` the deposit lists are the context's own buffers, kept from the last
        batch (no fresh pages to fault in per batch): the caller must consume the tally before the next call."""
        if not _compiled:
            self.compile()
        pk, L, rows, H = self.pk, self.L, self.rows, self.H
        nch = (n + self.mod.CHUNK - 1) // self.mod.CHUNK
        while True:
            led = np.zeros((nch, rows, 5, L))
            inc_sq = np.zeros((nch, rows, L))
            # the kernel writes every deposit entry before it reads it: no zeroing needed
            buf = self._dep_buf if reuse else None
            if buf is None or buf[0].shape[0] < nch or buf[0].shape[1] != self.cap:
                buf = (np.empty((nch, self.cap), np.int64), np.empty((nch, self.cap)), np.empty((nch, self.cap)))
                if reuse:
                    self._dep_buf = buf
            dep_idx, dep_w, dep_d = buf[0][:nch], buf[1][:nch], buf[2][:nch]
            dep_n = np.zeros(nch, np.int64)
            rc = self.rcap
            rec = dict(position=np.zeros((nch, rc, 6)), direction=np.zeros((nch, rc, 3)), flux=np.zeros((nch, rc)),
                       line=np.zeros((nch, rc), np.int32), source=np.zeros((nch, rc), np.int32),
                       object=np.zeros((nch, rc), np.int32), events=np.zeros((nch, rc), np.int32),
                       flags=np.zeros((nch, rc), np.uint32), history=np.zeros((nch, rc, H), np.int32),
                       opl=np.zeros((nch, rc)), start=np.zeros((nch, rc, 2)))
            rec_n = np.zeros(nch, np.int64)
            self.mod.trace_batch(
                Settings(int(first), int(n), int(self.total), int(self.seed), int(self.level), float(self.halt),
                         float(pk.nee_cut), int(pk.r_importance)),
                self.surfaces, self.objects, self.scatter, self.media, self.detectors, self.sources,
                Tallies(led, inc_sq, dep_idx, dep_w, dep_d, dep_n),
                Records(rec["position"], rec["direction"], rec["flux"], rec["line"], rec["source"], rec["object"],
                        rec["events"], rec["flags"], rec["history"], rec["opl"], rec["start"], rec_n))
            ok = True
            if np.any(dep_n < 0):
                self.cap *= 4   # a chunk overflowed its deposit list: trace the batch again with more room
                ok = False
            if self.records and np.any(rec_n < 0):
                self.rcap *= 4
                ok = False
            if ok:
                break
        recs = None
        if self.records:
            recs = {k: (np.concatenate([v[c, :rec_n[c]] for c in range(nch)]) if nch     # (no chunks: a batch
                        else v.reshape((0,) + v.shape[2:])) for k, v in rec.items()}        # of no rays)
            # the kernel writes positions as double-double (hi, lo): "position" stays the plain double,
            # "position_lo" keeps the rest, so points on an instrument placed 0.18 AU away stay exact
            recs["position"], recs["position_lo"] = recs["position"][:, :3].copy(), recs["position"][:, 3:].copy()
        return BatchTally(first, n, led, inc_sq, dep_idx, dep_w, dep_d, dep_n, recs)


class Accumulator:
    """Reduces batch tallies in ray-id order: the result does not depend on who traced which batch."""

    def __init__(self, ctx: TraceContext):
        self.ctx = ctx
        self.ledger = np.zeros((ctx.rows, 5, ctx.L))
        self.ledger_sq = np.zeros((ctx.rows, ctx.L))
        self.img = np.zeros(int(sum(ctx.i_sizes)))      # np.zeros, not zeros_like: pages a batch never touches
        self.img_sq = np.zeros(int(sum(ctx.i_sizes)))   # stay unmapped (a star on 1024^2 x 38 lines: 318 MB)
        self.rec_parts: list[dict] = []
        self.done = 0

    def add(self, t: BatchTally) -> None:
        c = self.ctx
        reduce_batch(t.led, t.inc_sq, t.dep_idx, t.dep_w, t.dep_d, t.dep_n, self.ledger, self.ledger_sq,
                     self.img, self.img_sq, c.d_off, c.d_npix, c.i_off, c.d_nb, c.d_fm, c.d_fm_off)
        if t.records is not None:
            self.rec_parts.append(t.records)
        self.done += t.n

    def result(self, passes: int = 1, interrupted: bool = False) -> TraceResult:
        ctx = self.ctx
        images = {}
        stokes = {} if ctx.ns == 4 else None
        for d, name in enumerate(ctx.pk.detector_names):
            shape = (ctx.ns, ctx.d_planes[d], int(ctx.pk.d_ny[d]), int(ctx.pk.d_nx[d]))
            a, b = int(ctx.i_off[d]), int(ctx.i_off[d]) + ctx.i_sizes[d]
            s1, s2 = self.img[a:b].reshape(shape), self.img_sq[a:b].reshape(shape)
            images[name] = (s1[0], s2[0])
            if stokes is not None:
                stokes[name] = (s1, s2)
        recs = None
        if ctx.records and self.rec_parts:
            recs = {k: np.concatenate([r[k] for r in self.rec_parts]) for k in self.rec_parts[0]}
        return TraceResult(ctx.pk, self.ledger, self.ledger_sq, images, recs, self.done, ctx.seed, interrupted, passes,
                           stokes)


def batches(total: int, batch: int, passes: int = 0):
    """(first ray id, count) of each batch of one pass over the sources."""
    start = 0
    while start < total:
        n = min(batch, total - start)
        yield passes * total + start, n
        start += n


BATCH_UNIT = 1 << 16          # rays per batch sent to a cluster worker, and with per-ray records
BATCH_TALLY_BYTES = 16 << 20  # in-process batches: as many chunks as keep a batch's tallies under this


def default_batch(ctx: TraceContext, runner=None) -> int:
    """Rays per batch.  Every batch is one parallel region (and its barrier, where idle threads spin): in
    process, batches as large as 256 chunks (262,144 rays) while their tallies stay under BATCH_TALLY_BYTES
    (a scene with many ledger rows and lines gets smaller ones, never under 64 chunks); BATCH_UNIT for a
    cluster's units and when per-ray records are kept."""
    if runner is not None or ctx.records:
        return BATCH_UNIT
    per_chunk = 8 * (ctx.rows * 6 * ctx.L) + 24 * ctx.cap
    return max(64, min(256, BATCH_TALLY_BYTES // per_chunk)) * ctx.mod.CHUNK


def run_trace(scene, *, seed: int, level: int, halt: float, until_error: float | None = None,
              until_target: str | None = None, records: bool = False, history: bool = False,
              batch: int | None = None, max_passes: int = 1000, progress: Progress | None = None,
              runner=None, features=None) -> TraceResult:
    """Trace a scene.  `runner(ctx, units) -> iterable of BatchTally in order` may run the batches elsewhere
    (irtlang.cluster); by default they run here, one after another, each in parallel over Numba threads.
    `batch` (rays per batch, whole chunks) defaults to ``default_batch``.  `features`: switched on beyond the
    scene's own (``pack``'s floor: run on a kernel another trace compiled)."""
    pk = pack(scene, records=records, history=history, floor=features)
    ctx = TraceContext(pk, seed=seed, level=level, halt=halt, records=records, history=history)
    # chunks are global (ray id // CHUNK), so results do not depend on the batch size: whole chunks per batch
    chunk = ctx.mod.CHUNK
    if batch is None:
        batch = default_batch(ctx, runner)
    batch = max(chunk, (batch + chunk - 1) // chunk * chunk)
    acc = Accumulator(ctx)
    target = list(scene.objects).index(until_target) if until_target else None
    if not getattr(ctx.mod, "_irt_ready", False):
        if hasattr(progress, "note") and not kernel_cached(ctx.mod):
            progress.note(COMPILING)
        if runner is None:
            ctx.compile()       # before the progress starts its clock: the rate it shows is the trace's
    prog = progress.start(ctx.total) if hasattr(progress, "start") else progress or Progress(ctx.total)
    passes = 0
    interrupted = False
    run = runner or (lambda c, units: (c.run_batch(f, n, reuse=True) for f, n in units))
    try:
        while True:
            for t in run(ctx, list(batches(ctx.total, batch, passes))):
                acc.add(t)
                prog.update(acc.done)
            passes += 1
            if until_error is None or target is None or passes >= max_passes:
                break
            s1 = acc.ledger[target, 0].sum()
            se = standard_error(s1, acc.ledger_sq[target].sum(), acc.done)
            if s1 > 0 and se / s1 <= until_error:
                break
    except KeyboardInterrupt:
        interrupted = True
    prog.update(acc.done, force=True)
    prog.close()
    return acc.result(passes, interrupted)
