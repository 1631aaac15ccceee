"""ELLIPSOID a b c [AT x y z]

An ellipsoid of semi-axes a, b, c along x, y, z (the WGS84 Earth: 6378.137 km 6378.137 km 6356.752 km),
normal pointing outward.

| parameter | unit | meaning |
|---|---|---|
| a b c | length | semi-axes along x, y, z (> 0) |
| AT x y z | length | centre (default the origin) |
"""
import numba

from ...kernels.geometry import ellipsoid_normal, hit_ellipsoid, leaving_ellipsoid_root
from ...kernels.layout import SF_PAR
from ...lang.spec import Clause, Form, V, Vs, positive
from ...core.units import LENGTH
from ...model.scene import Surface, Transform

KIND = "ELLIPSOID"
FORM = Form((V("a", LENGTH, check=positive), V("b", LENGTH, check=positive), V("c", LENGTH, check=positive)),
            (Clause("AT", (Vs("centre", LENGTH, n=3),), doc="centre"),))
EXAMPLE = "SURFACE\n  ELLIPSOID 6378.137 km 6378.137 km 6356.752 km AT 0 0 0\nOBJECT 'earth'"
FEATURE = "quadric"


def build(b, ctx) -> Surface:
    centre = tuple(b.get("centre", (0.0, 0.0, 0.0)))
    return Surface(KIND, {"a": b["a"], "b": b["b"], "c": b["c"]}, Transform(T=centre), None, b.span)


# ---- packing and the kernel (the contract: irtlang/plugins/surfaces/__init__.py) ----
def pack(s: Surface) -> dict:
    """par: the semi-axes a, b, c (m) along local x, y, z."""
    return {"par": (s.params["a"], s.params["b"], s.params["c"])}


def bounds(s: Surface) -> tuple:
    return (0.0, 0.0, 0.0, max(s.params["a"], s.params["b"], s.params["c"]))


def size(s: Surface) -> float:
    return max(s.params["a"], s.params["b"], s.params["c"])


@numba.njit(cache=True, inline="always")
def hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    if leaving:     # the other crossing in closed form (kernels/geometry.py, "Self-intersection policy")
        t1, t2 = leaving_ellipsoid_root(ox, oy, oz, dx, dy, dz, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_PAR + 2])
        return t1, t2, -1
    t1, t2 = hit_ellipsoid(ox, oy, oz, dx, dy, dz, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_PAR + 2])
    return t1, t2, -1


@numba.njit(cache=True, inline="always")
def normal(f, si, S, j, x, y, z, face):
    return ellipsoid_normal(x, y, z, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_PAR + 2])
