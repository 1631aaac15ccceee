"""SPHERE x y z radius

A full sphere, normal pointing outward.

| parameter | unit | meaning |
|---|---|---|
| x y z | length | centre |
| radius | length | radius (> 0) |
"""
from ...lang.spec import Form, V, positive
from ...core.units import LENGTH
from ...model.scene import Surface, Transform

KIND = "SPHERE"
FORM = Form((V("x", LENGTH), V("y", LENGTH), V("z", LENGTH), V("radius", LENGTH, check=positive)))
EXAMPLE = "SURFACE\n  SPHERE 0 0 0 6371 km\nOBJECT 'ball'"


def build(b, ctx) -> Surface:
    return Surface(KIND, {"radius": b["radius"]}, Transform(T=(b["x"], b["y"], b["z"])), None, b.span)
