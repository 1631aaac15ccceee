"""Kernel specialization: one generated module per scene feature set.

The trace kernel template (irtlang/kernels/trace_kernel.py) has ``F_*`` flags.  For a feature set we write a
copy with the flags set into ``$NUMBA_CACHE_DIR/irt_kernels/`` (the file name carries the feature key and a
hash of the kernels' sources, so a changed kernel never meets a stale cache) and import it; Numba compiles
the flags as constants and caches the result with ``cache=True``, so the second run of a scene type starts
warm.  A scene with only mirrors therefore compiles no refraction, mesh, media or record code.
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import importlib.util
import os
import re
import sys
from pathlib import Path

from .pack import KIND_FIELDS, Features

_FLAGS = {"conic": "F_CONIC", "quadric": "F_QUADRIC", "mesh": "F_MESH", "refract": "F_REFRACT",
          "absorb_media": "F_ABSORB_MEDIA", "precise": "F_PRECISE", "records": "F_RECORDS", "history": "F_HISTORY",
          "scatter": "F_SCATTER", "maps": "F_MAPS", "volume": "F_VOLUME", "importance": "F_IMPORTANCE",
          "shells": "F_SHELLS", "polar": "F_POLAR",
          "camera": "F_CAMERA", "hero": "F_HERO"}
_FUNCS = ("sample", "eval", "albedo", "direct", "mueller", "pdf", "delta", "parts")
_SIGS = {"sample": "P, k, wix, wiy, wiz, nx, ny, nz, u0, u1, u2",
         "eval": "P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz", "albedo": "P, k, cos_i", "direct": "P, k, cos_i",
         "mueller": "P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz, q, u, v, ex, ey, ez",
         "pdf": "P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz", "delta": "P, k, cos_i", "parts": "P, k, cos_i"}
_NAMES = {"sample": "sample", "eval": "eval", "albedo": "albedo", "direct": "direct_transmission",
          "mueller": "mueller", "pdf": "pdf", "delta": "delta_prob", "parts": "albedo_parts"}
# optional in a plugin: a Mueller matrix (default: depolarizing), the probability of a sampled delta (the
# unscattered beam of a slab; default: none) and albedo_parts (albedo, direct_transmission and delta_prob in one
# call; default: the three called apart, _COMPOSED_PARTS)
_DEFAULTS = {"mueller": ("irtlang.plugins.bsdfs._common", "depolarize"),
             "delta": ("irtlang.plugins.bsdfs._common", "no_delta")}


_COMPOSED_PARTS = """

@numba.njit(cache=True)
def _parts_{j}(P, k, cos_i):
    a_, b_ = _albedo_{j}(P, k, cos_i)
    return a_, b_, _direct_{j}(P, k, cos_i), _delta_{j}(P, k, cos_i)"""


def bsdf_dispatch(kinds) -> str:
    """Source of the BSDF dispatch functions for the scene's model kinds (registry order)."""
    from ..plugins.bsdfs import REGISTRY

    kinds = list(kinds) or ["LAMBERTIAN"]
    lines = []
    composed = []
    for j, kd in enumerate(kinds):
        mod = REGISTRY[kd].__name__
        for f in _FUNCS:
            if f == "parts" and not hasattr(REGISTRY[kd], _NAMES[f]):
                composed.append(_COMPOSED_PARTS.format(j=j))
            elif f in _DEFAULTS and not hasattr(REGISTRY[kd], _NAMES[f]):
                lines.append(f"from {_DEFAULTS[f][0]} import {_DEFAULTS[f][1]} as _{f}_{j}")
            else:
                lines.append(f"from {mod} import {_NAMES[f]} as _{f}_{j}")
    lines += composed
    for f in _FUNCS:
        lines += ["", "", "@numba.njit(cache=True)", f"def _bsdf_{f}(kind, {_SIGS[f]}):"]
        for j in range(len(kinds)):
            cond = "if" if j == 0 else "elif"
            if j == len(kinds) - 1:
                lines.append(f"    return _{f}_{j}({_SIGS[f]})")
            else:
                lines += [f"    {cond} kind == {j}:", f"        return _{f}_{j}({_SIGS[f]})"]
    return "\n".join(lines) + "\n"


_SURFACE_FUNCS = {"hit": ("f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving", "np.inf, np.inf, -1"),
                  "normal": ("f, si, S, j, x, y, z, face", "0.0, 0.0, 1.0")}


