"""SPOTS DIAGRAM: spot diagrams per field and wavelength, and through focus (irtlang/optics/spots.py has the
definitions: detector frame, reference point, RMS / GEO radius, Airy radius)."""
from __future__ import annotations

import math

import numpy as np

from ..core.units import LENGTH, POWER, Quantity
from ..model import scene as M
from .spots import detector_frame, local_xy, reference, spot_stats, working_f_number


def _field_results(eng, step):
    """[(field label, (fx, fy) deg or None, result)]: the 3 x 3 field grid traced again, or the current rays."""
    from ..core.diagnostics import RuntimeFailure
    from ..tracer import run_trace

    fields = step.params.get("fields")
    if fields is None:
        eng._need_rays(step, "SPOTS DIAGRAM")
        return [("", None, eng.result)]
    last = getattr(eng, "last_trace", None)
    srcs = last[0].sources if last is not None else ()
    if len(srcs) != 1 or not srcs[0].kind.endswith("+FIELD"):
        raise RuntimeFailure(step.span, "SPOTS DIAGRAM ... FIELDS traces the last TRACE's one GRID + SOURCE FIELD "
                             "again over the field grid: TRACE such a source first")
    sc, tp = last
    src = srcs[0]
    hx, hy = fields
    out = []
    for fy in (hy, 0.0, -hy):           # rows from +y down, as the sky looks on a plot
        for fx in (-hx, 0.0, hx):
            s2 = M.replace(src, params=M.frozen_params({"grid": src.params["grid"],
                                                        "direction": {"angle_x": fx, "angle_y": fy}}))
            res = run_trace(M.replace(sc, sources=(s2,)), seed=sc.seed, level=tp["level"], halt=tp["halt"],
                            records=True, history=eng.need_history or eng.predicate is not None, runner=eng.runner,
                            features=getattr(eng, "last_features", None))
            eng.rays_traced += res.n_traced
            out.append((f"field ({math.degrees(fx):+.4g}, {math.degrees(fy):+.4g}) deg",
                        (math.degrees(fx), math.degrees(fy)), res))
    eng.folder.info["rays_traced"] = eng.rays_traced
    return out


