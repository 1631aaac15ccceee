"""Compiling a run's later trace kernels ahead, in a second process, while the run compiles its first.

Numba compiles one trace kernel per feature combination (irtlang/compile/specialize.py), a minute or more each
on one core, and a run meets its kernels one after another: the flagship's first run compiled the forward
trace's kernel, traced, and only then compiled the camera-side traces' (71 s and 79 s on 2 cores, one after
the other).  When `irt run` starts compiling a kernel that is not in Numba's cache, it starts this module in a
background process (``irtlang.tracer.TraceContext.compile`` calls the hook ``irtlang.api.execute`` sets): the
process checks the script again (the same ``--set`` values), plans the kernels its TRACE steps will use, and
compiles those that are neither cached nor being compiled (each under ``compile.specialize.kernel_lock``, which
the run then waits on if it gets there first), in the run's order.  The run itself is unchanged: it loads what
the process has compiled, or waits for it, or compiles it as before.

The plan mirrors ``irtlang.engine``: a forward TRACE packs its scene (after CONSIDER) with the records and
history the program needs; a TRACE CAMERA packs its camera scene (``model.camera.camera_scene``, the first
analyzer pass) without them; a GUIDE's pilot runs on its camera trace's kernel.  Steps whose scenes have the same
structure (objects, sources, camera options) are packed once.  Retraces by PST and SPOTS DIAGRAM ... FIELDS
need no plan: they run on the kernel of the TRACE they repeat (``engine.last_features``, pack's floor).  A plan
that misses a kernel costs nothing but the time saved (the run compiles it when it needs it).

``irt warmup FILE`` (``warmup``) runs the same plan in the foreground, in as many processes as asked, and waits
for all of it.  ``IRT_COMPILE_AHEAD=0`` turns the run's helper off (also the reduction's compile ahead,
``irtlang.tracer._reduce_ahead``).
"""
from __future__ import annotations

import sys
from pathlib import Path


def _signature(scene, records: bool, history: bool, cam) -> tuple:
    """What decides a scene's kernel, roughly: its objects (their surfaces' kinds and scatter specs), its
    sources' kinds and parameter names, polarization, the records and history kept, and the camera's options.
    Hourly frames of one scene (another epoch, another Sun position) share it."""
    objs = tuple((k, tuple(getattr(s, "kind", "") for s in getattr(o, "surfaces", ()) or ()),
                  repr(getattr(o, "scatter", None))[:200]) for k, o in scene.objects.items())
    srcs = tuple((getattr(s, "kind", ""), tuple(sorted(getattr(s, "params", {}) or {}))) for s in scene.sources)
    camk = None if cam is None else tuple(sorted((k, repr(v)[:80]) for k, v in cam.items()))
    return objs, srcs, bool(getattr(scene, "polarization", False)), records, history, camk


def plan(steps):
    """The scenes the run's TRACE steps will pack, one per structure, in the run's order: (scene, records,
    history, level)."""
    from .engine import needs_from_steps
    from .model import scene as M
    from .model.camera import camera_scene

    records, history = needs_from_steps(steps)
    consider = None
    seen = set()
    for st in steps:
        if st.kind == "CONSIDER":
            consider = st.params.get("objects")
            continue
        if st.kind != "TRACE" or getattr(st, "scene", None) is None:
            continue
        sc = st.scene
        if consider:
            keep = set(consider)
            sc = M.replace(sc, objects=M.frozen_params({k: v for k, v in sc.objects.items() if k in keep}))
        cam = st.params.get("camera")
        r, h = (records, history) if cam is None else (False, False)
        sig = _signature(sc, r, h, cam)
        if sig in seen:
            continue
        seen.add(sig)
        if cam is not None:
            try:
                sc, _info = camera_scene(sc, cam, st.span, ())
            except Exception:       # the run reports it; nothing to plan
                continue
        yield sc, r, h, st.params.get("level", 10)


def planned_kernels(steps) -> list:
    """The run's distinct kernels, packed, in the run's order: (packed scene, records, history, level, kernel
    module)."""
    from .compile.pack import pack
    from .compile.specialize import kernel_module

    out, keys = [], set()
    for sc, r, h, level in plan(steps):
        try:
            pk = pack(sc, records=r, history=h)
        except Exception:       # the run reports it
            continue
        if pk.features.key() not in keys:
            keys.add(pk.features.key())
            out.append((pk, r, h, level, kernel_module(pk.features)))
    return out


