"""EMITTING SPHERE x y z radius RAYS n [TOWARD target]

A Lambertian sphere (the Sun: 0 0 0 6.957e5 km).  With TOWARD, rays are emitted only toward the target
object and weighted exactly by the solid angle it subtends, so no ray is wasted.

| parameter | unit | meaning |
|---|---|---|
| x y z | length | centre |
| radius | length | radius |
| RAYS | count | rays per wavelength line |
| TOWARD | object | importance target |
"""
from ...lang.spec import Form, V, positive
from ...core.units import LENGTH
from ._common import RAYS, TOWARD

KIND = "EMITTING SPHERE"
ROLE = "emitter"
FORM = Form((V("x", LENGTH), V("y", LENGTH), V("z", LENGTH), V("radius", LENGTH, check=positive)), (RAYS, TOWARD))
EXAMPLE = "EMITTING SPHERE 0 0 0 6.957e5 km RAYS 1000"


def build(b, ctx) -> dict:
    return {"centre": (b["x"], b["y"], b["z"]), "radius": b["radius"], "rays": b["rays"], "toward": b.get("toward")}
