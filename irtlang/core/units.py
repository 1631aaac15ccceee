"""Units and quantities.

Canonical internal units: metre, radian, second, watt, kelvin.  A value is a ``Quantity``: a float in
canonical units and a dimension, or a *bare* number (``dim is None``) whose unit is decided where it is
used: a bare length takes the ``UNITS`` unit, a bare angle is in degrees, everything else takes the
canonical unit (s, W, W/m2, m/s, K).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

# dimension exponents: (length, angle, time, power, temperature)
Dim = tuple[int, int, int, int, int]
NONE: Dim = (0, 0, 0, 0, 0)
LENGTH: Dim = (1, 0, 0, 0, 0)
ANGLE: Dim = (0, 1, 0, 0, 0)
TIME: Dim = (0, 0, 1, 0, 0)
POWER: Dim = (0, 0, 0, 1, 0)
TEMPERATURE: Dim = (0, 0, 0, 0, 1)
IRRADIANCE: Dim = (-2, 0, 0, 1, 0)
SPEED: Dim = (1, 0, -1, 0, 0)
INV_LENGTH: Dim = (-1, 0, 0, 0, 0)

AU_M = 1.495978707e11

# unit name (lower case) -> (factor to canonical, dimension)
UNITS: dict[str, tuple[float, Dim]] = {
    "nm": (1e-9, LENGTH), "um": (1e-6, LENGTH), "mm": (1e-3, LENGTH), "cm": (1e-2, LENGTH),
    "m": (1.0, LENGTH), "km": (1e3, LENGTH), "au": (AU_M, LENGTH), "in": (0.0254, LENGTH),
    "deg": (math.pi / 180.0, ANGLE), "rad": (1.0, ANGLE), "mrad": (1e-3, ANGLE), "urad": (1e-6, ANGLE),
    "arcsec": (math.pi / 180.0 / 3600.0, ANGLE),
    "s": (1.0, TIME), "min": (60.0, TIME), "h": (3600.0, TIME),
    "w": (1.0, POWER), "w/m2": (1.0, IRRADIANCE), "m/s": (1.0, SPEED), "k": (1.0, TEMPERATURE),
    "%": (0.01, NONE),
}
LENGTH_UNITS = ("NM", "UM", "MM", "CM", "M", "KM", "AU", "IN")

DIM_NAMES: dict[Dim, str] = {
    NONE: "a pure number", LENGTH: "a length", ANGLE: "an angle", TIME: "a time", POWER: "a power",
    TEMPERATURE: "a temperature", IRRADIANCE: "an irradiance", SPEED: "a speed",
    INV_LENGTH: "an inverse length",
}
# how a dimension is displayed (unit name, factor from canonical); lengths use UNITS at display time
DISPLAY: dict[Dim, tuple[str, float]] = {
    ANGLE: ("deg", math.pi / 180.0), TIME: ("s", 1.0), POWER: ("W", 1.0), TEMPERATURE: ("K", 1.0),
    IRRADIANCE: ("W/m2", 1.0), SPEED: ("m/s", 1.0),
}


def dim_name(dim: Dim | None) -> str:
    if dim is None:
        return "a number"
    if dim in DIM_NAMES:
        return DIM_NAMES[dim]
    return "a quantity of dimension " + unit_string(dim)


def unit_string(dim: Dim) -> str:
    names = ("m", "rad", "s", "W", "K")
    num = [f"{n}^{e}" if e != 1 else n for n, e in zip(names, dim) if e > 0]
    den = [f"{n}^{-e}" if e != -1 else n for n, e in zip(names, dim) if e < 0]
    s = "*".join(num) or "1"
    return s + ("/" + "/".join(den) if den else "")


@dataclass(frozen=True)
class Quantity:
    """A number in canonical units with a dimension; ``dim is None`` marks a bare number."""

    value: float
    dim: Dim | None = None

    @property
    def bare(self) -> bool:
        return self.dim is None

    def describe(self, length_unit: str = "MM") -> str:
        """As a person would write it: ``5 deg``, ``12.5 mm``, ``3``."""
        if self.dim is None or self.dim == NONE:
            return fmt_number(self.value)
        if self.dim == LENGTH:
            f = UNITS[length_unit.lower()][0]
            return f"{fmt_number(self.value / f)} {length_unit.lower()}"
        if self.dim in DISPLAY:
            name, f = DISPLAY[self.dim]
            return f"{fmt_number(self.value / f)} {name}"
        return f"{fmt_number(self.value)} {unit_string(self.dim)}"


def fmt_number(x: float) -> str:
    """Integers print as integers (``VANE_3``), others with up to 10 significant digits."""
    if isinstance(x, bool):
        return "1" if x else "0"
    if math.isfinite(x) and x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return f"{x:.10g}"


def parse_qty_token(text: str) -> tuple[float, str | None]:
    """Split a QTY token (``550nm``, ``7 m/s``, ``1%``) into its number and its unit (lower case)."""
    t = text.strip()
    if t.endswith("%"):
        return float(t[:-1].strip()), "%"
    m = _NUMBER.match(t)
    unit = t[m.end():].strip().lower() or None
    return float(m.group(0)), unit


_NUMBER = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def quantity(num: float, unit: str | None) -> Quantity:
    if unit is None:
        return Quantity(num, None)
    f, d = UNITS[unit]
    return Quantity(num * f, d)
