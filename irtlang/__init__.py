"""irtlang: end-to-end non-sequential optical simulation of space instruments.

Pipeline (one direction, one module per stage)::

    text -> Lark tree (irtlang.lang.parser) -> AST with spans (irtlang.lang.ast)
         -> interpreter (irtlang.lang.interp) -> scene model (irtlang.model)
         -> packed arrays (irtlang.compile) -> Numba kernels (irtlang.kernels)
         -> ray records and detectors (irtlang.io) -> analysis (top-level package ``analysis``)
"""
from ._version import __version__

__all__ = ["__version__"]
