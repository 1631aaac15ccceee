"""Resource limits: what one script may ask of the machine (docs/language.md, "Safety and limits").

Every limit has a default that suits a workstation and can be raised (or lowered) for a run:
``irt run FILE --limit rays=1e11 --limit memory=200G`` (``irt check`` takes the same option), or the
environment variable ``IRT_LIMITS="rays=1e11,memory=200G"`` (the command line wins).  A script that
exceeds a limit gets a diagnostic at the command that asks for it, at ``irt check`` time wherever the
numbers are known then, and never a MemoryError or a run that does not end.

This module imports nothing from the pipeline: the front end, the file writers and the command line
all read their limits here.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass

ENV = "IRT_LIMITS"


@dataclass(frozen=True)
class LimitDef:
    name: str
    default: float | None      # None: computed (memory: a share of the machine's memory)
    unit: str                  # how the value is shown ("", "bytes", "characters")
    doc: str


DEFS = {d.name: d for d in (
    LimitDef("rays", 1e10, "", "source rays of one TRACE (every source's rays times the wavelength lines)"),
    LimitDef("pixels", 1e8, "", "pixels of one image (DETECTOR PIXELS nx ny, PIXELS nx ny, PSF SIZE n squared)"),
    LimitDef("memory", None, "bytes", "memory a TRACE is estimated to need (ray records, images); default 75% of "
                                       "the machine's memory"),
    LimitDef("steps", 1e7, "", "statements and loop iterations the interpreter runs in all (every DO loop, "
                               "macro call and INCLUDE of the script together)"),
    LimitDef("string", 1e6, "characters", "characters of one string value (concatenation, interpolation)"),
    LimitDef("statement", 1e5, "characters", "characters of one line (one statement) of a script"),
    LimitDef("script", 8e6, "bytes", "bytes of a script or an INCLUDEd file"),
    LimitDef("input", 2e9, "bytes", "bytes of a data file read by MEDIUM/SPECTRUM TABLE, MAP, LOAD RAYS"),
    LimitDef("format", 1000, "", "width and precision in an interpolation's format ('{x:10.3f}')"),
)}

MEMORY_SHARE = 0.75
_SUFFIX = {"": 1.0, "K": 1e3, "M": 1e6, "G": 1e9, "T": 1e12}


def machine_memory() -> int | None:
    """Physical memory of this machine in bytes (None where the platform does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return None


class LimitError(ValueError):
    """A bad --limit or IRT_LIMITS entry (the message says which)."""


def parse_value(text: str) -> float:
    """'1e10', '200G', '64GB', '5M' -> a number (K M G T are powers of 1000)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([kKmMgGtT]?)[bB]?\s*", text)
    if not m:
        raise LimitError(f"'{text}' is not a number (write 1e10, 5000000 or 64G)")
    v = float(m.group(1)) * _SUFFIX[m.group(2).upper()]
    if not v > 0 or v == float("inf"):
        raise LimitError(f"'{text}' must be a positive number")
    return v


class Limits:
    """The limits of one run: defaults, then IRT_LIMITS, then --limit options."""

    def __init__(self, values: dict | None = None):
        self.values = dict(values or {})

    @classmethod
    def from_env(cls, options=(), environ=None) -> "Limits":
        env = os.environ if environ is None else environ
        lim = cls()
        text = env.get(ENV, "")
        for part in (p for p in re.split(r"[,;\s]+", text) if p):
            lim.set(part, where=ENV)
        for opt in options or ():
            lim.set(opt, where="--limit")
        return lim

    def set(self, assignment: str, where: str = "--limit") -> None:
        name, eq, value = assignment.partition("=")
        name = name.strip().lower()
        if not eq:
            raise LimitError(f"{where}: '{assignment}' is not NAME=VALUE (limits: {', '.join(DEFS)})")
        if name not in DEFS:
            raise LimitError(f"{where}: unknown limit '{name}' (limits: {', '.join(DEFS)})")
        try:
            self.values[name] = parse_value(value)
        except LimitError as e:
            raise LimitError(f"{where}: {name}: {e}") from None

    def __getitem__(self, name: str) -> float:
        if name in self.values:
            return self.values[name]
        d = DEFS[name]
        if d.default is not None:
            return d.default
        mem = machine_memory()
        return MEMORY_SHARE * mem if mem else 64e9

    def exceeded(self, name: str, value: float) -> str | None:
        """None, or the sentence a diagnostic says when `value` is over the limit `name`."""
        lim = self[name]
        if value <= lim:
            return None
        return f"{show(name, value)} is more than the limit {name}={show(name, lim)}"

    def hint(self, name: str) -> str:
        return (f"raise it with `irt run FILE --limit {name}=VALUE` (or IRT_LIMITS=\"{name}=VALUE\") if this machine "
                "can take it; docs/language.md, \"Safety and limits\"")


def show(name: str, value: float) -> str:
    unit = DEFS[name].unit
    if unit == "bytes":
        for s, f in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
            if value >= f:
                return f"{value / f:.3g} {s}"
        return f"{value:.0f} bytes"
    if value == int(value) and value < 1e15:
        v = f"{int(value):,}"
    elif isinstance(value, int) and value.bit_length() > 1000:   # beyond a float
        v = f"about 10^{len(str(value)) - 1}"
    else:
        v = f"{value:.3g}"
    return f"{v} {unit}".rstrip()


def current() -> Limits:
    """The limits of a front end built without explicit ones (IRT_LIMITS or the defaults)."""
    try:
        return Limits.from_env()
    except LimitError:
        return Limits()
