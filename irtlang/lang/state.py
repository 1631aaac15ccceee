"""The interpreter's state: what a script has defined so far, and STOP.

Its own module so that the commands (irtlang/lang/commands.py) and the interpreter (irtlang/lang/interp.py),
which runs them, both import it and neither imports the other backward (docs/architecture.md).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..core.diagnostics import Span
from ..model import scene as M


class StopScript(Exception):
    """STOP: ends the script here."""


class StepFailed(Exception):
    """A step's run found an input error (an IrtError from the engine): the run stops there, as after a run-time
    failure, instead of going on to steps that would use what the failed one should have made."""

    def __init__(self, error):
        super().__init__(str(error))
        self.error = error


@dataclass
class _SurfaceBlock:
    span: Span
    surfaces: list = field(default_factory=list)
    failed: bool = False                       # a surface in it failed: its OBJECT fails quietly


@dataclass
class State:
    """Everything a script has defined so far (mutable while interpreting; steps get frozen snapshots)."""

    units: str = "MM"
    wavelengths_nm: tuple = (550.0,)
    wavelengths_span: Span | None = None
    seed: int = 0
    media: dict = field(default_factory=lambda: {"AIR": M.AIR, "VACUUM": M.VACUUM})
    coatings: dict = field(default_factory=dict)
    spectra: dict = field(default_factory=dict)
    models: dict = field(default_factory=dict)
    maps: dict = field(default_factory=dict)
    objects: dict = field(default_factory=dict)
    groups: dict = field(default_factory=dict)
    sources: list = field(default_factory=list)
    pending_grid: tuple | None = None          # (module, params, span, group)
    block: _SurfaceBlock | None = None
    current: str | None = None                 # key of the current object
    group_stack: list = field(default_factory=list)
    level: int = 1000
    halt: float = 1e-6
    importance_cut: float = 0.0
    polarization: bool = False
    traces: int = 0                            # TRACE commands so far (a group may move between them)
    placed_trace: dict = field(default_factory=dict)   # group key -> the value of traces when it was placed
    first_per_line: Span | None = None         # first wavelength-dependent definition
    failed: set = field(default_factory=set)   # (namespace, key) of definitions that failed
    source_failed: bool = False                # a GRID, SOURCE or EMITTING failed (no follow-on errors)

    def scene(self) -> M.Scene:
        fp = M.frozen_params
        return M.Scene(self.units, self.wavelengths_nm, self.seed, fp(self.media), fp(self.coatings),
                       fp(self.spectra), fp(self.models), fp(self.maps), fp(self.objects), fp(self.groups),
                       tuple(self.sources), self.importance_cut, self.polarization)
