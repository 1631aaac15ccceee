"""The one late-stage hook: how irtlang reaches the ``analysis`` package without importing it.

The analysis package comes after irtlang in the pipeline (it reads the files irtlang writes and imports irtlang's
file formats), so no irtlang module imports it (docs/architecture.md, tests/unit/test_import_layers.py).  Two
things still run it: the script command ``ANALYZE`` (the interpreter checks its arguments, the engine runs it) and
``irt analyze``.  Both ask this module for the *analysis provider*, an object with

- ``build_parser(subparsers)``: add one argparse subparser per analysis (``rgb``, ``psf``, ...);
- ``run(args) -> int``: run the parsed command, 0 on success (errors on stderr).

The provider is whatever was given to :func:`register_analysis`, else the module named by
``ANALYSIS_PROVIDER`` (``analysis.cli``), imported by name the first time it is needed.  This is the only place
in irtlang that names a later stage; the import-layer test allows it here and nowhere else.
"""
from __future__ import annotations

import importlib

ANALYSIS_PROVIDER = "analysis.cli"

_provider = None


def register_analysis(provider) -> None:
    """Use `provider` (build_parser, run) for ANALYZE and ``irt analyze``; None goes back to the default."""
    global _provider
    _provider = provider


def analysis_provider(required: bool = True):
    """The analysis provider; None if it cannot be imported and `required` is false."""
    if _provider is not None:
        return _provider
    try:
        return importlib.import_module(ANALYSIS_PROVIDER)
    except ImportError:
        if required:
            raise
        return None
