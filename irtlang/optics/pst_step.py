"""PST: point source transmittance, the classic stray-light curve.

The last TRACE's collimated source (a GRID with SOURCE FIELD) is traced again at each off-axis angle of the sweep,
tilted about the grid's local y (AXIS X, the default: angles along local x) or x (AXIS Y), with the same rays, LEVEL
and HALT.  PST(theta) = E_det / E_in: E_det the flux on the detector object over its DETECTOR's area, E_in the
incident irradiance on a plane normal to the beam, P / (A_grid cos theta) (P the source's flux, A_grid the GRID's
area: the grid must cover the entrance aperture at every angle).  The standard error is the flux's (the ledger's
per-source-ray sums) over the same factor.
"""
from __future__ import annotations

import math

from ..core.units import Quantity
from ..model import scene as M


def run_pst(eng, step, interp) -> None:
    from ..core.diagnostics import RuntimeFailure
    from ..tracer import run_trace

    last = getattr(eng, "last_trace", None)
    if last is None:
        raise RuntimeFailure(step.span, "PST has no source to sweep: TRACE a GRID with SOURCE FIELD first")
    sc, tp = last
    fields = [s for s in sc.sources if s.kind.endswith("+FIELD")]
    if len(fields) != 1 or len(sc.sources) != 1:
        raise RuntimeFailure(step.span, "PST sweeps the last TRACE's one source, which must be a GRID with SOURCE "
                             f"FIELD (it traced {len(sc.sources)} source(s): "
                             f"{', '.join(s.kind for s in sc.sources) or 'none'})")
    src = fields[0]
    key = step.params["object"]
    names = list(sc.objects)
    if key not in names:
        raise RuntimeFailure(step.span, f"PST: object {key} was not part of the last TRACE (CONSIDER)")
    obj = sc.objects[key]
    if obj.detector is None:
        raise RuntimeFailure(step.span, f"PST ON {obj.name}: the object needs a DETECTOR (its area is the "
                             "detector's pixel grid)")
    g = src.params["grid"]
    if src.kind.startswith("GRID DISK"):
        a_grid = math.pi * g["radius"] ** 2
    else:
        a_grid = abs((g["x_max"] - g["x_min"]) * (g["y_max"] - g["y_min"])) if "x_max" in g else None
    if not a_grid:
        raise RuntimeFailure(step.span, f"PST: the area of {src.kind.split('+')[0]} is not known")
    a0, a1, n = step.params["first"], step.params["last"], int(step.params["count"])
    angles = [a0 + (a1 - a0) * k / (n - 1) for k in range(n)] if n > 1 else [a0]
    along_y = step.params.get("axis") == "Y"
    oi = names.index(key)
    rows = []
    for th in angles:
        if abs(th) >= math.pi / 2 - 1e-9:
            raise RuntimeFailure(step.span, f"PST angle {math.degrees(th):g} deg: must be within +-90 deg")
        d = {"angle_x": 0.0, "angle_y": th} if along_y else {"angle_x": th, "angle_y": 0.0}
        s2 = M.replace(src, params=M.frozen_params({"grid": g, "direction": d}))
        scn = M.replace(sc, sources=(s2,))
        res = run_trace(scn, seed=scn.seed, level=tp["level"], halt=tp["halt"], records=False, history=False,
                        runner=eng.runner, features=getattr(eng, "last_features", None))
        eng.rays_traced += res.n_traced
        P = float(res.ledger[res.packed.n_rows - 4, 0].sum())
        flux, se = res.flux_on(oi)
        ext = res.packed.d_ext[res.packed.detector_names.index(obj.name)]
        a_det = float(abs((ext[1] - ext[0]) * (ext[3] - ext[2])))
        # tilt of the beam from the grid's axis (FIELD: tan of the angles along x and y)
        cos_t = math.cos(th)
        e_in = P / (a_grid * cos_t) if P > 0 else 0.0
        k = 1.0 / (a_det * e_in) if e_in > 0 else 0.0
        rows.append((float(math.degrees(th)), float(flux * k), float(se) * k, float(flux), float(se)))
    eng.folder.info["rays_traced"] = eng.rays_traced
    lines = ["angle_deg,pst,stderr,flux_W,flux_stderr_W"] + [f"{a!r},{p!r},{e!r},{fl!r},{fe!r}"
                                                              for a, p, e, fl, fe in rows]
    shown = "\n".join(f"  {a:9.4g} deg  PST {p:11.4e} +- {e:9.2e}" for a, p, e, _, _ in rows)
    eng.out(f"PST ON {obj.name} ({len(rows)} angles, {res.n_traced:,} rays each, along local "
            f"{'y' if along_y else 'x'}):\n{shown}")
    best = max(rows, key=lambda r: r[1])
    interp.assign("PST_MAX", Quantity(best[1]), step.span)
    interp.assign("PST_LAST", Quantity(rows[-1][1]), step.span)
    interp.assign("PST_LAST_SE", Quantity(rows[-1][2]), step.span)
    file = step.params.get("file")
    if file:
        eng._write_text(file, "\n".join(lines) + "\n", "pst")
        from ..io.plots import pst_plot

        plot = eng.folder.output(file.rsplit(".", 1)[0] + ".png")
        fld = step.params.get("field")
        pst_plot(plot, [r[0] for r in rows], [r[1] for r in rows], [r[2] for r in rows],
                 field_deg=math.degrees(fld) if fld is not None else None,
                 title=f"point source transmittance on {obj.name}")
        eng.folder.record(plot, "pst")
