"""Moved to :mod:`irtlang.core.diagnostics` (a stage-independent module, docs/architecture.md).

This name stays so that older imports keep working; new code imports ``irtlang.core.diagnostics``.
"""
from ..core.diagnostics import *  # noqa: F401,F403
