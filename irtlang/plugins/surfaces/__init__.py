"""Surface kinds (the primitives allowed inside a SURFACE block)."""
from .. import load_registry

REGISTRY = load_registry(__name__, ["plane", "conic", "sphere", "ellipsoid", "tube", "mesh"])
