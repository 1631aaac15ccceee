"""SPHERE x y z radius

A full sphere, normal pointing outward.

| parameter | unit | meaning |
|---|---|---|
| x y z | length | centre |
| radius | length | radius (> 0) |
"""
import numba

from ...kernels.geometry import hit_sphere, leaving_sphere_root, sphere_normal
from ...kernels.layout import SF_PAR
from ...lang.spec import Form, V, positive
from ...core.units import LENGTH
from ...model.scene import Surface, Transform

KIND = "SPHERE"
FORM = Form((V("x", LENGTH), V("y", LENGTH), V("z", LENGTH), V("radius", LENGTH, check=positive)))
EXAMPLE = "SURFACE\n  SPHERE 0 0 0 6371 km\nOBJECT 'ball'"
FEATURE = "quadric"


def build(b, ctx) -> Surface:
    return Surface(KIND, {"radius": b["radius"]}, Transform(T=(b["x"], b["y"], b["z"])), None, b.span)


# ---- packing and the kernel (the contract: irtlang/plugins/surfaces/__init__.py) ----
def pack(s: Surface) -> dict:
    """par: the radius (m)."""
    return {"par": (s.params["radius"],)}


def bounds(s: Surface) -> tuple:
    return (0.0, 0.0, 0.0, s.params["radius"])


def size(s: Surface) -> float:
    return s.params["radius"]


@numba.njit(cache=True, inline="always")
def hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    if leaving:     # the other crossing in closed form (kernels/geometry.py, "Self-intersection policy")
        t1, t2 = leaving_sphere_root(ox, oy, oz, dx, dy, dz)
        return t1, t2, -1
    t1, t2 = hit_sphere(ox, oy, oz, dx, dy, dz, f[j, SF_PAR])
    return t1, t2, -1


@numba.njit(cache=True, inline="always")
def normal(f, si, S, j, x, y, z, face):
    return sphere_normal(x, y, z)
