"""irtlang: end-to-end non-sequential optical simulation of space instruments.

Pipeline (one direction, one module per stage)::

    text -> Lark tree (irtlang.lang.parser) -> AST with spans (irtlang.lang.ast)
         -> interpreter (irtlang.lang.interp) -> scene model (irtlang.model)
         -> packed arrays (irtlang.compile) -> Numba kernels (irtlang.kernels)
         -> ray records and detectors (irtlang.io) -> analysis (top-level package ``analysis``)

The Python API (docs/python_api.md): ``irtlang.run(script_or_path, set={...}, seed=None, out=None)`` returns a
``RunResult`` (``.dataset``, ``.files``, ``.manifest``, ``.variables``); ``irtlang.check(...)`` returns the
diagnostics.  They are imported on first use, so ``import irtlang`` stays cheap.
"""
from ._version import __version__


def _setup_numba_cache() -> None:
    """One Numba cache for every way irtlang runs: ``$NUMBA_CACHE_DIR`` if set, else
    ``$XDG_CACHE_HOME/irtlang/numba`` (default ``~/.cache/irtlang/numba``), the folder ``irt`` always used.

    Without it, Numba keeps a module's compiled code in the ``__pycache__`` beside the module while no
    NUMBA_CACHE_DIR is set, and in NUMBA_CACHE_DIR once one is: a process that imported irtlang and then ran
    `irt` in-process (``cli.main`` set the variable), or the Python API beside the command line, kept two caches
    of the same kernel, and compiled it twice (the README's test command compiled the all-features kernel
    twice, about 2 min each).  Set at import, before any kernel is decorated; Numba re-reads its configuration
    when it compiles, and here at once if it was imported first."""
    import os
    import sys

    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    os.environ["NUMBA_CACHE_DIR"] = os.path.join(base, "irtlang", "numba")
    if "numba" in sys.modules:
        from numba.core import config

        config.reload_config()


_setup_numba_cache()

__all__ = ["__version__", "run", "check", "RunResult", "RunError", "IrtError"]


def __getattr__(name):
    if name in ("run", "check", "RunResult", "RunError", "IrtError"):
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'irtlang' has no attribute {name!r}")
