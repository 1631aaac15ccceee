"""Scatter models (MODEL name KIND ...).  Each module: KIND, FORM, EXAMPLE, build(bound, ctx) -> params.

The kernel API every module implements (see lambertian.py, the reference, for the conventions): N_PARAMS,
pack(params, n_lines) -> (N_PARAMS, L) float64, and the njit functions eval, pdf, sample, albedo,
direct_transmission; optional: mueller (default: depolarizing) and delta_prob(P, k, cos_i), the probability with
which sample returns a delta (a slab's unscattered beam; default 0), which hero wavelengths weigh a delta by, and
albedo_parts(P, k, cos_i) -> (albedo's R, albedo's T, direct_transmission, delta_prob), bit for bit those calls'
values, which a slab may compute at once (hero wavelengths call it per line at every crossing; default: the
three calls).  Shared helpers (albedo tables, the single-scattering slab) live in ``_common``.
"""
from .. import load_registry

REGISTRY = load_registry(__name__, ["lambertian", "rossli", "glint", "rayleigh", "hg", "eddington", "abg", "table"])