def surface_kinds(features: Features) -> list:
    """The surface kinds a kernel for `features` dispatches over: those whose FEATURE flag is on (registry
    order; a kind's code is its registry index)."""
    from ..plugins.surfaces import REGISTRY

    return [k for k, m in REGISTRY.items() if m.FEATURE is None or getattr(features, m.FEATURE)]


def surface_dispatch(features: Features) -> str:
    """Source of the kernel's surface dispatch (``_surface_hit``, ``_surface_normal``): one branch per kind in
    ``surface_kinds``, on its code; an unknown code misses (no hit) and gets the local +z normal."""
    from ..plugins.surfaces import CODES, REGISTRY

    kinds = surface_kinds(features)
    lines = []
    for kd in kinds:
        for f in _SURFACE_FUNCS:
            lines.append(f"from {REGISTRY[kd].__name__} import {f} as _{f}_{CODES[kd]}")
    for f, (sig, miss) in _SURFACE_FUNCS.items():
        lines += ["", "", '@numba.njit(cache=True, inline="always")', f"def _surface_{f}(k, {sig}):"]
        for kd in kinds:
            lines += [f"    if k == {CODES[kd]}:", f"        return _{f}_{CODES[kd]}({sig})"]
        lines.append(f"    return {miss}")
    return "\n".join(lines) + "\n"


def source_dispatch(kinds=()) -> str:
    """Source of the kernel's source dispatch (``_source_emit``, ``_source_direction``, ``_source_lambert``,
    ``_source_toward``) over the source kinds `kinds` (``Features.source_kinds``; all of them when empty) of the
    registry (irtlang/plugins/sources/__init__.py).  A code outside them gets the fallbacks below (never
    reached: a kernel is compiled for its scene's kinds)."""
    from ..plugins.sources import EMITTER_CODES, REGISTRY

    use = set(kinds) if kinds else set(REGISTRY)
    lines = ["from irtlang.plugins.sources._common import lambert as _lambert_default",
             "from irtlang.plugins.sources._common import toward as _toward_default"]
    emit = [(EMITTER_CODES[k], REGISTRY[k]) for k in EMITTER_CODES if k in use]
    dirs = [m for k, m in REGISTRY.items() if hasattr(m, "DIRECTION_CODES") and k in use]
    for code, m in emit:
        for f in ("emit", "lambert", "toward"):
            if hasattr(m, f):
                lines.append(f"from {m.__name__} import {f} as _{f}_{code}")
    for q, m in enumerate(dirs):
        lines.append(f"from {m.__name__} import direction as _direction_{q}")
    head = '@numba.njit(cache=True, inline="always")'
    lines += ["", "", head, "def _source_emit(kind, SRC, s, q, u0, u1):"]
    for code, m in emit:
        lines += [f"    if kind == {code}:", f"        return _emit_{code}(SRC, s, q, u0, u1)"]
    lines.append("    return 0.0, 0.0, 0.0, 0.0, 0.0, 1.0")
    lines += ["", "", head, "def _source_direction(dk, SRC, s, x, y, z):"]
    for q, m in enumerate(dirs):
        cond = " or ".join(f"dk == {c}" for c in m.DIRECTION_CODES)
        lines += [f"    if {cond}:", f"        return _direction_{q}(SRC, s, x, y, z)"]
    lines.append("    return 0.0, 0.0, 1.0")
    for f, sig in (("lambert", "SRC, s, u2, u3"), ("toward", "SRC, s, c, omega")):
        lines += ["", "", head, f"def _source_{f}(kind, {sig}):"]
        for code, m in emit:
            if hasattr(m, f):
                lines += [f"    if kind == {code}:", f"        return _{f}_{code}({sig})"]
        lines.append(f"    return _{f}_default({sig})")
    return "\n".join(lines) + "\n"


_loaded: dict[str, object] = {}


def _kernel_dir() -> Path:
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "irtlang", "numba")
    d = Path(base) / "irt_kernels"
    d.mkdir(parents=True, exist_ok=True)
    return d


_NOT_IN_THE_KERNEL = ("reduce.py", "spline.py")      # modules of kernels/ that trace_kernel never imports


def kernel_sources() -> list:
    """Every source a generated kernel depends on: kernels/ and the scatter-model, surface and source plugins;
    not kernels/reduce.py and kernels/spline.py, which the trace kernel does not use (editing one recompiles only
    itself)."""
    root = Path(__file__).resolve().parents[1]
    kernels = [p for p in sorted((root / "kernels").glob("*.py")) if p.name not in _NOT_IN_THE_KERNEL]
    return kernels + [p for sub in ("bsdfs", "surfaces", "sources") for p in sorted((root / "plugins" / sub).glob("*.py"))]


