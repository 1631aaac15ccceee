"""The scene model: typed, immutable, in canonical units.

Canonical units: lengths in metres, angles in radians, power in W, irradiance in W/m2, wavelengths in nm
(the one exception, since every spectral table and output is in nm).  Every wavelength-dependent value is a
tuple with one value per system line.  Each element keeps the ``Span`` of the command that made it so later
stages (packing, tracing) can point at the script.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any, Mapping

from ..core.diagnostics import NO_SPAN, Span


def frozen_params(d: Mapping[str, Any] | None = None) -> Mapping[str, Any]:
    return MappingProxyType(dict(d or {}))


@dataclass(frozen=True)
class Transform:
    """world = R @ local + T (R row-major 3x3, T in metres)."""

    R: tuple = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    T: tuple = (0.0, 0.0, 0.0)

    def then(self, R2: tuple, T2: tuple = (0.0, 0.0, 0.0)) -> "Transform":
        """Apply (R2, T2) after this transform: x -> R2 @ (R x + T) + T2."""
        R = _matmul(R2, self.R)
        T = tuple(sum(R2[3 * i + k] * self.T[k] for k in range(3)) + T2[i] for i in range(3))
        return Transform(R, T)

    def shifted(self, d: tuple) -> "Transform":
        return Transform(self.R, tuple(a + b for a, b in zip(self.T, d)))

    def rotated(self, axis: str, angle: float, about: tuple = (0.0, 0.0, 0.0)) -> "Transform":
        Rr = rotation(axis, angle)
        moved = Transform(self.R, tuple(a - b for a, b in zip(self.T, about)))
        return moved.then(Rr, about)

    def apply(self, p: tuple) -> tuple:
        return tuple(sum(self.R[3 * i + k] * p[k] for k in range(3)) + self.T[i] for i in range(3))


IDENTITY = Transform()


def _matmul(A: tuple, B: tuple) -> tuple:
    return tuple(sum(A[3 * i + k] * B[3 * k + j] for k in range(3)) for i in range(3) for j in range(3))


def rotation(axis: str, angle: float) -> tuple:
    """Right-handed rotation about a coordinate axis (row-major 3x3)."""
    c, s = math.cos(angle), math.sin(angle)
    if axis == "X":
        return (1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
    if axis == "Y":
        return (c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
    return (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)


# axis frames for PLANE X/Y/Z, CONIC X/Y/Z and TUBE: columns are the world directions of local x, y, z.
# Cyclic order (Z: x then y; X: y then z; Y: z then x), so every frame is a proper rotation.
AXIS_FRAME = {
    "Z": (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
    "X": (0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0),
    "Y": (0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0),
}


# ---------------------------------------------------------------- materials
@dataclass(frozen=True)
class Medium:
    name: str
    kind: str                   # builtin | index | sellmeier | table
    index: tuple                # refractive index per line
    absorb: tuple               # extinction coefficient per line, 1/m
    params: Mapping = field(default_factory=frozen_params)
    span: Span = NO_SPAN


@dataclass(frozen=True)
class Coating:
    name: str
    kind: str                   # rt | fresnel | metal
    reflect: tuple = ()         # metal: the real part n of the complex index, per line
    transmit: tuple = ()        # metal: its imaginary part k (>= 0)
    span: Span = NO_SPAN
    polarized: tuple | None = None   # POLARIZED: per line (Rs - Rp)/2, (Ts - Tp)/2, delta_r, delta_t (radians)


@dataclass(frozen=True)
class Spectrum:
    name: str
    kind: str                   # solar | table | blackbody
    wavelengths_nm: tuple       # the spectrum's own sampling
    values: tuple
    on_lines: tuple             # averaged over each system line's band, energy conserved
    unit: str                   # e.g. W/m2/nm, or '' for a pure number
    params: Mapping = field(default_factory=frozen_params)
    span: Span = NO_SPAN


@dataclass(frozen=True)
class ScatterModel:
    name: str
    kind: str                   # registry key: LAMBERTIAN, ROSSLI, GLINT, RAYLEIGH, HG, ...
    params: Mapping             # label -> tuple per line (or a scalar)
    span: Span = NO_SPAN


@dataclass(frozen=True)
class MapDef:
    name: str
    kind: str                   # LATLON
    path: str | None            # a file, or None for a built-in dataset
    dataset: str | None
    span: Span = NO_SPAN


# ---------------------------------------------------------------- geometry
@dataclass(frozen=True)
class Aperture:
    kind: str                   # RECT | DISK | ANNULUS | ELLIPSE
    params: tuple               # metres
    span: Span = NO_SPAN


@dataclass(frozen=True)
class Surface:
    kind: str                   # registry key: PLANE, CONIC, SPHERE, ELLIPSOID, TUBE, MESH
    params: Mapping             # canonical units; see the plugin module
    frame: Transform            # surface local frame -> object frame (axis letter, position)
    aperture: Aperture | None = None
    span: Span = NO_SPAN


@dataclass(frozen=True)
class Interface:
    kind: str                   # coating | reflect | absorb | transmit | polarizer | retarder
    coating: str | None
    back: str                   # medium on the side the normal points away from
    front: str                  # medium on the side the normal points to
    span: Span = NO_SPAN
    angle: float = 0.0          # polarizer / retarder: the axis, rad from the object's local x toward its y
    retardance: float = 0.0     # retarder: the slow axis's phase delay, rad


@dataclass(frozen=True)
class ScatterSpec:
    model: str | None           # SCATTER MODEL m
    map: str | None             # SCATTER MAP m MODELS ...
    models: tuple = ()          # class index -> model name
    rays: int = 1
    toward: str | None = None
    span: Span = NO_SPAN


@dataclass(frozen=True)
class Detector:
    nx: int
    ny: int
    span: Span = NO_SPAN
    qe: tuple | None = None     # quantum efficiency per line, applied to the image
    filters: tuple | None = None    # ((name, transmission per line), ...): one image per filter
    start: tuple | None = None  # (x_min, x_max, y_min, y_max) m: binned by the rays' start points (adjoint image)


@dataclass(frozen=True)
class SceneObject:
    name: str
    surfaces: tuple
    transform: Transform = IDENTITY     # object frame -> its group's frame (or the world)
    interface: Interface | None = None
    scatter: tuple = ()
    detector: Detector | None = None
    group: str | None = None
    span: Span = NO_SPAN
    # OPAQUE WHERE map FROM lo TO hi: (map key, lo, hi, span): the object exists only where the map's value at
    # the hit lies in [lo, hi): opaque there (its scatter models apply, the rest is absorbed), clear elsewhere
    where: tuple | None = None


@dataclass(frozen=True)
class Group:
    name: str
    parent: str | None
    placement: Transform = IDENTITY     # group frame -> parent frame
    placed: Span | None = None
    span: Span = NO_SPAN


# ---------------------------------------------------------------- sources
@dataclass(frozen=True)
class Flux:
    kind: str                   # total | spectrum
    value: float | None = None  # W (total)
    spectrum: str | None = None
    span: Span = NO_SPAN


@dataclass(frozen=True)
class Source:
    kind: str                   # GRID_RECT+DIRECTION, EMITTING_SPHERE, ... (registry key)
    params: Mapping
    group: str | None = None
    flux: Flux = Flux("total", 1.0)
    span: Span = NO_SPAN


# ---------------------------------------------------------------- the scene
@dataclass(frozen=True)
class Scene:
    units: str = "MM"
    wavelengths_nm: tuple = (550.0,)
    seed: int = 0
    media: Mapping = field(default_factory=frozen_params)
    coatings: Mapping = field(default_factory=frozen_params)
    spectra: Mapping = field(default_factory=frozen_params)
    models: Mapping = field(default_factory=frozen_params)
    maps: Mapping = field(default_factory=frozen_params)
    objects: Mapping = field(default_factory=frozen_params)   # in definition order
    groups: Mapping = field(default_factory=frozen_params)
    sources: tuple = ()
    importance_cut: float = 0.0     # HALT ... IMPORTANCE c: roulette of rays sent toward targets
    polarization: bool = False      # POLARIZATION: rays carry Stokes vectors

    @property
    def n_lines(self) -> int:
        return len(self.wavelengths_nm)

    def world_transform(self, obj: SceneObject) -> Transform:
        """The object's frame composed with every enclosing group's placement."""
        t = obj.transform
        g = obj.group
        while g is not None:
            grp = self.groups[g]
            t = t.then(grp.placement.R, grp.placement.T)
            g = grp.parent
        return t


# ---------------------------------------------------------------- steps (what a script asks to run)
@dataclass(frozen=True)
class Step:
    """A command that acts on rays: TRACE, SAVE/LOAD RAYS, and the analysis commands."""

    kind: str                   # TRACE, STATS, SPOTS, FOCUS, SPECTRUM_OF, EXPORT, SAVE_RAYS, ...
    params: Mapping
    scene: Scene | None
    span: Span = NO_SPAN


AIR = Medium("AIR", "builtin", (1.0,), (0.0,), span=NO_SPAN)
VACUUM = Medium("VACUUM", "builtin", (1.0,), (0.0,), span=NO_SPAN)

__all__ = [n for n in dir() if not n.startswith("_")] + ["replace"]