def run_spot_diagram(eng, step, interp) -> None:
    from ..core.diagnostics import RuntimeFailure
    from ..io.plots import spot_diagram

    saved = eng.result
    about = step.params.get("about") or "CENTROID"
    through, steps = step.params.get("through"), step.params.get("steps")
    shifts = [float(v) for v in np.linspace(-through, through, steps)] if through else [0.0]
    unit, f = eng._lu()
    panels, rows_csv, summary = [], [], []
    lines_nm = None
    try:
        for label, fxy, res in _field_results(eng, step):
            eng.result = res
            m = eng._selected(step, "SPOTS DIAGRAM")
            r = res.records
            lines_nm = list(res.packed.lines_nm)
            if not m.any():
                raise RuntimeFailure(step.span, f"SPOTS DIAGRAM: no selected rays reached a surface ({label or 'rays'})")
            objs = r["object"][m]
            det = int(np.bincount(objs[objs >= 0]).argmax()) if (objs >= 0).any() else -1
            frame = detector_frame(res.packed, det) if det >= 0 else None
            ref0, rel = eng._rel_positions(m)
            pos = rel + ref0
            d, w, line = r["direction"][m], r["flux"][m], r["line"][m]
            start = r.get("start")
            start = start[m] if start is not None else None
            normal = frame[3] if frame is not None else np.eye(3)[int(np.argmax(np.abs(d.mean(0))))]
            dn = d @ normal
            N = working_f_number(d, w)
            airy = np.array([1.22 * lam * 1e-9 * N for lam in lines_nm]) if math.isfinite(N) else None
            groups = [(q, line == q) for q in range(len(lines_nm)) if (line == q).any()]
            per_line = len(lines_nm) > 1 and not through
            for dz in shifts:
                p = pos + ((dz / np.where(dn != 0, dn, np.inf))[:, None] * d if dz else 0.0)
                x, y = local_xy(p, frame)
                x0, y0 = reference(x, y, w, start, about)
                xu, yu = (x - x0) * 1e6, (y - y0) * 1e6
                sets = ([(lines_nm[q], g) for q, g in groups] if per_line else []) + [("all", np.ones(len(x), bool))]
                for lam, g in sets:
                    rms, geo = spot_stats(xu[g], yu[g], w[g])
                    sub = ", ".join(x for x in (label, "" if lam == "all" or not per_line else f"{lam:g} nm",
                                                f"focus {dz / f:+.4g} {unit}" if through else "") if x)
                    panels.append({"x_um": xu[g], "y_um": yu[g], "line": line[g], "lines_nm": lines_nm,
                                   "label": sub or "spot", "rms_um": rms, "geo_um": geo})
                    a_um = (float(airy[lines_nm.index(lam)]) * 1e6 if lam != "all" else float(airy.max()) * 1e6) \
                        if airy is not None else 0.0
                    rows_csv.append((fxy, lam, dz / f, int(g.sum()), float(w[g].sum()), x0 / f, y0 / f, rms, geo, a_um))
                    summary.append((label, lam, dz, rms, geo, float(w[g].sum()), fxy))
    finally:
        eng.result = saved
    ncols = len(shifts) if through else (len(lines_nm) + 1 if len(lines_nm) > 1 else 3 if step.params.get("fields") else 1)
    nrows = math.ceil(len(panels) / ncols)
    scale = step.params.get("scale")
    geo_max = max(pn["geo_um"] for pn in panels)
    airy_um = (airy * 1e6) if airy is not None else None
    half = scale * 1e6 if scale else 1.1 * max(geo_max, float(airy_um.max()) if airy_um is not None else 0.0, 1e-6)
    title = (f"spot diagrams about the {'chief ray' if about == 'CHIEF' else 'centroid'}, detector frame; "
             f"circle: Airy radius 1.22 lambda N (N = {N:.3g})" if airy_um is not None else "")
    spot_diagram(eng.folder.output(step.params["file"]), panels, nrows=nrows, ncols=ncols, scale_um=half,
                 airy_um=airy_um, title=title)
    eng.folder.record(eng.folder.output(step.params["file"]), "spots")
    csv_rel = step.params["file"].rsplit(".", 1)[0] + ".csv"
    text = [f"field_x_deg,field_y_deg,wavelength_nm,focus_shift_{unit},rays,flux_W,ref_x_{unit},ref_y_{unit},"
            "rms_um,geo_um,airy_um"]
    for fxy, lam, dz, n, fl, x0, y0, rms, geo, a in rows_csv:
        fx, fy = fxy if fxy is not None else ("", "")
        text.append(f"{fx},{fy},{lam},{dz!r},{n},{fl!r},{x0!r},{y0!r},{rms!r},{geo!r},{a!r}")
    eng._write_text(csv_rel, "\n".join(text) + "\n", "spots")
    poly = [s for s in summary if s[1] == "all" and abs(s[2]) == min(abs(t[2]) for t in summary)]
    shown = "\n".join(f"  {s[0] or 'spot'}: RMS {s[3]:.4g} um, GEO {s[4]:.4g} um, {s[5]:.6g} W" for s in poly)
    eng.out(f"SPOTS DIAGRAM ({about.lower()} reference, {len(panels)} panels) -> {step.params['file']}:\n{shown}")
    axis_rms = next((s[3] for s in poly if s[6] is not None and s[6] == (0.0, 0.0)), poly[len(poly) // 2][3])
    interp.assign("SPOTS_RMS", Quantity(max(s[3] for s in poly) * 1e-6, LENGTH), step.span)
    interp.assign("SPOTS_GEO", Quantity(max(s[4] for s in poly) * 1e-6, LENGTH), step.span)
    interp.assign("SPOTS_RMS_AXIS", Quantity(axis_rms * 1e-6, LENGTH), step.span)
    interp.assign("SPOTS_FLUX", Quantity(poly[0][5], POWER), step.span)
