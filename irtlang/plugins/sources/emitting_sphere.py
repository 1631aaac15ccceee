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
import numba

from ...kernels.sampling import uniform_sphere
from ...lang.spec import Form, V, positive
from ...core.units import LENGTH
from ._common import RAYS, TOWARD

KIND = "EMITTING SPHERE"
ROLE = "emitter"
FORM = Form((V("x", LENGTH), V("y", LENGTH), V("z", LENGTH), V("radius", LENGTH, check=positive)), (RAYS, TOWARD))
EXAMPLE = "EMITTING SPHERE 0 0 0 6.957e5 km RAYS 1000"


def build(b, ctx) -> dict:
    return {"centre": (b["x"], b["y"], b["z"]), "radius": b["radius"], "rays": b["rays"], "toward": b.get("toward")}


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
@numba.njit(cache=True, inline="always")
def emit(SRC, s, q, u0, u1):
    """A uniform point of the sphere; its outward normal is the Lambertian axis (the default ``lambert`` and
    ``toward``: cosine-weighted over the outer hemisphere)."""
    x, y, z = uniform_sphere(u0, u1)
    r = SRC.par[s, 0]
    return r * x, r * y, r * z, x, y, z
