"""Moved to :mod:`irtlang.core.units` (a stage-independent module, docs/architecture.md).

This name stays so that older imports keep working; new code imports ``irtlang.core.units``.
"""
from ..core.units import *  # noqa: F401,F403