def compile_kernels(kernels, log=None) -> list:
    """Compile each of `kernels` (planned_kernels' list) that is neither cached nor locked by another process
    (each under its kernel_lock, taken without waiting).  Returns the keys compiled here."""
    from .compile.specialize import kernel_cached, kernel_lock
    from .tracer import TraceContext

    done = []
    for pk, r, h, level, mod in kernels:
        if kernel_cached(mod):
            continue
        with kernel_lock(mod, wait=False) as held:
            if not held or kernel_cached(mod):
                continue        # another process compiles it (the run itself, most often), or has
            ctx = TraceContext(pk, seed=0, level=int(level), halt=0.0, records=r, history=h)
            ctx.run_batch(0, 0, _compiled=True)
            done.append(pk.features.key())
            if log:
                log(f"compiled ahead: {pk.features.key()}")
    return done


def compile_planned(script: Path, presets=(), allow_outside: bool = False, log=None, limits=()) -> list:
    """Check `script` (`limits`: --limit's NAME=VALUE strings, over IRT_LIMITS), plan its kernels, compile those
    neither cached nor locked by another process.  Returns the kernel keys it compiled."""
    from .lang.interp import check_file
    from .limits import Limits

    checked = check_file(Path(script), presets, limits=Limits.from_env(limits), allow_outside=allow_outside)
    return compile_kernels(planned_kernels(checked.steps), log)


def warmup(checked, script: Path, presets=(), allow_outside: bool = False, jobs: int = 1, on_plan=None,
           limits=()) -> dict:
    """``irt warmup``: compile every kernel a checked script's run will use, in this process and in `jobs` - 1
    helper processes (each takes the next kernel nobody holds), and wait for all of them.  `on_plan(planned,
    missing, at_once)` is called before the compiles start.  Returns the plan's keys, those cached before, and
    those cached now."""
    from .compile.specialize import kernel_cached, kernel_lock
    from .kernels import reduce as _reduce

    kernels = planned_kernels(checked.steps)
    before = [pk.features.key() for pk, *_r, mod in kernels if kernel_cached(mod)]
    missing = len(kernels) - len(before)
    if on_plan is not None:
        on_plan(len(kernels), missing, max(1, min(jobs, missing)))
    helpers = [start(script, presets, allow_outside, force=True, limits=limits) for _ in range(min(jobs, missing) - 1)]
    compile_kernels(kernels)
    if kernels and not _reduce.cached():
        _reduce.warm()          # and the batches' reduction, which every trace runs after its kernel
    for p in helpers:
        if p is not None:
            p.wait()
    for *_x, mod in kernels:    # a helper of another run may still hold one: wait for it
        if not kernel_cached(mod):
            with kernel_lock(mod):
                pass
    return {"planned": [pk.features.key() for pk, *_ in kernels], "cached_before": before,
            "cached": [pk.features.key() for pk, *_r, mod in kernels if kernel_cached(mod)]}


def start(script: Path, presets=(), allow_outside: bool = False, force: bool = False, limits=()):
    """Start ``compile_planned`` in a background process (returns the Popen, or None where none started;
    `force`: even where IRT_COMPILE_AHEAD=0, as `irt warmup` asks; `limits`: --limit's strings)."""
    from .core.background import start_python

    args = [str(script)] + (["--allow-outside"] if allow_outside else [])
    args += [a for p in presets for a in ("--set", p)] + [a for x in limits for a in ("--limit", x)]
    return start_python("irtlang.ahead", args, force=force)


def main(argv=None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="irtlang.ahead")
    ap.add_argument("script")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--allow-outside", action="store_true")
    ap.add_argument("--limit", action="append", default=[])
    ap.add_argument("--verbose", action="store_true")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        compile_planned(Path(a.script), a.set, a.allow_outside, log=print if a.verbose else None, limits=a.limit)
    except Exception as e:      # a background helper: the run reports the script's problems, not this
        if a.verbose:
            print(f"irtlang.ahead: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    return 0
