"""Helpers for the instrument tests (tests/physics/test_instrument_*.py): the HRI-like Cassegrain of
examples_scripts/cassegrain.inr, its design numbers worked out here from ORACLES.md's formulas (not read from the
script), an exact sequential numpy trace of its two mirrors, and a runner for small scripts that include it."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import EXAMPLES, trace_file  # noqa: E402

MM = 1e-3
UM = 1e-6

# ORACLES.md "Instrument": D = 300 mm, EFL = m f1, focus e = 300 mm behind the primary vertex
F1 = 1028.7 * MM
M_SEC = 10.207
EFL = M_SEC * F1
E_BACK = 300 * MM
K_RATIO = (F1 + E_BACK) / (EFL + F1)
D0 = F1 * (1 - K_RATIO)                          # design mirror separation
R1 = 2 * F1
R2 = 2 * M_SEC * K_RATIO * F1 / (M_SEC - 1)
K2 = -((M_SEC + 1) / (M_SEC - 1)) ** 2
# the instrument's stops, as cassegrain.inr builds them (mm -> m)
R_OBSC = 48.5 * MM
VANE_HALF = 1.0 * MM
R_TUBE = 165 * MM
R_HOLE, R_PRIMARY, R_SEC = 40 * MM, 150 * MM, 20 * MM


def paraxial_focus(d: float) -> float:
    """z of the Cassegrain's paraxial focus for mirror separation d (Gaussian optics, mirror equation): the
    primary images infinity at z = f1, a virtual object at f1 - d behind the convex secondary (focal length
    -R2/2), whose image lies 1 / (1/(f1 - d) - 2/R2) in front of it."""
    return d - 1.0 / (1.0 / (F1 - d) - 2.0 / R2)


def _conic_hit(p, d, zv, c, k):
    """Rays p + t d against the conic c rho^2 - 2 Z + (1 + k) c Z^2 = 0 (Z = z - zv): the hit on the sheet through
    the vertex (the root with the smaller |Z|, t > 0) and the unit normal there."""
    P = p - np.array([0.0, 0.0, zv])
    a = c * (d[:, 0] ** 2 + d[:, 1] ** 2) + (1 + k) * c * d[:, 2] ** 2
    b = 2 * c * (P[:, 0] * d[:, 0] + P[:, 1] * d[:, 1]) - 2 * d[:, 2] + 2 * (1 + k) * c * P[:, 2] * d[:, 2]
    cc = c * (P[:, 0] ** 2 + P[:, 1] ** 2) - 2 * P[:, 2] + (1 + k) * c * P[:, 2] ** 2
    disc = np.sqrt(b * b - 4 * a * cc)
    q = -0.5 * (b + np.copysign(disc, b))
    with np.errstate(divide="ignore", invalid="ignore"):
        ts = np.stack([q / a, cc / q], axis=1)
    Z = P[:, 2:3] + ts * d[:, 2:3]
    ok = np.isfinite(ts) & (ts > 1e-12)
    pick = np.where(ok, np.abs(Z), np.inf).argmin(axis=1)
    t = ts[np.arange(len(ts)), pick]
    h = p + t[:, None] * d
    Zh = h[:, 2] - zv
    n = np.stack([2 * c * h[:, 0], 2 * c * h[:, 1], -2 + 2 * (1 + k) * c * Zh], axis=1)
    return h, n / np.linalg.norm(n, axis=1)[:, None]


def _reflect(d, n):
    return d - 2 * np.einsum("ij,ij->i", d, n)[:, None] * n


def cassegrain_trace(p0, d0, spacing_delta_um=0.0, z_plane=-E_BACK):
    """Exact sequential trace (metres): the rays p0 + t d0 (travelling toward -z) past the central obscuration
    (disk R_OBSC at z = d + 1 mm) and the four vanes (strips 2 VANE_HALF wide at z = d + 3 mm, along 45, 135,
    225, 315 deg, from R_OBSC - 1 mm to R_TUBE + 1 mm), onto the primary (annulus R_HOLE .. R_PRIMARY), the
    secondary (disk R_SEC) and the plane z = z_plane.  Returns (kept mask, points, directions) on the plane."""
    d = D0 + spacing_delta_um * UM
    p0, d0 = np.asarray(p0, float), np.asarray(d0, float)

    def at_z(z):
        t = (z - p0[:, 2]) / d0[:, 2]
        return p0 + t[:, None] * d0

    q = at_z(d + 1 * MM)
    keep = np.hypot(q[:, 0], q[:, 1]) > R_OBSC
    q = at_z(d + 3 * MM)
    for i in range(4):
        a = math.radians(45 + 90 * i)
        along = q[:, 0] * math.cos(a) + q[:, 1] * math.sin(a)
        across = -q[:, 0] * math.sin(a) + q[:, 1] * math.cos(a)
        keep &= ~((np.abs(across) <= VANE_HALF) & (along >= R_OBSC - 1 * MM) & (along <= R_TUBE + 1 * MM))
    h1, n1 = _conic_hit(p0, d0, 0.0, 1 / R1, -1.0)
    r1 = np.hypot(h1[:, 0], h1[:, 1])
    keep &= (r1 >= R_HOLE) & (r1 <= R_PRIMARY)
    d1 = _reflect(d0, n1)
    h2, n2 = _conic_hit(h1, d1, d, 1 / R2, K2)
    keep &= np.hypot(h2[:, 0], h2[:, 1]) <= R_SEC
    d2 = _reflect(d1, n2)
    t = (z_plane - h2[:, 2]) / d2[:, 2]
    return keep, h2 + t[:, None] * d2, d2


def instrument_script(body: str, *, wavelengths="550 NM", spacing_delta=0.0, band="550", group=False) -> str:
    inc = f"INCLUDE '{EXAMPLES / 'cassegrain.inr'}'"
    if group:
        inc = f"GROUP tel\n{inc}\nEND GROUP"
    return (f"SYSTEM NEW\nWAVELENGTHS {wavelengths}\nSEED 1\nspacing_delta = {spacing_delta!r}\nband = {band}\n"
            f"{inc}\nLEVEL 30\n{body}\n")


def trace_instrument(tmp_path, body: str, name="inst.inr", **kw):
    """Trace the last TRACE of an instrument script; returns (result, records of the rays that ended on fpa)."""
    f = Path(tmp_path) / name
    f.write_text(instrument_script(body, **{k: v for k, v in kw.items() if k in ("wavelengths", "spacing_delta",
                                                                                   "band", "group")}))
    res = trace_file(f, **{k: v for k, v in kw.items() if k in ("records", "history")})
    names = [n.upper() for n in res.packed.object_names]
    r = res.records
    if r is None:
        return res, None
    on = r["object"] == names.index("FPA")
    return res, {k: v[on] for k, v in r.items()}


def field_dir(fx_deg, fy_deg):
    """SOURCE FIELD's direction for a grid above the plane z = 0 (plugins/sources/field.py)."""
    v = np.array([math.tan(math.radians(fx_deg)), math.tan(math.radians(fy_deg)), -1.0])
    return v / np.linalg.norm(v)
