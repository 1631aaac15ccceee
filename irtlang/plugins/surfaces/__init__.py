"""Surface kinds (the primitives allowed inside a SURFACE block).

A surface kind is one module here and one name in ``REGISTRY`` below; its code in the packed scene is its index
in the registry, and the kernel's dispatch over kinds is generated from the registry
(``irtlang.compile.specialize.surface_dispatch``).  A module declares:

* ``KIND``, ``FORM``, ``EXAMPLE``, ``build(bound, ctx) -> model.scene.Surface`` and a docstring with its parameter
  table (``irtlang/plugins/__init__.py``);
* ``FEATURE``: the kernel feature flag its code is compiled under (``irtlang.compile.pack.Features``: "conic",
  "quadric", "mesh", or a field of its own, as "biconic": then only scenes with the kind compile its code), or None
  for code every kernel has;
* ``pack(surface) -> dict`` with any of ``par`` (at most ``layout.N_PAR`` floats, columns SF_PAR..),
  ``asph`` (at most ``layout.N_ASPH`` even-asphere terms, SF_ASPH..) and ``mesh`` (a ``kernels.bvh.build_bvh``
  result); its docstring says what each parameter is.  Everything in metres, in the surface's local frame;
* ``bounds(surface) -> (cx, cy, cz, r)``: a sphere in the local frame that holds the whole surface within its
  aperture (r = inf: unbounded); TOWARD aims at it, and the kernel culls with it, widened by ``BOUNDS_PAD``
  (relative, absolute; default (1e-9, 0));
* ``size(surface) -> float``: the characteristic size without an aperture (the self-hit tolerance scales with
  it; with an aperture its outer radius is used);
* ``hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving) -> (t1, t2, face)``, njit inline: the ray's
  crossings with surface j in its local frame (f, si: the surface table's float and int columns, S.f and S.i
  passed apart, so the hot path reads them without going through the tuple; S the whole ``layout.Surfaces``
  table, for a mesh's BVH), t1 <= t2, inf where absent, before the
  aperture test (the kernel applies it).  With ``leaving`` the ray starts on this surface (it has just left it):
  the root of the departure point itself must be dropped.  ``face``: a mesh's triangle row, else -1;
* ``normal(f, si, S, j, x, y, z, face) -> (nx, ny, nz)``, njit inline: the local unit normal at a point of the surface.
  Both read S's arrays in place (``S.fn[face, 0]``), never as locals (``fn = S.fn``): a local is an atomically
  counted reference that runs on every hit (docs/architecture.md, "The kernel"; tests/unit/test_kernel_layout.py).

Generic tests over the registry: tests/unit/test_surface_plugins.py.
"""
from .. import load_registry

REGISTRY = load_registry(__name__, ["plane", "conic", "sphere", "ellipsoid", "tube", "mesh", "biconic"])
#: kind -> code in the packed scene (layout.SI_KIND)
CODES = {k: q for q, k in enumerate(REGISTRY)}
