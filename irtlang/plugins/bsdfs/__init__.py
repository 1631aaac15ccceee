"""Scatter models (MODEL name KIND ...).  Each module: KIND, FORM, EXAMPLE, build(bound, ctx) -> params.

The kernel API every module implements (see lambertian.py, the reference, for the conventions): N_PARAMS,
pack(params, n_lines) -> (N_PARAMS, L) float64, and the njit functions eval, pdf, sample, albedo,
direct_transmission.  Shared helpers (albedo tables, the single-scattering slab) live in ``_common``.
"""
from .. import load_registry

REGISTRY = load_registry(__name__, ["lambertian", "rossli", "glint", "rayleigh", "hg", "eddington", "abg", "table"])
