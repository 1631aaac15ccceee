"""Source kinds.  KIND is the full command ('GRID RECT', 'SOURCE DIRECTION', 'EMITTING SPHERE');
ROLE says how it combines: a 'grid' gives ray positions and waits for a 'direction' (SOURCE ...);
an 'emitter' is a whole source by itself."""
from .. import load_registry

REGISTRY = load_registry(__name__, ["grid_rect", "grid_disk", "direction", "position", "field",
                                    "emitting_sphere", "emitting_disk", "emitting_point"])


def of_role(head: str) -> dict:
    """{second word: module} for one head word (GRID, SOURCE, EMITTING)."""
    return {k.split()[1]: m for k, m in REGISTRY.items() if k.split()[0] == head}
