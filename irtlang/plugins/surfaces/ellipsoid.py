"""ELLIPSOID a b c [AT x y z]

An ellipsoid of semi-axes a, b, c along x, y, z (the WGS84 Earth: 6378.137 km 6378.137 km 6356.752 km),
normal pointing outward.

| parameter | unit | meaning |
|---|---|---|
| a b c | length | semi-axes along x, y, z (> 0) |
| AT x y z | length | centre (default the origin) |
"""
from ...lang.spec import Clause, Form, V, Vs, positive
from ...core.units import LENGTH
from ...model.scene import Surface, Transform

KIND = "ELLIPSOID"
FORM = Form((V("a", LENGTH, check=positive), V("b", LENGTH, check=positive), V("c", LENGTH, check=positive)),
            (Clause("AT", (Vs("centre", LENGTH, n=3),), doc="centre"),))
EXAMPLE = "SURFACE\n  ELLIPSOID 6378.137 km 6378.137 km 6356.752 km AT 0 0 0\nOBJECT 'earth'"


def build(b, ctx) -> Surface:
    centre = tuple(b.get("centre", (0.0, 0.0, 0.0)))
    return Surface(KIND, {"a": b["a"], "b": b["b"], "c": b["c"]}, Transform(T=centre), None, b.span)
