"""Executes the steps a script reaches (TRACE, SAVE/LOAD RAYS, analysis).

Steps that only change settings (WINDOW, PIXELS, CONSIDER, SELECT, RESET) are recorded.  Steps that need
traced rays report a clear missing capability until the non-sequential tracer is part of this build: no
step is ever skipped silently.
"""
from __future__ import annotations

from .io.manifest import RunFolder
from .lang.diagnostics import Span


class MissingCapability(Exception):
    def __init__(self, span: Span, what: str, capability: str):
        self.span, self.what, self.capability = span, what, capability
        super().__init__(f"{what} needs {capability}, which this version of irtlang does not have yet")


class RuntimeFailure(Exception):
    def __init__(self, span: Span, message: str):
        self.span, self.message = span, message
        super().__init__(message)


SETTINGS = ("WINDOW", "PIXELS", "CONSIDER", "SELECT", "RESET")
NEEDS_TRACER = ("TRACE", "LOAD_RAYS")


class Engine:
    def __init__(self, folder: RunFolder):
        self.folder = folder
        self.settings: dict = {}
        self.have_rays = False

    def run_step(self, step, interp) -> None:
        k = step.kind
        if k in SETTINGS:
            self.settings[k] = step.params
            if k == "RESET":
                self.have_rays = False
            return
        what = {"LOAD_RAYS": "LOAD RAYS", "SAVE_RAYS": "SAVE RAYS", "SPECTRUM_OF": "SPECTRUM OF"}.get(k, k)
        if k in NEEDS_TRACER:
            raise MissingCapability(step.span, what, "the non-sequential tracer (issue: the tracer)")
        if not self.have_rays:
            raise RuntimeFailure(step.span, f"{what} has no rays to work on: TRACE or LOAD RAYS first")
