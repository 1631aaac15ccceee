"""EMITTING DISK axis position radius RAYS n [CONE half_angle] [TOWARD target]

A Lambertian disk in the plane (axis) = position, centred on the axis, emitting toward +axis; with CONE
only within that half-angle of the normal (which carries a share sin^2 of the Lambertian flux).

| parameter | unit | meaning |
|---|---|---|
| axis position | X/Y/Z, length | the disk's plane |
| radius | length | radius |
| RAYS | count | rays per wavelength line |
| CONE | angle (bare: deg) | emission half-angle (default 90) |
| TOWARD | object | importance target |
"""
from ...lang.spec import Axis, Form, V, positive
from ...core.units import LENGTH
from ._common import CONE, RAYS, TOWARD

KIND = "EMITTING DISK"
ROLE = "emitter"
FORM = Form((Axis(), V("position", LENGTH), V("radius", LENGTH, check=positive)), (RAYS, CONE, TOWARD))
EXAMPLE = "EMITTING DISK Z 0 5 RAYS 1000 CONE 10"


def build(b, ctx) -> dict:
    return {"axis": b["axis"], "position": b["position"], "radius": b["radius"], "rays": b["rays"],
            "cone": b.get("cone", 1.5707963267948966), "toward": b.get("toward")}
