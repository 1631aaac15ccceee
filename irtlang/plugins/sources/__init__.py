"""Source kinds.  KIND is the full command ('GRID RECT', 'SOURCE DIRECTION', 'EMITTING SPHERE');
ROLE says how it combines: a 'grid' gives ray positions and waits for a 'direction' (SOURCE ...);
an 'emitter' is a whole source by itself.

The kernel's side of a kind is in its module too, and the kernel's dispatch over kinds is generated from this
registry (``irtlang.compile.specialize.source_dispatch``).  All njit, inline, reading the ``layout.Sources``
table SRC at row s:

* a grid or an emitter: ``emit(SRC, s, q, u0, u1) -> (x, y, z, ax, ay, az)``: the start point of the source's
  q-th ray of a line (its own frame; u0, u1 uniform numbers) and the axis of Lambertian emission there.  Its code
  (``Sources.kind``) is its index among the kinds that have ``emit``, in registry order (``EMITTER_CODES``).
  A Lambertian emitter may have ``lambert(SRC, s, u2, u3) -> (x, y, z, weight factor)`` (a direction about +z)
  and ``toward(SRC, s, cos, omega) -> weight factor`` (a direction drawn uniformly in a cone of solid angle omega
  toward a target, at cos to the axis); without them, ``_common``'s: cosine-weighted over the hemisphere;
* a direction: ``DIRECTION_CODES`` (its ``layout.DIR_*`` codes) and ``direction(SRC, s, x, y, z) -> (dx, dy,
  dz)`` in the source's frame (the kernel rotates and normalizes it; DIR_COLLIMATED once per batch).
Read SRC's arrays in place (``SRC.par[s, 0]``), never as locals (``par = SRC.par``): a local is an atomically
counted reference that runs on every ray (docs/architecture.md, "The kernel"; tests/unit/test_kernel_layout.py).
Packing stays in ``irtlang.compile.pack._pack_sources``.
"""
from .. import load_registry

REGISTRY = load_registry(__name__, ["grid_rect", "grid_disk", "direction", "position", "field",
                                    "emitting_sphere", "emitting_disk", "emitting_point"])
#: kind -> code of the kinds that start rays (layout.Sources.kind)
EMITTER_CODES = {k: q for q, k in enumerate(k for k, m in REGISTRY.items() if hasattr(m, "emit"))}


def of_role(head: str) -> dict:
    """{second word: module} for one head word (GRID, SOURCE, EMITTING)."""
    return {k.split()[1]: m for k, m in REGISTRY.items() if k.split()[0] == head}
