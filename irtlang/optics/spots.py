"""Spot diagrams as optical engineers draw them (SPOTS DIAGRAM), and the paraxial report of FOCUS.

Intercepts are taken in the detector's own frame (the local x and y of the object the rays ended on), in
micrometres about a reference point: the flux-weighted centroid (ABOUT CENTROID, the default), or the chief ray
(ABOUT CHIEF): the intercept of the ray through the centre of the source GRID, from a least-squares fit of the
intercepts as a linear function of the rays' start points in the grid (x = a + b sx + c sy, the same for y),
evaluated at sx = sy = 0, so that a chief ray blocked by a central obscuration still has its point.

RMS radius: sqrt of the flux-weighted mean of r^2 about the reference; GEO radius: the largest r.  The Airy
radius is 1.22 lambda N, N = 1 / (2 NA) the working f-number, NA the sine of the largest angle between a ray and
the rays' mean direction (the marginal ray's).
"""
from __future__ import annotations

import math

import numpy as np

from ..core.units import LENGTH, Quantity


def detector_frame(pk, obj_index: int):
    """(origin (3,), x axis, y axis, normal) of an object's first surface in world coordinates, or None."""
    if not hasattr(pk, "s_obj"):
        return None
    js = np.flatnonzero(np.asarray(pk.s_obj) == obj_index)
    if not len(js):
        return None
    j = int(js[0])
    R = np.asarray(pk.s_R[j], float).reshape(3, 3)
    T = np.asarray(pk.s_Th[j], float) + np.asarray(pk.s_Tl[j], float)
    return T, R[:, 0], R[:, 1], R[:, 2]


def local_xy(pos, frame, fallback_axes=(0, 1)):
    """Positions (n, 3) in the frame's local x, y (world axes when frame is None)."""
    if frame is None:
        return pos[:, fallback_axes[0]], pos[:, fallback_axes[1]]
    o, ex, ey, _ = frame
    d = pos - o
    return d @ ex, d @ ey


def reference(x, y, w, start, about: str):
    """Reference point (x0, y0) of a spot: centroid, or chief ray (see the module docstring)."""
    wg = w if w.sum() > 0 else np.ones_like(w)
    cx, cy = float((x * wg).sum() / wg.sum()), float((y * wg).sum() / wg.sum())
    if about != "CHIEF" or start is None or len(x) < 3:
        return cx, cy
    A = np.column_stack([np.ones(len(x)), start[:, 0], start[:, 1]])
    if np.linalg.matrix_rank(A) < 3:
        return cx, cy
    sol, *_ = np.linalg.lstsq(A, np.column_stack([x, y]), rcond=None)
    return float(sol[0, 0]), float(sol[0, 1])


def spot_stats(x, y, w):
    """(rms, geo) radius about (0, 0)."""
    r2 = x * x + y * y
    wg = w if w.sum() > 0 else np.ones_like(w)
    return math.sqrt(float(r2 @ wg / wg.sum())), math.sqrt(float(r2.max())) if len(r2) else 0.0


def working_f_number(d, w) -> float:
    """N = 1 / (2 NA), NA the sine of the largest angle between a ray and the mean direction."""
    if len(d) < 2:
        return 0.0
    m = (d * w[:, None]).sum(0) if w.sum() > 0 else d.sum(0)
    m = m / np.linalg.norm(m)
    s = np.sqrt(np.maximum(0.0, 1.0 - (d @ m) ** 2)).max()
    return 1.0 / (2.0 * s) if s > 0 else math.inf


def paraxial(h, d, p, w, axis):
    """Paraxial report of a collimated on-axis beam: (efl, focus point along the axis (a coordinate), f_number).

    h: the rays' heights in the entrance pupil (distance of their start point from the grid's centre); d, p: the
    rays' directions and end points; axis: the unit optical axis (the rays' mean direction after the system).
    sin(u') of each ray (u' its angle to the axis) is fitted as c1 h + c3 h^3 + c5 h^5: EFL = 1 / c1 (the
    paraxial limit h -> 0, also when a central obscuration removes the rays near the axis).  The paraxial focus
    is where the rays cross the axis line in the same limit: z_i = (crossing of ray i) fitted as z0 + a h^2 + b h^4.
    """
    if len(h) < 6 or np.ptp(h) <= 0:
        return None
    sin_u = np.sqrt(np.maximum(0.0, 1.0 - (d @ axis) ** 2))
    hn = h / h.max()
    A = np.column_stack([hn, hn ** 3, hn ** 5])
    c, *_ = np.linalg.lstsq(A, sin_u, rcond=None)
    if not c[0] > 0:
        return None
    efl = h.max() / c[0]
    # the axis line passes through the best-focus centroid: each ray's closest approach to it
    c0 = (p * w[:, None]).sum(0) / w.sum() if w.sum() > 0 else p.mean(0)
    q = p - c0
    t_perp = q - np.outer(q @ axis, axis)
    d_perp = d - np.outer(d @ axis, axis)
    dd = (d_perp * d_perp).sum(1)
    ok = dd > 0
    t = -(t_perp[ok] * d_perp[ok]).sum(1) / dd[ok]
    z = ((q[ok] + t[:, None] * d[ok]) @ axis)
    B = np.column_stack([np.ones(ok.sum()), hn[ok] ** 2, hn[ok] ** 4])
    zc, *_ = np.linalg.lstsq(B, z, rcond=None)
    z0 = float(zc[0] + c0 @ axis)
    return efl, z0, efl / (2 * h.max())


