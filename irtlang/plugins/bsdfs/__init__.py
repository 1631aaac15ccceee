"""Scatter models (MODEL name KIND ...).  Each module: KIND, FORM, EXAMPLE, build(bound, ctx) -> params."""
from .. import load_registry

REGISTRY = load_registry(__name__, ["lambertian", "rossli", "glint", "rayleigh", "hg"])
