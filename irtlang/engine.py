"""Executes the steps a script reaches: TRACE, SAVE/LOAD RAYS and the analysis commands.

The interpreter hands each step over as soon as it is reached, so results print in script order.  Every
printed result carries its Monte Carlo standard error.  Files go into the run folder (relative names) and
are written atomically; each is recorded in the manifest.

Selection model (ASAP-like):
* ``CONSIDER ONLY a b``: a later TRACE sees only those objects, and the analysis commands see only rays
  that ended on them; ``CONSIDER ALL`` undoes it.
* ``SELECT pred``: the analysis commands see only rays whose history satisfies pred; ``SELECT ALL`` undoes it.
* Detector images (EXPORT of an object with a DETECTOR, SPECTRUM OF) are streaming tallies over every ray;
  SELECT does not apply to them (they keep no per-ray data).  Record-based results (SPOTS, FOCUS,
  STATS POSITION/DIRECTION, EXPORT of an object without a DETECTOR, SAVE RAYS) honour both.
"""
from __future__ import annotations

import csv
import io
import math
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from .io.manifest import RunFolder
from .core.diagnostics import MissingCapability, RuntimeFailure, Span  # noqa: F401  (re-exported)
from .core.units import Quantity, UNITS, LENGTH, POWER
from .model import scene as M
from .core.stats import lit_pixels, result_standard_error, total_standard_error
from .tracer import standard_error


RECORD_STEPS = {"SPOTS", "FOCUS", "SAVE_RAYS", "EXPORT", "PSF"}
COLS = ("incident_W", "reflected_W", "transmitted_W", "scattered_W", "absorbed_W")


def needs_from_steps(steps) -> tuple[bool, bool]:
    """(records, history) that the program's steps need, decided from the checked program."""
    rec = hist = False
    scene = None
    for s in steps:
        if s.kind == "TRACE":
            scene = getattr(s, "scene", None)
        if s.kind == "EXPORT" and scene is not None and not s.params.get("diffraction"):
            obj = scene.objects.get(s.params.get("object"))
            if obj is not None and obj.detector is not None:
                continue    # a DETECTOR's image is a streaming sum: no per-ray records (memory flat in rays)
        if s.kind in RECORD_STEPS or (s.kind == "STATS" and s.params.get("what") != "LEDGER"):
            rec = True      # plain STATS, POSITION, DIRECTION and PATHS work on the selected rays' records
        if (s.kind == "STATS" and s.params.get("what") == "PATHS") or s.kind == "FOCUS":
            hist = True     # the path report; FOCUS's BFL (the last surface before the detector)
        if s.kind == "SELECT" and s.params.get("predicate") is not None:
            rec = hist = True
        if s.kind == "SAVE_RAYS":
            hist = True
    return rec, hist


def trace_memory_bytes(scene, records: bool, history: bool, level: int) -> float:
    """An estimate of the memory one TRACE of `scene` needs: its detector images (sum and sum of squares, and
    the copies the result keeps) and, when later commands need them, the per-ray records (irtlang.tracer: two
    record slots per source ray, 124 bytes each plus 4 per history entry, gathered into one array at the end)."""
    from .lang.interp import source_rays
    from .tracer import HISTORY_CAP

    L = len(scene.wavelengths_nm)
    img = 0.0
    for obj in scene.objects.values():
        d = obj.detector
        if d is not None:
            img += (len(d.filters) if d.filters else L) * float(d.nx) * float(d.ny) * 8 * 4
    rays = float(sum(source_rays(s) for s in scene.sources)) * L
    rec = rays * (124 + 4 * (min(level, HISTORY_CAP) if history else 0)) * 2 * 2 if records else 0.0
    return img + rec


def check_trace_memory(steps, limits) -> list:
    """Diagnostics for the TRACEs of a checked script whose estimated memory is over the limit `memory`."""
    from .core.diagnostics import Diagnostic

    records, history = needs_from_steps(steps)
    out = []
    for s in steps:
        if s.kind == "TRACE" and s.scene is not None:
            need = trace_memory_bytes(s.scene, records, history, int(s.params.get("level", 1000)))
            over = limits.exceeded("memory", need)
            if over:
                what = " (with per-ray records, which a later SPOTS, FOCUS, SAVE RAYS ... needs)" if records else ""
                out.append(Diagnostic(s.span, f"this TRACE would need about {over}{what}", limits.hint("memory")))
    return out


#: TRACE CAMERA ... GUIDE: the pilot's seed, the same in every run and frame (its tables are cached per instrument)
GUIDE_PILOT_SEED = 0x5EED_6D1DE


def hero_offset(seed: int, K: int) -> int:
    """Where a HERO trace's first full block of K lines (or strata) starts, from the trace's seed."""
    return ((int(seed) * 0x9E3779B97F4A7C15) >> 17) % int(K)