def paraxial_report(eng, step, interp, m, axis) -> None:
    """FOCUS's paraxial report (irtlang/optics/spots.py) for the last TRACE's one on-axis source: EFL, BFL,
    f-number, magnification."""
    last = getattr(eng, "last_trace", None)
    r = eng.result.records
    if last is None or eng.result is None or r.get("start") is None or len(last[0].sources) != 1:
        return
    src = last[0].sources[0]
    if "+" not in src.kind:
        return
    dkind = src.kind.split("+")[1]
    dpar = src.params["direction"]
    g = src.params["grid"]
    if dkind == "FIELD" and (dpar["angle_x"] or dpar["angle_y"]):
        eng.out("FOCUS: no paraxial report for an off-axis field (trace the axial field: SOURCE FIELD 0 0)")
        return
    if dkind == "POSITION" and dpar.get("converge"):
        return
    if dkind == "DIRECTION":   # on axis only: along the grid's axis (no group rotation in between)
        ax_i = "XYZ".index(g["axis"])
        dvec = np.asarray(dpar["direction"], float)
        if src.group is not None or abs(abs(dvec[ax_i]) - 1.0) > 1e-12:
            return
    if dkind not in ("FIELD", "DIRECTION", "POSITION"):
        return
    w = r["flux"][m]
    h = np.hypot(r["start"][m, 0], r["start"][m, 1])
    par = paraxial(h, r["direction"][m], r["position"][m] + (r["position_lo"][m] if r.get("position_lo") is not None
                                                             else 0.0), w, axis)
    if par is None:
        return
    efl, z0, fnum = par
    unit, f = eng._lu()
    # the last surface before the detector: the most frequent second-to-last object of the rays' histories
    hist = r["history"][m]
    if hist.ndim != 2 or hist.shape[1] == 0:
        hist = np.full((len(w), 1), -1)
    nev = (hist != -1).sum(1)
    # the last curved surface the rays met before the detector (a flat window or filter has no power)
    pk = eng.result.packed
    curved = {int(o) for o, k in zip(pk.s_obj, pk.s_kind) if k != 0} if hasattr(pk, "s_kind") else set()
    prev = np.full(len(hist), -1)
    for k in range(hist.shape[1] - 1, -1, -1):
        hk = hist[:, k]
        ok = (prev < 0) & (np.arange(hist.shape[1])[k] < nev - 1) & (hk >= 0) & np.isin(hk // 8, list(curved))
        prev[ok] = hk[ok] // 8
    prev = prev[prev >= 0]
    bfl = None
    if len(prev):
        o = int(np.bincount(prev).argmax())
        fr = detector_frame(eng.result.packed, o)
        if fr is not None:
            bfl = z0 - float(fr[0] @ axis)
            last_name = eng.result.packed.object_names[o]
    real = bfl is None or bfl > 0
    efl_s = efl if real else -efl
    mag, mag_text = 0.0, "0 (object at infinity)"
    if dkind == "POSITION":
        pos = np.array(dpar["point"], float) if "point" in dpar else None
        ax = "XYZ".index(g["axis"])
        if pos is not None and abs(pos[ax] - g["position"]) > 0:
            L = abs(pos[ax] - g["position"])
            # sin u = h / L near the axis; sin u' = h / efl: m = u / u' (negative: a real, inverted image)
            mag = -(efl / L) if real else efl / L
            mag_text = f"{mag:.6g}"
            efl_s, fnum = math.nan, math.nan   # a finite conjugate: the fit gives the image distance's scale
    lines = ["FOCUS paraxial report (rotationally symmetric system, from the rays near the axis):"]
    if dkind != "POSITION":
        lines.append(f"  effective focal length EFL {efl_s / f:.6g} {unit}"
                     + ("" if real else " (negative: a diverging system, the focus is virtual)"))
        lines.append(f"  entrance pupil diameter {2 * h.max() / f:.6g} {unit}: f-number f/{fnum:.4g}")
    if bfl is not None:
        lines.append(f"  back focal length BFL {bfl / f:.6g} {unit} (paraxial focus "
                     f"{'after' if bfl > 0 else 'before'} the vertex of {last_name}, along the light)")
    lines.append(f"  paraxial focus at {'XYZ'[int(np.argmax(np.abs(axis)))]} = {z0 * np.sign(axis[np.argmax(np.abs(axis))]) / f:.9g} {unit}; "
                 f"magnification {mag_text}")
    eng.out("\n".join(lines))
    interp.assign("FOCUS_EFL", Quantity(float(efl_s) if dkind != "POSITION" else 0.0, LENGTH), step.span)
    interp.assign("FOCUS_BFL", Quantity(float(bfl) if bfl is not None else 0.0, LENGTH), step.span)
    interp.assign("FOCUS_FNUM", Quantity(float(fnum) if dkind != "POSITION" else 0.0), step.span)
    interp.assign("FOCUS_MAG", Quantity(float(mag)), step.span)
