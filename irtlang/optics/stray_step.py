"""STATS PATHS: the path report of the selected rays (irtlang/optics/stray.py), its CSV and its layout plot."""
from __future__ import annotations

import numpy as np

from ..core.units import POWER, Quantity
from .stray import path_table


def run_paths(eng, step, interp) -> None:
    from ..core.diagnostics import RuntimeFailure

    m = eng._selected(step, "STATS PATHS")
    r = eng.result.records
    if r.get("history") is None or np.asarray(r["history"]).shape[1:] in ((0,), ()):
        raise RuntimeFailure(step.span, "STATS PATHS needs the rays' histories, which this trace did not keep")
    top = step.params.get("top")
    names = list(eng.result.packed.object_names)
    rows, other, total, total_se, n_paths = path_table(r, m, names, eng.result.n_traced, top)
    kinds = getattr(eng.result, "event_kinds_known", True)
    out = [f"STATS PATHS: {int(m.sum()):,} rays selected, {total:.6g} W +- {total_se:.2g} in {n_paths} paths"]
    if not kinds:
        out.append("  (this ray file holds no event kinds: events are shown as '?')")
    lines = ["rank,path,events,flux_W,stderr_W,fraction"]
    for k, (path, events, flux, se, count, _) in enumerate(rows, 1):
        frac = flux / total if total else 0.0
        out.append(f"  {k:3d}  {flux:12.6g} W +- {se:8.2g}  {frac:7.2%}  {path}  [{events}]  ({count:,} rays)")
        lines.append(f"{k},{_csv(path)},{_csv(events)},{flux!r},{se!r},{frac!r}")
    if other is not None:
        frac = other[2] / total if total else 0.0
        out.append(f"  ...  {other[2]:12.6g} W +- {other[3]:8.2g}  {frac:7.2%}  {other[0]}  ({other[4]:,} rays)")
        lines.append(f"other,{_csv(other[0])},,{other[2]!r},{other[3]!r},{frac!r}")
    lines.append(f"total,,,{total!r},{total_se!r},{1.0 if total else 0.0!r}")
    eng.out("\n".join(out))
    top_flux = rows[0][2] if rows else 0.0
    interp.assign("PATHS_TOP_FLUX", Quantity(top_flux, POWER), step.span)
    interp.assign("PATHS_TOP_FLUX_SE", Quantity(rows[0][3] if rows else 0.0, POWER), step.span)
    interp.assign("PATHS_TOP_FRACTION", Quantity(top_flux / total if total else 0.0), step.span)
    interp.assign("PATHS_TOP", rows[0][0] if rows else "", step.span)
    interp.assign("PATHS_SECOND_FLUX", Quantity(rows[1][2] if len(rows) > 1 else 0.0, POWER), step.span)
    interp.assign("PATHS_SECOND_FLUX_SE", Quantity(rows[1][3] if len(rows) > 1 else 0.0, POWER), step.span)
    interp.assign("PATHS_FLUX", Quantity(total, POWER), step.span)
    interp.assign("PATHS_COUNT", Quantity(float(n_paths)), step.span)
    f = step.params.get("file")
    if f:
        eng._write_text(f, "\n".join(lines) + "\n", "paths")
        plot = f.rsplit(".", 1)[0] + "_layout.png"
        _layout(eng, rows, names, total, plot)


def _csv(text: str) -> str:
    return '"' + text.replace('"', '""') + '"' if ("," in text or '"' in text) else text


def _layout(eng, rows, names, total, rel) -> None:
    """The leading paths (at most 8): their fluxes, and where their rays end in the frame of the object most of
    them end on (the detector).  The records hold each path's end point only (docs/tracer.md), not the points
    between, so the figure shows the footprints, not the paths' segments."""
    from ..io.plots import path_layout
    from .spots import detector_frame, local_xy

    r = eng.result.records
    unit, f = eng._lu()
    objs = r["object"][np.any([row[5] for row in rows[:8]], axis=0)] if rows else np.zeros(0, int)
    det = int(np.bincount(objs[objs >= 0]).argmax()) if (objs >= 0).any() else -1
    frame = detector_frame(eng.result.packed, det) if det >= 0 else None
    shown = []
    for path, events, flux, se, count, mask in rows[:8]:
        pos = r["position"][mask]
        if len(pos) > 3000:
            pos = pos[np.linspace(0, len(pos) - 1, 3000).astype(int)]
        x, y = local_xy(pos, frame)
        ev = events.split(" > ")
        label = " > ".join(f"{o}({e[:1].upper()})" if e and e != "..." else o
                           for o, e in zip(path.split(" > "), ev + [""] * len(path.split(" > "))))
        shown.append((label, flux, flux / total if total else 0.0, x / f, y / f))
    p = eng.folder.output(rel)
    path_layout(p, shown, unit, names[det] if det >= 0 and frame is not None else "the world's x, y")
    eng.folder.record(p, "paths")