def _sources_hash() -> str:
    """Hash of kernel_sources(): a generated kernel's file name carries it, so an edit recompiles the kernels."""
    h = hashlib.sha256()
    for p in kernel_sources():
        h.update(p.read_bytes())
    return h.hexdigest()[:12]


def kernel_cached(mod) -> bool:
    """Whether Numba's cache holds a compiled ``trace_batch`` of the kernel module `mod` (its index, read as
    Numba reads it: one left by an older source counts as empty).  True where that cannot be told."""
    try:
        return bool(mod.trace_batch._cache._cache_file._load_index())
    except Exception:       # Numba's internals changed: nothing is compiled ahead (irtlang.ahead)
        return True


@contextlib.contextmanager
def kernel_lock(mod, wait: bool = True):
    """Held while a process compiles (or loads from the cache) the kernel module `mod`: an exclusive lock on a
    file beside the module's source in the kernel folder.  Two processes that need the same kernel at once
    (a local cluster's workers, the test suite's two workers, two runs started together) would otherwise both
    compile it from an empty cache, minutes each; with the lock the second waits and then loads the first one's
    cached code.  Where the platform has no fcntl, nothing is locked.  Yields True when held; with `wait`
    False a lock another process holds is not waited for, and it yields False (irtlang.ahead)."""
    try:
        import fcntl
    except ImportError:        # not POSIX: no lock (each process compiles, as before)
        yield wait
        return
    path = Path(mod.__file__).with_suffix(".lock")
    with open(path, "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            yield False
            return
        try:
            yield True
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def all_features() -> Features:
    """Every feature on and every scatter model in the dispatch: one kernel for any scene."""
    from ..plugins.bsdfs import REGISTRY

    # every flag but polarization (it changes results: the scene's own), surface kinds without a template flag too
    from ..plugins.sources import REGISTRY as SOURCES

    f = Features(**{k: True for k in Features.__dataclass_fields__ if k not in ("polar",) + KIND_FIELDS})
    f.bsdf_kinds = tuple(REGISTRY)
    f.source_kinds = tuple(SOURCES)
    return f


def kernel_module(features: Features):
    """The trace-kernel module specialized for `features` (generated and imported once per process).

    With the environment variable ``IRT_KERNEL_FEATURES=all`` every scene uses one kernel with all features
    (one compilation for a whole test suite; the results agree with the specialized kernels to rounding,
    which a test checks)."""
    if os.environ.get("IRT_KERNEL_FEATURES", "").lower() == "all":
        features = dataclasses.replace(all_features(), polar=features.polar)
    key = features.key()
    if key in _loaded:
        return _loaded[key]
    template = (Path(__file__).resolve().parents[1] / "kernels" / "trace_kernel.py").read_text()
    text = template
    for field, flag in _FLAGS.items():
        text, n = re.subn(rf"^{flag} = (True|False)$", f"{flag} = {bool(getattr(features, field))}", text, flags=re.M)
        if n != 1:      # the template's line must read exactly "F_X = True" (no comment after it)
            raise RuntimeError(f"kernel template: no line '{flag} = True|False' to specialize")
    a = text.index("# ---- source dispatch")
    b = text.index("# ---- end of source dispatch ----")
    text = text[:a] + "# ---- source dispatch (generated) ----\n" + source_dispatch(features.source_kinds) + text[b:]
    a = text.index("# ---- surface dispatch")
    b = text.index("# ---- end of surface dispatch ----")
    text = text[:a] + "# ---- surface dispatch (generated) ----\n" + surface_dispatch(features) + text[b:]
    a = text.index("# ---- bsdf dispatch")
    b = text.index("# ---- end of bsdf dispatch ----")
    text = text[:a] + "# ---- bsdf dispatch (generated) ----\n" + bsdf_dispatch(features.bsdf_kinds) + text[b:]
    # the copy lives outside the package: make its relative imports absolute
    text = text.replace("from .", "from irtlang.kernels.")
    name = f"irt_trace_{key}_{_sources_hash()}"
    path = _kernel_dir() / f"{name}.py"
    if not path.exists() or path.read_text() != text:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    mod.BSDF_KINDS = tuple(features.bsdf_kinds)   # the order of its BSDF dispatch
    mod.SURFACE_KINDS = tuple(surface_kinds(features))
    _loaded[key] = mod
    return mod