class Engine:
    def __init__(self, folder: RunFolder, *, records: bool = True, history: bool = True, progress=None,
                 out=None, runner=None):
        self.folder = folder
        self.runner = runner   # where TRACE runs its batches (irtlang.cluster.DaskRunner); None: in-process
        self.need_records, self.need_history = records, history
        self.progress = progress
        self.out = out or (lambda s: print(s, flush=True))
        self.result = None
        self.scene: M.Scene | None = None
        self.window = None
        self.pixels = (101, 101)
        self.consider: tuple | None = None
        self.predicate = None
        self.rays_traced = 0
        self._saved_from = {}   # resolved path of a SAVE RAYS file -> (the result and scene it was saved from)
        self.collector = None   # irtlang.io.results.ResultsCollector: every image, spectrum and ledger (results.nc)
        self.seed = None        # irt run --seed N: the first TRACE's seed (trace_seed)
        self._seed0 = None      # the script's SEED at the first TRACE (with --seed)
        self._guides = {}       # TRACE CAMERA ... GUIDE: the pilots' tables, by what the pilot traces

    def trace_seed(self, script_seed: int) -> int:
        """The seed a TRACE uses: the script's SEED, or with irt run --seed N, N plus the script's SEED's offset
        from the one its first TRACE used.  A script with one SEED (most) traces with N; a script that moves its
        SEED between traces (the flagship: a seed per hourly frame, so that the frames' errors are independent)
        keeps its traces apart under --seed too."""
        if self.seed is None:
            return int(script_seed)
        if self._seed0 is None:
            self._seed0 = int(script_seed)
        return (self.seed + int(script_seed) - self._seed0) % (1 << 63)

    # ------------------------------------------------------------------ dispatch
    def run_step(self, step: M.Step, interp) -> None:
        from .io.manifest import OutsideRunFolder
        from .core.diagnostics import IrtError, error

        fn = getattr(self, "do_" + step.kind.lower(), None)
        if fn is None:  # pragma: no cover - every step kind has a handler
            raise MissingCapability(step.span, step.kind, "an executor for this command")
        try:
            fn(step, interp)
        except OutsideRunFolder as e:   # a link in the run folder that leads out of it, say
            raise IrtError(error(step.span, str(e), "outputs stay inside the run folder unless "
                                 "`irt run --allow-outside` is given").diagnostics) from None
        except MemoryError:
            raise IrtError(error(step.span, "this command ran out of memory", "lower its rays or pixels; the "
                                 "limits of docs/language.md (\"Safety and limits\") catch most such requests at "
                                 "irt check time").diagnostics) from None
        except OSError as e:            # an output that cannot be written: a read-only folder, a full disk ...
            where = f" {e.filename}" if getattr(e, "filename", None) else ""
            raise IrtError(error(step.span, f"cannot write{where}: {e.strerror or e}").diagnostics) from None

    def _need_rays(self, step, what):
        if self.result is None:
            raise RuntimeFailure(step.span, f"{what} has no rays to work on: TRACE or LOAD RAYS first")

    def _lu(self) -> tuple[str, float]:
        u = (self.scene.units if self.scene else "MM")
        return u.lower(), UNITS[u.lower()][0]

    # ------------------------------------------------------------------ settings
    def do_reset(self, step, interp):
        self.result = None
        self.predicate = None

    def do_window(self, step, interp):
        self.window = dict(step.params)

    def do_pixels(self, step, interp):
        self.pixels = (step.params["nx"], step.params["ny"])

    def do_consider(self, step, interp):
        self.consider = step.params["objects"]

    def do_select(self, step, interp):
        self.predicate = step.params["predicate"]
        if self.result is not None and self.predicate is not None and self.result.records is None:
            raise RuntimeFailure(step.span, "SELECT needs ray records, which this trace did not keep")

    # ------------------------------------------------------------------ trace
    def do_trace(self, step, interp):
        from .compile.pack import MissingFeature
        from .tracer import run_trace

        sc = step.scene
        if self.consider:
            keep = set(self.consider)
            sc = M.replace(sc, objects=M.frozen_params({k: v for k, v in sc.objects.items() if k in keep}))
        p = step.params
        cam = p.get("camera")
        if cam is not None:
            self._trace_camera(step, sc, cam, interp)
            return
        try:
            res = run_trace(sc, seed=self.trace_seed(sc.seed), level=p["level"], halt=p["halt"], until_error=p["until_error"],
                            until_target=p["until_target"], records=self.need_records, history=self.need_history,
                            progress=self.progress, runner=self.runner)
        except MissingFeature as e:
            raise MissingCapability(e.span, e.what, e.capability) from None
        self.result = res
        self.scene = sc
        self.last_trace = (sc, p)     # PST and SPOTS DIAGRAM trace its sources again
        self.last_features = res.packed.features    # ... on its kernel (pack's floor: no compile of their own)
        self.rays_traced += res.n_traced
        self.folder.info["rays_traced"] = self.rays_traced
        tier = data_tier(sc, self.folder.info.get("data_tier"))
        self.folder.info["data_tier"] = tier
        if self.collector is not None:
            epoch = interp.lookup("EPOCH_UTC") if interp is not None else None
            self.collector.new_frame(epoch if isinstance(epoch, str) else None, res.n_traced)
        lost = res.ledger[res.packed.n_rows - 1, 4].sum()
        emitted = res.ledger[res.packed.n_rows - 4, 0].sum()
        msg = f"TRACE: {res.n_traced:,} rays, {emitted:.6g} W emitted"
        if res.passes > 1:
            msg += f" ({res.passes} passes)"
        if p["until_target"]:
            oi = list(sc.objects).index(p["until_target"])
            f, se = res.flux_on(oi)
            msg += f"; {sc.objects[p['until_target']].name}: {f:.6g} W +- {se:.2g} ({se / f:.2%})" if f else ""
        self.out(msg)
        if res.interrupted:
            self.out("TRACE: interrupted; the results hold the rays traced so far")
        if lost > 0:
            print(f"warning: {lost:.3g} W of ray flux was LOST to numerical failures "
                  f"(see STATS LEDGER)", file=sys.stderr)

    # TRACE CAMERA ... STOKES: six traces, each behind ideal elements on the detector's face (from the detector
    # outward; angles from its local x toward its y): linear analyzers at 0, 90, 45 and 135 deg, and two
    # circular ones (a polarizer at -+45 deg behind a quarter-wave retarder along x)
    STOKES_ANALYZERS = ((("polarizer", 0.0),), (("polarizer", math.pi / 2),),
                        (("polarizer", math.pi / 4),), (("polarizer", 3 * math.pi / 4),),
                        (("polarizer", -math.pi / 4), ("retarder", 0.0, math.pi / 2)),
                        (("polarizer", math.pi / 4), ("retarder", 0.0, math.pi / 2)))

    def _trace_camera(self, step, sc, cam, interp):
        """TRACE CAMERA: a camera-side (adjoint) trace (irtlang/model/camera.py).  Its image becomes the camera
        object's, so EXPORT, ANALYZE and the REPL see it as a forward trace's; per-pixel standard errors use the
        number of rays behind each pixel of each image (camera_scene's samples), not the whole trace's.  With
        STOKES, six traces behind ideal analyzers (STOKES_ANALYZERS; independent random streams: seed + k 2^40)
        give I, Q, U, V."""
        import dataclasses

        from .compile.pack import MissingFeature
        from .model.camera import camera_scene, with_guide
        from .tracer import run_trace

        p = step.params
        passes = self.STOKES_ANALYZERS if cam.get("stokes") else ((),)
        t0 = time.perf_counter()
        imgs, n_traced = [], 0
        guide = None
        for k, analyzer in enumerate(passes):
            csc, info = camera_scene(sc, cam, step.span, analyzer)
            seed = self.trace_seed(csc.seed)
            if info.get("hero", 0) > 1:
                # HERO: where the blocks of lines start, from the seed (frames of different seeds put the blocks'
                # edges, where their correlated errors step, in different places)
                src = csc.sources[0]
                off = hero_offset(seed, info["hero"])
                csc = M.replace(csc, sources=(M.replace(src, params=M.frozen_params(dict(src.params,
                                                                                       hero_offset=off))),))
                info["hero_offset"] = off
            if cam.get("guide"):
                if k == 0:
                    guide, gstats = self._camera_guide(csc, cam, info, step)
                if guide is not None:
                    csc = with_guide(csc, *guide)
                    info["guide"] = gstats
            try:
                res = run_trace(csc, seed=(seed + (k << 40)) % (1 << 63), level=p["level"], halt=p["halt"],
                                records=False, history=False, progress=self.progress, runner=self.runner)
            except MissingFeature as e:
                raise MissingCapability(e.span, e.what, e.capability) from None
            img, img2 = res.images.pop(csc.objects[info["light"]].name)
            # the rays behind one pixel of one image: SPECTRAL k draws k lines per point, each image taking its
            # share (zero for the others); without it each line's image has rays_per_pixel_line rays of its own
            n_p = info["rays_per_pixel_line"] * info["samples"]
            if info["paired"]:
                var = img2      # the sum over stratified pairs of (a - b)^2: the variance of the pixel's sum
            elif n_p > 1:
                var = np.maximum(img2 - img * img / n_p, 0.0) * (n_p / (n_p - 1))
            else:
                var = img2
            imgs.append((img, var))
            n_traced += res.n_traced
        if cam.get("stokes"):
            # the analyzers' images: I_a = (I + Q cos 2a' + U sin 2a') / 2 (a' the axis in the detector's Stokes
            # frame, e1 = its x, e2 = d x e1: the light arrives along -side n, so e2 = -side y and a' = -side a),
            # and the circular pair (I +- V) / 2 (docs/tracer.md, "Polarization"); independent traces, so their
            # variances add
            (a0, v0), (a90, v90), (a45, v45), (a135, v135), (ar, vr), (al, vl) = imgs
            sg = -info["side"]
            img = (a0 + a90 + a45 + a135 + ar + al) / 3.0
            var = (v0 + v90 + v45 + v135 + vr + vl) / 9.0
            stokes = (np.stack([img, a0 - a90, sg * (a45 - a135), sg * (ar - al)]),
                      np.stack([var, v0 + v90, v45 + v135, vr + vl]))
            res.stokes = {info["camera"]: stokes}
        else:
            img, var = imgs[0]
            # POLARIZATION: the camera paths carry Stokes vectors from an unpolarized pixel to the unpolarized
            # light; by reciprocity (each element's reversed Mueller matrix is diag(1, 1, -1, 1) M^T diag(1, 1,
            # -1, 1)) the light's I is the pixel's polarization-correct I.  Its Q, U and V mean nothing for the
            # pixel: dropped
            res.stokes = None
        res.images[info["camera"]] = (img, var)
        res.n_traced = n_traced
        self._camera_sun_variables(csc, res, info, interp, step)
        res.packed = dataclasses.replace(res.packed, detector_names=[info["camera"]])
        res.camera = info
        res.paired = info["paired"]
        if self.collector is not None:
            # results.nc's frames: a forward TRACE opens one; a camera trace opens one when the EPOCH moved on
            # since the last frame (a run whose later hours have camera traces only)
            epoch = interp.lookup("EPOCH_UTC") if interp is not None else None
            fr = self.collector.frames
            if isinstance(epoch, str) and (not fr or fr[-1]["epoch"] != epoch):
                self.collector.new_frame(epoch, n_traced)
        res.correlated = info["correlated"]
        self.result = res
        self.scene = csc
        self.rays_traced += res.n_traced
        self.folder.info["rays_traced"] = self.rays_traced
        i0, i1, j0, j1 = info["window"]
        rel = np.divide(np.sqrt(var), img, out=np.full_like(img, np.inf), where=img > 0)
        lit = lit_pixels(img) if img.size else img > 0
        med = float(np.median(rel[lit])) if lit.any() else float("nan")
        # and their root mean square: with pairs a pixel's variance comes from a few pairs, unbiased but itself
        # noisy, so the median of the per-pixel errors sits below the error they estimate (about 0.68 of it with
        # one pair's worth; docs/tracer.md, "Standard errors per pixel"); the mean of their squares does not
        rms = float(np.sqrt(np.mean(rel[lit] ** 2))) if lit.any() else float("nan")
        how = (f"{info['rays_per_pixel_line']} x {info['spectral']} per pixel, lines drawn from {info['lines']}"
               if info["spectral"] else f"{info['rays_per_pixel_line']} per pixel and line, {info['lines']} lines")
        if cam.get("stokes"):
            how += "; six traces behind ideal analyzers: I, Q, U, V"
        strata = info["spectral"] // 2 if info.get("paired") else info["spectral"]
        if info.get("hero", 0) > 1 and info["spectral"]:
            # (one stratum: nothing to carry, one line per ray; pack leaves HERO off)
            how += (f"; each ray carries a line from each of {min(info['hero'], strata)} strata of the bands' "
                    "weights (HERO)" if strata > 1 else "; one spectral stratum: HERO has nothing to add")
        elif info.get("hero", 0) > 1:
            how += f"; each ray carries the {min(info['hero'], info['lines'])} lines of its block (HERO)"
        self.out(f"TRACE CAMERA {info['camera']}: {res.n_traced:,} camera rays ({how}, "
                 f"pixels {i0}..{i1 - 1} x {j0}..{j1 - 1}); "
                 f"{img.sum():.6g} W on the window, median relative standard error {med:.2%} on lit pixels "
                 f"(root mean square {rms:.2%}); "
                 f"{time.perf_counter() - t0:.1f} s")

    def _camera_guide(self, csc, cam, info, step):
        """TRACE CAMERA ... GUIDE g: the pilot trace through the instrument alone toward the scene
        (irtlang/model/camera.py, guide_pilot), on the camera trace's own kernel (its features as the
        pilot's floor: no compilation of its own), and the tables the camera's rays then draw their directions
        from: ((pmf, g, t), the pilot's shares of directions that reach the scene), or (None, None) where the
        scene outside the instrument is unbounded (the trace then goes unguided)."""
        from .compile.pack import MissingFeature, pack
        from .model.camera import guide_pilot, guide_tables, instrument_objects, pilot_key
        from .tracer import _object_bounds, run_trace

        t0 = time.perf_counter()
        pk = pack(csc)
        keep = instrument_objects(csc, cam["camera"], info["light"])
        bc, br = _object_bounds(pk)
        rest = [i for i, k in enumerate(csc.objects) if k not in keep and csc.objects[k].name != info["light"]]
        if not rest or not np.all(np.isfinite(br[rest])):
            self.out(f"TRACE CAMERA {info['camera']}: GUIDE needs a bounded scene outside the instrument: "
                     "the rays go unguided")
            return None, None
        # the target: a sphere about the scene's centre, half as wide as the scene is far (a ray that leaves the
        # instrument toward the scene reaches it wherever the scene's own edges are)
        big = max(rest, key=lambda i: br[i])
        centre = bc[big]
        radius = 0.5 * float(np.linalg.norm(centre - (pk.src_Th[0] + pk.src_Tl[0])))
        pilot, pinfo = guide_pilot(csc, cam, info, step.span, (centre, radius))
        g, t = pinfo["g"], pinfo["t"]
        # the same instrument, window and scene centre give the same tally: the pilot has a seed of its own (not
        # the trace's), so a cached tally is the one the pilot would give again (the tables follow from it and
        # the trace's NEAR share)
        key = pilot_key(pilot, step.params["level"])
        hit = self._guides.get(key)
        if hit is None:
            try:
                res = run_trace(pilot, seed=GUIDE_PILOT_SEED, level=step.params["level"], halt=0.0,
                                features=pk.features)
            except MissingFeature as e:
                raise MissingCapability(e.span, e.what, e.capability) from None
            img, _ = res.images[pinfo["catcher"]]
            hit = self._guides[key] = (img.sum(axis=0), res.n_traced)
            how = f"{res.n_traced:,} pilot rays through {pinfo['kept']} objects"
        else:
            how = "the pilot of an earlier trace: the same instrument and window"
        near = cam.get("guide_near")
        pmf, stats = guide_tables(hit[0], g, t, near)
        stats = dict(stats, cells=g, tiles=t, pilot_rays=hit[1])
        self.out(f"TRACE CAMERA {info['camera']}: GUIDE {g} x {g} cells of the aim cone in {t} x {t} tiles"
                 + (f", {near:g} of the rays near the clear cells" if near is not None else "") + " "
                 f"({how}): {stats['uniform']:.1%} of the directions reach the scene, {stats['guided']:.1%} of "
                 f"the guided ones; {time.perf_counter() - t0:.1f} s")
        return (pmf, g, t), stats

    def _camera_sun_variables(self, csc, res, info, interp, step):
        """CAMERA_SUN[_filter]: the light's irradiance at 1 AU summed over each image's band (W/m2), weighted as
        the image is (filter transmission times QE): the white reference of an I/F (docs/tracer.md)."""
        from .compile.pack import SUN_AREA_1AU, _line_power
        from .core.units import NONE, Quantity

        src = csc.sources[0]
        pk = res.packed
        E = _line_power(csc, src.flux, SUN_AREA_1AU, pk.line_width_nm) / SUN_AREA_1AU
        det = csc.objects[next(k for k, o in csc.objects.items() if o.name == info["light"])].detector
        qe = np.asarray(det.qe if det.qe is not None else np.ones(len(E)), float)
        if det.filters:
            for name, tr in det.filters:
                interp.assign(f"CAMERA_SUN_{name}", Quantity(float(np.sum(E * qe * np.asarray(tr, float))), NONE),
                              step.span)
        else:
            interp.assign("CAMERA_SUN", Quantity(float(np.sum(E * qe)), NONE), step.span)

    # ------------------------------------------------------------------ record selection
    def _selected(self, step, what, obj_filter=None) -> np.ndarray:
        """Mask of the records the analysis sees (CONSIDER, SELECT, and an optional last-object filter)."""
        self._need_rays(step, what)
        r = self.result.records
        if r is None:
            raise RuntimeFailure(step.span, f"{what} needs ray records, which this trace did not keep")
        m = np.ones(len(r["flux"]), bool)
        names = self._keys()
        if self.consider:
            idx = [names.index(k) for k in self.consider if k in names]
            m &= np.isin(r["object"], idx)
        if obj_filter is not None:
            if obj_filter not in names:
                raise RuntimeFailure(step.span, f"{what}: object {obj_filter} is not among the rays' objects")
            m &= r["object"] == names.index(obj_filter)
        if self.predicate is not None:
            unknown = [k for k in _pred_objects(self.predicate) if k not in names]
            if unknown:
                raise RuntimeFailure(step.span, f"{what}: SELECT names {', '.join(unknown)}, which the rays never met "
                                     "(not part of the last TRACE or ray file)")
            m &= _eval_pred(self.predicate, r, names, self.result.packed.lines_nm)
        return m

    def _keys(self) -> list:
        """Object keys in the order the records index them (a loaded ray file: the file's objects)."""
        keys = getattr(self.result, "object_keys", None)
        return list(keys) if keys is not None else list(self.scene.objects)

    def _rel_positions(self, m):
        """(ref, p - ref) for the selected records, with the records' low parts (position_lo) when they have them:
        spots on a focal plane 0.18 AU from the origin keep their sub-micrometre detail."""
        r = self.result.records
        p = r["position"][m]
        ref = p[0].copy() if len(p) else np.zeros(3)
        lo = r.get("position_lo")
        return ref, (p - ref) + (lo[m] if lo is not None else 0.0)

    # ------------------------------------------------------------------ analysis
    def do_stats(self, step, interp):
        what = step.params["what"]
        if what == "LEDGER":
            self._need_rays(step, "STATS LEDGER")
            res = self.result
            if res.ledger is None:
                raise RuntimeFailure(step.span, "STATS LEDGER: this ray file holds no ledger (written by an older "
                                     "irtlang, or a file not written by SAVE RAYS); trace the scene again for it")
            led = res.ledger.sum(axis=2)
            rows = res.rows
            se = _se_rows(res)
            lines = [f"{'object':<16}" + "".join(f"{c:>16}" for c in COLS)]
            for name, row, e in zip(rows, led, se):
                lines.append(f"{name:<16}" + "".join(f"{v:16.6g}" for v in row) + (f"   +- {e:.2g}" if e else ""))
            total_abs = led[:, 4].sum()
            emitted = led[len(rows) - 4, 0]
            lines.append(f"ledger: sum of absorbed_W = {total_abs:.12g} W, EMITTED = {emitted:.12g} W, "
                         f"relative difference {abs(total_abs - emitted) / emitted if emitted else 0:.1e}")
            self.out("\n".join(lines))
            if self.collector is not None:
                self.collector.add_ledger(rows, led, se, step.params["file"] or "")
            if step.params["file"]:
                buf = io.StringIO()
                w = csv.writer(buf, lineterminator="\n")
                w.writerow(("object",) + COLS)
                for name, row in zip(rows, led):
                    w.writerow([name] + [repr(float(v)) for v in row])
                self._write_text(step.params["file"], buf.getvalue(), "ledger")
            return
        if what == "PATHS":
            from .optics.stray_step import run_paths   # the path report (irtlang/optics/stray.py)
            run_paths(self, step, interp)
            return
        label = f"STATS {what}" if what else "STATS"
        m = self._selected(step, label)
        r = self.result.records
        w = r["flux"][m]
        unit, f = self._lu()
        n = int(m.sum())
        tot = float(w.sum())
        se = self._se_of(m)
        interp.assign("STATS_FLUX", Quantity(tot, POWER), step.span)
        interp.assign("STATS_FLUX_SE", Quantity(se, POWER), step.span)
        interp.assign("STATS_RAYS", Quantity(float(n)), step.span)
        if n == 0:
            self.out(f"{label}: no rays selected")
            return
        if not what:   # the selected rays' flux on each object they ended on
            names = list(self.result.packed.object_names)
            objs = r["object"][m]
            lines = [f"STATS: {n:,} rays selected, flux {tot:.6g} W +- {se:.2g}"]
            rows = []
            for o in np.unique(objs):
                mo = m.copy()
                mo[m] = objs == o
                fo, eo = float(r["flux"][mo].sum()), self._se_of(mo)
                nm = names[o] if 0 <= o < len(names) else "(none)"
                rows.append((nm, int(mo.sum()), fo, eo))
                lines.append(f"  on {nm}: {int(mo.sum()):,} rays, {fo:.6g} W +- {eo:.2g}")
            self.out("\n".join(lines))
            if step.params["file"]:
                text = "object,rays,flux_W,stderr_W\n" + "".join(f"{a},{b},{c!r},{d!r}\n" for a, b, c, d in rows)
                text += f"total,{n},{tot!r},{se!r}\n"
                self._write_text(step.params["file"], text, "stats")
            return
        ref, vec = self._rel_positions(m) if what == "POSITION" else (np.zeros(3), r["direction"][m])
        vec = vec / f if what == "POSITION" else vec
        mean = (vec * w[:, None]).sum(0) / tot if tot else vec.mean(0)
        sd = np.sqrt(((vec - mean) ** 2 * w[:, None]).sum(0) / tot) if tot else np.zeros(3)
        mean = mean + ref / (f if what == "POSITION" else 1.0)
        sem = sd / math.sqrt(max(n - 1, 1))
        lab = f" ({unit})" if what == "POSITION" else ""
        self.out(f"STATS {what}: {n:,} rays, flux {tot:.6g} W +- {se:.2g}\n"
                 + "\n".join(f"  {a}: mean {mu:.9g} +- {e:.2g}{lab}, rms spread {s:.6g}"
                             for a, mu, e, s in zip("XYZ", mean, sem, sd)))
        dim = LENGTH if what == "POSITION" else None
        for a, mu in zip("XYZ", mean):
            interp.assign(f"STATS_{a}", Quantity(float(mu) * (f if dim else 1.0), dim), step.span)
        if step.params["file"]:
            text = f"axis,mean,stderr,rms_spread\n" + "".join(f"{a},{mu!r},{e!r},{s!r}\n" for a, mu, e, s in
                                                              zip("XYZ", map(float, mean), map(float, sem), map(float, sd)))
            self._write_text(step.params["file"], text, "stats")

    def _se_of(self, m) -> float:
        """Standard error of the selected records' total flux, the records grouped by source ray."""
        from .optics.stray import grouped_se, ray_keys

        r = self.result.records
        sub = {k: r[k][m] for k in ("source", "line", "flux") if k in r}
        if r.get("start") is not None:
            sub["start"] = r["start"][m]
        return grouped_se(sub["flux"], ray_keys(sub), self.result.n_traced)

    def _window(self, vec):
        if self.window:
            wd = self.window
            ax = ("XYZ".index(wd["axis1"]), "XYZ".index(wd["axis2"]))
            return ax, (wd["min1"], wd["max1"]), (wd["min2"], wd["max2"])
        # no WINDOW: the two axes across the rays' mean direction, a square around the rays
        d = self.result.records["direction"]
        main = int(np.argmax(np.abs(d.mean(0)))) if len(d) else 2
        ax = tuple(i for i in range(3) if i != main)
        lo, hi = vec[:, ax].min(0), vec[:, ax].max(0)
        c = 0.5 * (lo + hi)
        h = max(float((hi - lo).max()) / 2 * 1.05, 1e-15 * max(1.0, float(np.abs(c).max())))
        return ax, (c[0] - h, c[0] + h), (c[1] - h, c[1] + h)

    def do_spots(self, step, interp):
        if step.params["what"] == "DIAGRAM":
            from .optics.spots_step import run_spot_diagram   # spot diagrams (irtlang/optics/spots.py)
            run_spot_diagram(self, step, interp)
            return
        m = self._selected(step, "SPOTS")
        r = self.result.records
        if not m.any():
            self.out("SPOTS: no rays selected")
            return
        unit, f = self._lu()
        vec = r["position"][m] if step.params["what"] == "POSITION" else r["direction"][m]
        ax, (a0, a1), (b0, b1) = self._window(vec)
        w = r["flux"][m]
        nx, ny = self.pixels
        img, _, _ = np.histogram2d(vec[:, ax[1]], vec[:, ax[0]], bins=(ny, nx), range=((b0, b1), (a0, a1)), weights=w)
        inside = ((vec[:, ax[0]] >= a0) & (vec[:, ax[0]] <= a1) & (vec[:, ax[1]] >= b0) & (vec[:, ax[1]] <= b1))
        x, y = vec[:, ax[0]], vec[:, ax[1]]
        ox = oy = 0.0
        if step.params["what"] == "POSITION":
            ref, rel = self._rel_positions(m)
            x, y, ox, oy = rel[:, ax[0]], rel[:, ax[1]], ref[ax[0]], ref[ax[1]]
        tot = w.sum()
        wg = w if tot > 0 else np.ones_like(w)   # rays that carry no flux (FLUX TOTAL 0): their plain centroid
        cx, cy = (x * wg).sum() / wg.sum(), (y * wg).sum() / wg.sum()
        rms = math.sqrt(((x - cx) ** 2 + (y - cy) ** 2) @ wg / wg.sum())
        cx, cy = ox + cx, oy + cy
        scale = f if step.params["what"] == "POSITION" else 1.0
        lab = unit if step.params["what"] == "POSITION" else "(direction cosine)"
        geo = math.sqrt(float(((x - (cx - ox)) ** 2 + (y - (cy - oy)) ** 2).max()))
        local = ""
        if step.params["what"] == "POSITION":   # the centroid in the frame of the object most rays ended on
            from .optics.spots import detector_frame

            objs = r["object"][m]
            det = int(np.bincount(objs[objs >= 0]).argmax()) if (objs >= 0).any() else -1
            fr = detector_frame(self.result.packed, det) if det >= 0 else None
            if fr is not None:
                c3 = np.zeros(3)
                c3[ax[0]], c3[ax[1]] = cx, cy
                c3[[i for i in range(3) if i not in ax][0]] = float(r["position"][m][:, [i for i in range(3)
                                                                                        if i not in ax][0]].mean())
                lx, ly = float((c3 - fr[0]) @ fr[1]), float((c3 - fr[0]) @ fr[2])
                local = (f"; on {self.result.packed.object_names[det]} (its local x, y): centroid "
                         f"{lx / f:.9g}, {ly / f:.9g} {unit}")
        self.out(f"SPOTS {step.params['what']}: {int(m.sum()):,} rays, {tot:.6g} W +- {self._se_of(m):.2g}"
                 f" ({inside.mean():.1%} in the window); centroid {'XYZ'[ax[0]]} {cx / scale:.9g}, "
                 f"{'XYZ'[ax[1]]} {cy / scale:.9g} {lab}; rms radius {rms / scale:.6g} {lab}, geo radius "
                 f"{geo / scale:.6g} {lab}{local}")
        dim = LENGTH if step.params["what"] == "POSITION" else None
        for var, v in (("SPOTS_RMS", rms), ("SPOTS_GEO", geo), ("SPOTS_X", cx), ("SPOTS_Y", cy)):
            interp.assign(var, Quantity(float(v), dim), step.span)
        interp.assign("SPOTS_FLUX", Quantity(float(tot), POWER), step.span)
        if step.params["file"]:
            self._write_image(step.params["file"], img[None], "spots", extent=(a0 / scale, a1 / scale, b0 / scale, b1 / scale),
                              per_line=False, name="spots", coord_unit=None if step.params["what"] == "POSITION" else "1")

    def do_focus(self, step, interp):
        m = self._selected(step, "FOCUS")
        r = self.result.records
        if m.sum() < 2:
            raise RuntimeFailure(step.span, "FOCUS needs at least two selected rays")
        p, d, w = self._rel_positions(m)[1], r["direction"][m], r["flux"][m]   # only differences of p matter
        if not w.sum() > 0:
            w = np.ones_like(w)    # rays that carry no flux (FLUX TOTAL 0): weigh them equally, as STATS does
        axis = (d * w[:, None]).sum(0)
        if not np.abs(axis).max() > 0:
            raise RuntimeFailure(step.span, "FOCUS: the selected rays have no mean direction")
        axis /= np.abs(axis).max()   # to O(1) first: with denormal fluxes the squares in the norm underflow
        axis /= np.linalg.norm(axis)
        a = int(np.argmax(np.abs(axis)))
        sgn = 1.0 if axis[a] > 0 else -1.0
        # transverse coordinates and slopes per unit advance along the axis
        da = d[:, a]
        if np.any(np.abs(da) < 1e-12):
            raise RuntimeFailure(step.span, "FOCUS: some rays run across the axis")
        tr = [i for i in range(3) if i != a]
        x0 = p[:, tr]
        u = d[:, tr] / da[:, None]
        W = w.sum()
        xm, um = (x0 * w[:, None]).sum(0) / W, (u * w[:, None]).sum(0) / W
        X, U = x0 - xm, u - um
        den = (w[:, None] * U * U).sum()
        s = -(w[:, None] * X * U).sum() / den if den > 0 else 0.0
        rms0 = math.sqrt((w[:, None] * X * X).sum() / W)
        Xs = X + s * U
        rms = math.sqrt((w[:, None] * Xs * Xs).sum() / W)
        unit, f = self._lu()
        # the absolute best-focus point: the rays' centroid moved by s along the axis coordinate
        ref = self._rel_positions(m)[0]
        pa = float((p[:, a] * w).sum() / W)
        best = np.empty(3)
        best[a] = ref[a] + pa + s
        best[tr] = ref[tr] + xm + um * s
        s *= sgn   # s above is a shift of the axis coordinate; report it along the rays' direction of travel
        where = "beyond" if s > 0 else "short of"
        self.out(f"FOCUS: best focus {s / f:+.9g} {unit} along {'+-'[sgn < 0]}{'XYZ'[a]} from the rays' end points "
                 f"(RMS radius {rms / f:.6g} {unit} there, {rms0 / f:.6g} {unit} at the end points; "
                 f"{int(m.sum()):,} rays)\n"
                 f"  best-focus position X {best[0] / f:.9g}, Y {best[1] / f:.9g}, Z {best[2] / f:.9g} {unit}: "
                 f"{abs(s) / f:.6g} {unit} {where} the rays' end points, along the light")
        interp.assign("FOCUS_SHIFT", Quantity(s, LENGTH), step.span)
        interp.assign("FOCUS_RMS", Quantity(rms, LENGTH), step.span)
        for k, ax_name in enumerate("XYZ"):
            interp.assign(f"FOCUS_{ax_name}", Quantity(float(best[k]), LENGTH), step.span)
        from .optics.spots import paraxial_report   # EFL, BFL, f-number, magnification
        paraxial_report(self, step, interp, m, axis)

    def do_spectrum_of(self, step, interp):
        self._need_rays(step, "SPECTRUM OF")
        res = self.result
        if res.ledger is None:
            raise RuntimeFailure(step.span, "SPECTRUM OF needs the flux ledger of a TRACE: loaded rays carry none")
        names = self._keys()
        key = step.params["object"]
        if key not in names:
            raise RuntimeFailure(step.span, f"object {key} was not part of the last TRACE (CONSIDER)")
        if res.ledger is None:
            raise RuntimeFailure(step.span, "SPECTRUM OF: this ray file holds no ledger (written by an older irtlang)")
        o = names.index(key)
        if step.params.get("stokes"):
            return self._spectrum_stokes(step, o, interp)
        cam = getattr(res, "camera", None)
        shown_name = res.packed.object_names[o]
        if cam is not None and self.scene.objects[key].name == cam["camera"]:
            # after TRACE CAMERA: what the camera's window receives per line, the flux its rays brought back from
            # the light (the light's ledger row: every camera ray is an independent sample, or a stratified pair)
            o = names.index(next(k for k in names if self.scene.objects[k].name == cam["light"]))
        flux = res.ledger[o, 0]
        se = result_standard_error(res, flux, res.ledger_sq[o])
        tot_se = None
        if (cam is not None and cam.get("hero", 0) > 1 and not cam.get("spectral")
                and self.scene.objects[key].name == cam["camera"]):
            # HERO: the light's ledger row is the hero lines' own (each ray books its hero's weight); the lines'
            # combined estimates are the camera's image, per line (its pixels are independent: a source ray
            # deposits in its start pixel only), without the QE the image applies
            img, var = res.images[cam["camera"]]
            qe = np.asarray(self.scene.objects[names[o]].detector.qe or np.ones(len(flux)), float)
            q = np.where(qe > 0, qe, 1.0)
            flux = img.reshape(len(flux), -1).sum(axis=1) / q
            se = np.sqrt(var.reshape(len(flux), -1).sum(axis=1)) / q
            # the total: lines of one block share their rays (correlated errors: their standard errors add, the
            # bound for any correlation), blocks are independent (their variances add); the blocks are those of
            # the traced lines (the camera source's line map), from the line the seed chose (_trace_camera)
            pk = res.packed
            traced = pk.src_lmap[0][:int(round(res.n_traced / pk.src_n[0]))]
            K, off = min(cam["hero"], len(traced)), cam.get("hero_offset", 0)
            st = se[traced]
            tot_se = float(np.sqrt(sum(st[max(0, b):b + K].sum() ** 2 for b in range(off - K, len(st), K))))
        lines = ["wavelength_nm,flux_W,stderr_W"] + [f"{lam:.6g},{repr(float(f))},{repr(float(e))}"
                                                     for lam, f, e in zip(res.packed.lines_nm, flux, se)]
        shown = lines[:1] + lines[1:8] + (["..."] if len(lines) > 9 else []) + (lines[-1:] if len(lines) > 8 else [])
        self.out(f"SPECTRUM OF {shown_name}:\n  " + "\n  ".join(shown))
        if self.collector is not None:
            self.collector.add_spectrum(shown_name, res.packed.lines_nm, flux, se,
                                        step.params["file"] or "")
        tot = float(flux.sum())
        interp.assign("SPECTRUM_FLUX", Quantity(tot, POWER), step.span)
        if tot_se is None:
            tot_se = total_standard_error(res, flux, res.ledger_sq[o])
        interp.assign("SPECTRUM_FLUX_SE", Quantity(tot_se, POWER), step.span)
        if step.params["file"]:
            self._write_text(step.params["file"], "\n".join(lines) + "\n", "spectrum")

    def _spectrum_stokes(self, step, o, interp):
        """SPECTRUM OF obj ['file'] STOKES: I, Q, U, V per line from the object's DETECTOR, which must have one
        pixel and no FILTERS: its tallies are then sums over whole source rays, so the standard errors are exact
        (a many-pixel image's total would need the covariances between its pixels).  QE applies, as to images."""
        res = self.result
        name = res.packed.object_names[o]
        st = getattr(res, "stokes", None)
        if getattr(res, "camera", None) is not None:
            raise RuntimeFailure(step.span, f"SPECTRUM OF {name} STOKES after TRACE CAMERA: a camera trace's Stokes "
                                 "vectors are images: EXPORT the camera ... STOKES after TRACE CAMERA ... STOKES")
        if not st:
            raise RuntimeFailure(step.span, f"SPECTRUM OF {name} STOKES needs a polarized trace: put POLARIZATION "
                                 "before TRACE")
        if name not in st:
            raise RuntimeFailure(step.span, f"SPECTRUM OF {name} STOKES needs a DETECTOR on {name} (DETECTOR PIXELS 1)")
        s1, s2 = st[name]
        d = res.packed.detector_names.index(name)
        filt = res.packed.d_filters[d] if getattr(res.packed, "d_filters", None) else None
        if s1.shape[2] * s1.shape[3] != 1 or filt is not None:
            raise RuntimeFailure(step.span, f"SPECTRUM OF {name} STOKES needs a one-pixel DETECTOR without FILTERS "
                                 f"(DETECTOR PIXELS 1; {name} has {s1.shape[3]} x {s1.shape[2]}"
                                 + (" and FILTERS" if filt is not None else "") + "): EXPORT ... STOKES writes images")
        x = s1[:, :, 0, 0]
        e = np.asarray(standard_error(x, s2[:, :, 0, 0], res.n_traced))
        head = "wavelength_nm,I_W,Q_W,U_W,V_W,stderr_I_W,stderr_Q_W,stderr_U_W,stderr_V_W"
        lines = [head] + [",".join([f"{lam:.6g}"] + [repr(float(v)) for v in x[:, k]] + [repr(float(v)) for v in e[:, k]])
                          for k, lam in enumerate(res.packed.lines_nm)]
        shown = lines[:1] + lines[1:8] + (["..."] if len(lines) > 9 else []) + (lines[-1:] if len(lines) > 8 else [])
        self.out(f"SPECTRUM OF {name} STOKES:\n  " + "\n  ".join(shown))
        tot = float(x[0].sum())       # a ray carries one line: the lines' squares add up to the total's
        interp.assign("SPECTRUM_FLUX", Quantity(tot, POWER), step.span)
        interp.assign("SPECTRUM_FLUX_SE", Quantity(float(standard_error(tot, s2[0, :, 0, 0].sum(), res.n_traced)),
                                                   POWER), step.span)
        if step.params["file"]:
            self._write_text(step.params["file"], "\n".join(lines) + "\n", "spectrum")

    def do_export(self, step, interp):
        self._need_rays(step, "EXPORT")
        key = step.params["object"]
        obj = self.scene.objects.get(key)
        if obj is None:
            raise RuntimeFailure(step.span, f"object {key} was not part of the last TRACE (CONSIDER)")
        unit, f = self._lu()
        if obj.name in self.result.images:
            img, img2 = self.result.images[obj.name]
            d = self.result.packed.detector_names.index(obj.name)
            x0, x1, y0, y1 = self.result.packed.d_ext[d] / f
            note = ""
            if step.params.get("diffraction"):   # convolved with the last PSF's kernel (irtlang/optics/psf_step.py)
                from .optics.psf_step import diffraction_image
                img, img2, kept = diffraction_image(self, step, obj.name, img, img2, (x1 - x0) * f / img.shape[2])
                note = f", convolved with the diffraction kernel ({kept:.4f} of its energy)"
            filters = (self.result.packed.d_filters[d] if getattr(self.result.packed, "d_filters", None)
                       else None)
            what = "lines"
            bands = None
            if filters is not None:
                what = "filters"
                lam = np.asarray(self.result.packed.lines_nm, float)
                T = np.asarray(filters[1], float)   # (lines, filters)
                centre = (T * lam[:, None]).sum(0) / np.where(T.sum(0) > 0, T.sum(0), 1.0)
                bands = (list(filters[0]), list(centre))
                if step.params.get("filter") is not None:
                    k = step.params["filter"]
                    fname = step.params.get("filter_name")
                    if fname is not None:      # by name: a TRACE CAMERA ... FILTER image holds one of the filters
                        upper = [n.upper() for n in filters[0]]
                        if fname.upper() not in upper:
                            raise RuntimeFailure(step.span, f"EXPORT {obj.name} FILTER {fname}: the last trace formed "
                                                 f"only the image of {', '.join(filters[0])}")
                        k = upper.index(fname.upper())
                    img, img2 = img[k:k + 1], img2[k:k + 1]
                    what = f"filter {filters[0][k]}"
                    bands = ([filters[0][k]], [centre[k]])
                    sel = slice(k, k + 1)
            if step.params.get("sum"):
                if getattr(self.result, "camera", None):
                    raise RuntimeFailure(step.span, f"EXPORT {obj.name} SUM: a camera-side image's lines share their "
                                         "rays, so their standard errors do not add; its FILTERS images are the bands")
                if filters is not None:
                    raise RuntimeFailure(step.span, f"EXPORT {obj.name} SUM: its planes are the bands of its FILTERS, "
                                         "not lines (EXPORT ... FILTER f writes one)")
                img, img2, bands = self._line_sum(img, img2)
                what = "band (its lines summed)"
            if step.params.get("stokes"):
                self._export_stokes(step, obj, d, sel if filters is not None and step.params.get("filter") is not None
                                    else slice(None), (x0, x1, y0, y1), filters is None, bands, interp)
                self.out(f"EXPORT {obj.name} STOKES: {img.shape[2]}x{img.shape[1]} pixels x {img.shape[0]} {what}, "
                         f"I, Q, U, V, DOLP, AOLP -> {step.params['file']}")
                return
            self._write_image(step.params["file"], img, "image", extent=(x0, x1, y0, y1), sum2=img2,
                              per_line=filters is None and bands is None, name=obj.name, bands=bands, interp=interp,
                              kind_label="image_diffraction" if step.params.get("diffraction") else "image",
                              log=bool(step.params.get("log")))
            self.out(f"EXPORT {obj.name}: {img.shape[2]}x{img.shape[1]} pixels x {img.shape[0]} {what}, "
                     f"{img.sum():.6g} W{note} -> {step.params['file']}")
            return
        if step.params.get("diffraction"):
            raise RuntimeFailure(step.span, f"EXPORT {obj.name} DIFFRACTION needs an object with a DETECTOR")
        if step.params.get("stokes"):
            raise RuntimeFailure(step.span, f"EXPORT {obj.name} STOKES needs an object with a DETECTOR (its pixels "
                                 "tally Q, U and V)")
        # no DETECTOR: the WINDOW / PIXELS grid of the selected rays that ended on the object
        m = self._selected(step, "EXPORT", obj_filter=key)
        r = self.result.records
        vec = r["position"][m]
        if len(vec) == 0:
            raise RuntimeFailure(step.span, f"EXPORT {obj.name}: no selected rays ended on it")
        ax, (a0, a1), (b0, b1) = self._window(vec)
        nx, ny = self.pixels
        L = len(self.result.packed.lines_nm)
        img = np.zeros((L, ny, nx))
        img2 = np.zeros((L, ny, nx))
        for k in range(L):
            mk = r["line"][m] == k
            w = r["flux"][m][mk]
            img[k] = np.histogram2d(vec[mk, ax[1]], vec[mk, ax[0]], bins=(ny, nx), range=((b0, b1), (a0, a1)), weights=w)[0]
            img2[k] = np.histogram2d(vec[mk, ax[1]], vec[mk, ax[0]], bins=(ny, nx), range=((b0, b1), (a0, a1)), weights=w * w)[0]
        bands, what = None, f"{L} lines"
        if step.params.get("sum"):
            img, img2, bands = self._line_sum(img, img2)
            what = "1 band (its lines summed)"
        self._write_image(step.params["file"], img, "image", extent=(a0 / f, a1 / f, b0 / f, b1 / f), sum2=img2,
                          per_line=bands is None, name=obj.name, bands=bands, kind_label="window",
                          log=bool(step.params.get("log")))
        self.out(f"EXPORT {obj.name}: WINDOW grid {nx}x{ny} x {what}, {img.sum():.6g} W -> {step.params['file']}")

    def _line_sum(self, img, img2):
        """EXPORT ... SUM: a forward trace's image (L, ny, nx) summed over its lines, with the band's label (the
        lines' range) and its flux-weighted wavelength.  Each source ray carries one line, so a ray's contribution
        to the sum is its contribution to its line, and the per-ray squared sums add too."""
        lam = np.asarray(self.result.packed.lines_nm, float)
        w = img.sum(axis=(1, 2))
        mean = float((w * lam).sum() / w.sum()) if w.sum() > 0 else float(lam.mean())
        name = (f"{lam[0]:g} nm" if len(lam) == 1 else f"sum of {len(lam)} lines {lam.min():g}-{lam.max():g} nm")
        return (img.sum(axis=0, keepdims=True), None if img2 is None else img2.sum(axis=0, keepdims=True),
                ([name], [mean]))

    def do_pst(self, step, interp):
        from .optics.pst_step import run_pst   # point source transmittance (irtlang/optics/pst_step.py)
        run_pst(self, step, interp)

    def do_psf(self, step, interp):
        from .optics.psf_step import run_psf   # the diffraction PSF (irtlang/optics/diffraction.py)
        run_psf(self, step, interp)

    def do_save_rays(self, step, interp):
        from .io.rayfile import write_rays_v1

        at = step.params["at"]
        m = self._selected(step, "SAVE RAYS", obj_filter=at)
        r = self.result.records
        unit, f = self._lu()
        dets = {}
        for name, (img, img2) in self.result.images.items():
            d = self.result.packed.detector_names.index(name)
            x0, x1, y0, y1 = self.result.packed.d_ext[d] / f
            dets[name] = {"sum": img, "sum2": img2, "x_range": (x0, x1), "y_range": (y0, y1),
                          "pixel_size": ((x1 - x0) / img.shape[2], (y1 - y0) / img.shape[1])}
        hist = r["history"][m]
        if hist.size:   # object indices, and the event at each (docs/rayfile.md: event_kinds)
            kinds = np.where(hist >= 0, hist % 8, np.where(hist == -2, 5, 0)).astype(np.int8)
            hist = np.where(hist >= 0, hist // 8, -1).astype(np.int32)
        else:
            hist, kinds = np.full((int(m.sum()), 1), -1, np.int32), None
        start = r.get("start")
        extra = {"event_kinds": kinds, "start": start[m] / f if start is not None else None}
        if hasattr(self.result.packed, "s_obj"):   # each object's frame (its first surface): origin, x, y, normal
            from .optics.spots import detector_frame

            frames = []
            for o in range(len(self.result.packed.object_names)):
                fr = detector_frame(self.result.packed, o)
                frames.append(np.array([fr[0] / f, fr[1], fr[2], fr[3]]) if fr is not None else np.full((4, 3), np.nan))
            extra["object_frames"] = np.array(frames).reshape(-1, 4, 3)
        if getattr(self.result, "ledger", None) is not None:
            extra["ledger"] = {"rows": list(self.result.rows), "values": self.result.ledger,
                               "sum_sq": self.result.ledger_sq}
        path = self.folder.output(step.params["file"])
        write_rays_v1(path, wavelengths_nm=self.result.packed.lines_nm, objects=self.result.packed.object_names,
                      position=r["position"][m] / f, direction=r["direction"][m], flux=r["flux"][m],
                      line=r["line"][m], source=r["source"][m], object=r["object"][m], events=r["events"][m],
                      flags=r["flags"][m], history=hist, detectors=dets, length_unit=unit, seed=self.result.seed,
                      script_sha256=self.folder.info["script_sha256"], data_tier=self.folder.info["data_tier"],
                      rays_traced=self.result.n_traced, **extra)
        self.folder.record(path, "rays")
        self._saved_from[str(path.resolve())] = (self.result, self.scene)   # LOAD RAYS of it keeps the ledger
        self.out(f"SAVE RAYS: {int(m.sum()):,} rays -> {step.params['file']}")

    def do_load_rays(self, step, interp):
        from .core.checks import AnalysisError
        from .io.rayfile import read_rays

        name = step.params["file"]
        if step.params.get("in_run_folder"):   # written by an earlier SAVE RAYS of this run
            name = str(self.folder.output(name, create=False))
        try:
            rf = read_rays(name)
        except (AnalysisError, OSError) as e:
            raise RuntimeFailure(step.span, f"LOAD RAYS: {e}") from None
        self.result = _LoadedResult(rf, step.scene)
        self.scene = step.scene
        src = self._saved_from.get(str(Path(name).resolve())) if step.params.get("in_run_folder") else None
        if src is not None and rf.ledger is None and getattr(src[0], "ledger", None) is not None:
            # a file this run saved without a ledger: its flux ledger is the one of the TRACE that wrote it
            # (STATS LEDGER, SPECTRUM OF after the LOAD, as LANGUAGE.md's example does); files SAVE RAYS writes
            # now carry their ledger themselves
            res, self.scene = src
            self.result.ledger, self.result.ledger_sq = res.ledger, res.ledger_sq
            self.result.n_traced = res.n_traced
            self.result.packed.row_names = list(res.packed.row_names)
            self.result.packed.n_rows, self.result.packed.object_names = res.packed.n_rows, res.packed.object_names
        missing = [what for what, ok in (("the events at each interaction (STATS PATHS shows '?')", rf.event_kinds),
                                         ("the start points (standard errors take every ray as independent)",
                                          rf.start), ("the energy ledger (STATS LEDGER)", rf.ledger))
                   if ok is None]
        self.out(f"LOAD RAYS: {rf.n_rays:,} rays on {len(rf.objects)} objects ({', '.join(rf.objects)}) from "
                 f"{Path(step.params['file']).name}" + (f"; the file does not hold {'; '.join(missing)}"
                                                         if missing and rf.n_rays else ""))

    def do_analyze(self, step, interp):
        """Run an analysis subcommand; file names resolve in the run folder first, then the script's folder."""
        import contextlib
        import io as _io

        from .core.hooks import analysis_provider
        from .lang.commands import ANALYSIS_OUTPUT_OPTIONS, analysis_parser

        argv, written = [], []
        raw = list(step.params["argv"])
        for k, a in enumerate(raw):
            if not a.startswith("\0path:"):
                argv.append(a)
                continue
            name = a[len("\0path:"):]
            if k > 0 and raw[k - 1] in ANALYSIS_OUTPUT_OPTIONS:
                out = self.folder.output(name)
                written.append(out)
                argv.append(str(out))
                continue
            out = self.folder.root / name      # an input: the run folder first, then as a script's input
            if out.exists():
                argv.append(str(out))
            else:
                from .lang.interp import find_input

                p = find_input(name, Path(step.params["base"]))
                argv.append(str(p) if p is not None else name)
        args = analysis_parser().parse_args(argv)
        buf, err = _io.StringIO(), _io.StringIO()
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
            code = analysis_provider().run(args)
        if code != 0:
            raise RuntimeFailure(step.span, f"ANALYZE {argv[0].upper()}: {err.getvalue().strip().removeprefix('error: ')}")
        self.out(f"ANALYZE {argv[0].upper()}:\n" + buf.getvalue().rstrip())
        for w in written:
            if w.exists():
                self.folder.record(w, "analysis")

    def do_append(self, step, interp):
        """APPEND: one row more in a CSV table of the run (rewritten whole, atomically, at every row)."""
        tabs = self.__dict__.setdefault("tables", {})
        f, header, values = step.params["file"], tuple(step.params["header"]), tuple(step.params["values"])
        if f in tabs and tabs[f][0] != header:
            raise RuntimeFailure(step.span, f"APPEND '{f}': the columns ({', '.join(header)}) differ from the "
                                 f"table's ({', '.join(tabs[f][0])})")
        hdr, rows = tabs.setdefault(f, (header, []))
        rows.append(values)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(hdr)
        w.writerows(rows)
        self._write_text(f, buf.getvalue(), "table")

    # ------------------------------------------------------------------ files
    def _write_text(self, rel, text, kind):
        from .io.atomic import write_text

        p = self.folder.output(rel)
        write_text(p, text)
        self.folder.record(p, kind)

    def _export_stokes(self, step, obj, d, sel, extent, per_line, bands, interp):
        """EXPORT ... STOKES: name_I, name_Q, name_U, name_V (each with its standard error) and the degree and
        angle of linear polarization, name_DOLP (0..1) and name_AOLP (degrees from the detector's local x toward
        e2 = d x e1, in (-90, 90]; docs/tracer.md, "Polarization")."""
        st = getattr(self.result, "stokes", None)
        if getattr(self.result, "camera", None) is not None and not st:
            raise RuntimeFailure(step.span, f"EXPORT {obj.name} STOKES after TRACE CAMERA without STOKES: that trace "
                                 "gives the polarization-correct I image only; Q, U and V images need TRACE CAMERA "
                                 "... STOKES (or a forward TRACE) with POLARIZATION")
        if not st or obj.name not in st:
            raise RuntimeFailure(step.span, f"EXPORT {obj.name} STOKES needs a polarized trace: put "
                                 "POLARIZATION before TRACE")
        s1, s2 = st[obj.name]
        s1, s2 = s1[:, sel], s2[:, sel]
        rel = step.params["file"]
        stem, dot, ext = rel.rpartition(".")
        labels = {"I": "Stokes I per pixel (W)", "Q": "Stokes Q per pixel (W)", "U": "Stokes U per pixel (W)",
                  "V": "Stokes V per pixel (W)"}
        for k, comp in enumerate("IQUV"):
            self._write_image(f"{stem}_{comp}.{ext}", s1[k], "image", extent=extent, sum2=s2[k], per_line=per_line,
                              name=f"{obj.name}_{comp}", bands=bands, interp=interp, kind_label=f"stokes_{comp}",
                              quantity=None if k == 0 else (labels[comp], "W", True))
        if ext.lower() == "png":      # one picture: the degree and angle of the light summed over the planes
            s1 = s1.sum(axis=1, keepdims=True)
        i = s1[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            dolp = np.where(i > 0, np.hypot(s1[1], s1[2]) / np.where(i > 0, i, 1.0), 0.0)
        aolp = np.where(i > 0, np.degrees(0.5 * np.arctan2(s1[2], s1[1])), 0.0)
        for comp, a, q in (("DOLP", dolp, ("degree of linear polarization", "", False)),
                           ("AOLP", aolp, ("angle of linear polarization (deg from local x)", "deg", False))):
            self._write_image(f"{stem}_{comp}.{ext}", a, "image", extent=extent, per_line=per_line and a.shape[0] > 1,
                              name=f"{obj.name}_{comp}", bands=bands if a.shape[0] > 1 else None, interp=interp,
                              kind_label=comp.lower(), quantity=q)

    def _write_image(self, rel, img, kind, extent, sum2=None, per_line=True, *, name=None, bands=None,
                     coord_unit=None, interp=None, kind_label=None, quantity=None, log=False):
        """An image file, and the image for results.nc.  extent in the script's length unit (coord_unit None), or
        in coord_unit ("1": direction cosines); bands: (filter names, centre wavelengths nm) of the k images;
        log: a .png on a logarithmic colour scale (EXPORT ... LOG)."""
        from .io.images import write_image

        p = self.folder.output(rel)
        unit, f = self._lu()
        lines = (self.result.packed.lines_nm if per_line and img.shape[0] == len(self.result.packed.lines_nm)
                 else None)
        mm = np.asarray(extent, float) * (f / 1e-3) if coord_unit is None else np.asarray(extent, float)
        focal = focal_length_m(interp) if coord_unit is None else None
        # a camera-side image's sum2 is already its per-pixel variance (TRACE CAMERA: n rays per pixel, not the
        # whole trace's); every other image's standard error is the tracer's, from the trace's ray count
        n_tr = None if getattr(self.result, "camera", None) else self.result.n_traced
        se = (None if sum2 is None else np.sqrt(np.asarray(sum2, np.float64)) if not n_tr
              else np.asarray(standard_error(img, np.asarray(sum2, np.float64), int(n_tr)), np.float64))
        prov = {k: self.folder.info.get(k) for k in ("irtlang_version", "script", "script_sha256", "seed",
                                                      "data_tier", "rays_traced")}
        epoch = interp.lookup("EPOCH_UTC") if interp is not None else None
        if isinstance(epoch, str):
            prov["epoch_utc"] = epoch
        for q in write_image(p, img, sum2=sum2, extent=tuple(mm) if coord_unit is None else extent,
                             wavelengths_nm=lines, length_unit="mm" if coord_unit is None else "direction cosine",
                             bands=bands[0] if bands else None, focal_length_m=focal, provenance=prov,
                             object_name=name or kind, n_traced=n_tr, psf=kind == "psf", quantity=quantity,
                             log=log):
            self.folder.record(q, kind)
        if self.collector is not None:
            self.collector.add_image(name=name or kind, kind=kind_label or kind, img=img, se=se, extent_mm=tuple(mm),
                                     coord_unit=coord_unit or "mm", lines_nm=lines, bands=bands[0] if bands else None,
                                     band_nm=bands[1] if bands else None, focal_m=focal, file=str(rel))


def focal_length_m(interp) -> float | None:
    """The focal length behind a detector's field angles: the last PSF's PSF_EFL, else the script's variable
    FOCAL_LENGTH (a length); None when neither is known (docs/python_api.md)."""
    if interp is None:
        return None
    for name in ("PSF_EFL", "FOCAL_LENGTH"):
        v = interp.lookup(name)
        if isinstance(v, Quantity) and v.dim == LENGTH and v.value > 0 and math.isfinite(v.value):
            return float(v.value)
    return None


def data_tier(scene, before: str | None = None) -> str:
    """Which Earth data the scene's MAPs come from: 'default' (MAP ... DEFAULT: the built-in tier), the tier
    named by a map file's JSON sidecar ('real' for irtlang.earth.products output), 'user' for other map
    files, 'none' without maps; several join with '+', and a run keeps every tier its traces used."""
    import json

    tiers = set() if before in (None, "none") else set(before.split("+"))
    for m in scene.maps.values():
        if getattr(m, "path", None) is None:
            if getattr(m, "dataset", None) is not None:
                tiers.add("default")
            continue
        tier = "user"
        p = Path(m.path)
        for side in (p.with_name(p.name + ".json"), p.with_suffix(".json")):
            try:
                tier = str(json.loads(side.read_text()).get("tier", tier))
                break
            except (OSError, ValueError, AttributeError):
                continue
        tiers.add(tier)
    return "+".join(sorted(tiers)) or "none"


class _LoadedResult:
    """Ray records read by LOAD RAYS, shaped like a TraceResult for the analysis commands."""

    def __init__(self, rf, scene):
        f = UNITS[rf.attrs.get("length_unit", "mm").lower()][0]
        n = rf.n_rays
        hist = rf.history if rf.history is not None else np.full((n, 1), -1, np.int32)
        kinds = rf.event_kinds
        if kinds is not None:   # object * 8 + event, -2 for a volume event (the tracer's encoding)
            hist = np.where(hist >= 0, hist * 8 + kinds, np.where(kinds == 5, -2, -1))
        else:
            hist = np.where(hist >= 0, hist * 8, -1)
        self.event_kinds_known = kinds is not None
        self.records = dict(position=rf.position * f if n else np.zeros((0, 3)),
                            direction=rf.direction if n else np.zeros((0, 3)),
                            flux=rf.flux if n else np.zeros(0), line=rf.line if n else np.zeros(0, np.int32),
                            source=rf.source if n else np.zeros(0, np.int32),
                            object=rf.object if n else np.zeros(0, np.int32),
                            events=rf.events if n else np.zeros(0, np.int32),
                            flags=rf.flags if n else np.zeros(0, np.uint32), history=hist,
                            start=rf.start * f if rf.start is not None else None)
        self.n_traced = int(rf.attrs.get("rays_traced", rf.n_rays))
        self.seed = int(rf.attrs.get("seed", 0))
        self.images = {n: (d.sum, d.sum2) for n, d in rf.detectors.items()}
        self.object_keys = [o.upper() for o in rf.objects]
        led = rf.ledger
        self.packed = SimpleNamespace(
            lines_nm=rf.wavelengths_nm, object_names=list(rf.objects), detector_names=list(rf.detectors),
            d_ext=(np.array([[*d.x_range, *d.y_range] for d in rf.detectors.values()]) * f if rf.detectors
                   else np.zeros((0, 4))),
            row_names=led["rows"] if led else [], n_rows=len(led["rows"]) if led else 0)
        self.ledger = led["values"] if led else None
        self.ledger_sq = led["sum_sq"] if led else None

    @property
    def rows(self) -> list:
        return self.packed.row_names


def _eval_pred(pred, r, names, lines_nm) -> np.ndarray:
    op = pred[0]
    if op == "and":
        return _eval_pred(pred[1], r, names, lines_nm) & _eval_pred(pred[2], r, names, lines_nm)
    if op == "or":
        return _eval_pred(pred[1], r, names, lines_nm) | _eval_pred(pred[2], r, names, lines_nm)
    if op == "not":
        return ~_eval_pred(pred[1], r, names, lines_nm)
    h = r["history"]
    hobj = np.where(h >= 0, h // 8, -1)
    if op == "WAVELENGTH":
        lo, hi = pred[1]
        lam = np.asarray(lines_nm)[r["line"]]
        return (lam >= lo) & (lam <= hi)
    idx = [names.index(k) for k in pred[1]]
    if op == "HIT":
        return np.isin(hobj, idx).any(axis=1) | np.isin(r["object"], idx)
    if op == "LAST":
        return np.isin(r["object"], idx)
    if op == "SCATTERED":
        return (np.isin(hobj, idx) & ((h % 8) == 3)).any(axis=1)
    if op == "PATH":
        want = np.full(h.shape[1], -1)
        n = min(len(idx), h.shape[1])
        want[:n] = idx[:n]
        return np.all(hobj == want, axis=1)
    raise ValueError(op)  # pragma: no cover


def _pred_objects(pred) -> list:
    if pred[0] in ("and", "or"):
        return _pred_objects(pred[1]) + _pred_objects(pred[2])
    if pred[0] == "not":
        return _pred_objects(pred[1])
    return [] if pred[0] == "WAVELENGTH" else list(pred[1])


def _se_rows(res):
    """Standard error of each ledger row's incident flux (objects only; 0 for the other rows)."""
    nobj = len(res.packed.object_names)
    return [total_standard_error(res, res.ledger[i, 0], res.ledger_sq[i]) if i < nobj else 0.0
            for i in range(res.packed.n_rows)]
