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

__all__ = ["__version__", "run", "check", "RunResult", "RunError", "IrtError"]


def __getattr__(name):
    if name in ("run", "check", "RunResult", "RunError", "IrtError"):
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'irtlang' has no attribute {name!r}")
