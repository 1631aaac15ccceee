"""The ``PSF`` command and ``EXPORT ... DIFFRACTION``: the engine side of irtlang.optics.diffraction.

``run_psf`` takes the last TRACE's records of the rays of one ``GRID RECT`` source that ended on a detector,
computes each wavelength line's PSF (with the traced wavefront error) and the aberration-free PSF of the same
pupil (amplitudes only), prints the figures of the polychromatic PSF (lines weighted by the detected flux times
the detector's QE: source x filter x optics x QE), sets the variables ``PSF_FWHM``, ``PSF_EE80``, ``PSF_RING``,
``PSF_OUTER`` (lengths, 0 when undefined), ``PSF_STREHL`` and ``PSF_EFL`` and keeps the result in the engine for
``EXPORT obj 'file' DIFFRACTION``.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.diagnostics import RuntimeFailure
from ..core.units import LENGTH, NONE, Quantity
from . import diffraction as D

FL_SCATTERED = 1


class PSFResult:
    def __init__(self, obj, det_index, lines_nm, psfs, perfect, weights, pitch, size):
        self.obj, self.det_index, self.lines_nm = obj, det_index, list(lines_nm)
        self.psfs, self.perfect, self.weights = psfs, perfect, weights   # per line; None where no ray
        self.pitch, self.size = pitch, size
        self._kernels: dict = {}

    def kernel(self, line: int, lam_nm: float, pitch: float, size: int) -> np.ndarray:
        """The aberration-free pixel kernel for a line: the traced pupil's amplitude, no wavefront error (the
        FFT intensity of a pupil without phase does not depend on the wavelength, so a line without rays
        borrows the nearest line's pupil, rescaled)."""
        key = (line, round(lam_nm, 9), pitch, size)
        k = self._kernels.get(key)
        if k is None:
            have = [i for i, p in enumerate(self.perfect) if p is not None]
            j = line if line < len(self.perfect) and self.perfect[line] is not None else \
                min(have, key=lambda i: abs(self.lines_nm[i] - lam_nm))
            p = dataclasses.replace(self.perfect[j], wavelength=lam_nm * 1e-9, _spline=self.perfect[j]._spline)
            k = self._kernels[key] = p.pixelate(pitch, size)
        return k


def _detector_frame(pk, oi):
    """(R, T) of the detector object's first surface: world = R local + T."""
    js = np.nonzero(np.asarray(pk.s_obj) == oi)[0]
    j = int(js[0])
    return np.asarray(pk.s_R[j], float).reshape(3, 3), np.asarray(pk.s_Th[j], float) + np.asarray(pk.s_Tl[j], float)


def _start_path(pk, s, start):
    kind, dk, par = int(pk.src_kind[s]), int(pk.src_dir[s]), np.asarray(pk.src_par[s], float)
    if dk == 0:
        return D.plane_wave_start(start, par[6:9])
    if dk == 3:
        return D.plane_wave_start(start, (math.tan(par[6]), math.tan(par[7]), par[8]))
    if dk in (1, 2):
        return D.point_source_start(start, par[6:9], converge=(dk == 2))
    return None


def run_psf(eng, step, interp):
    eng._need_rays(step, "PSF")
    res, sc = eng.result, eng.scene
    pk = res.packed
    names = list(sc.objects)
    p = step.params
    key = p.get("object")
    if key is None:
        cands = [k for k in names if sc.objects[k].detector is not None and (not eng.consider or k in eng.consider)]
        if len(cands) != 1:
            raise RuntimeFailure(step.span, "PSF: name the detector with ON obj (" +
                                 (f"{len(cands)} objects with a DETECTOR are considered" if cands else
                                  "no object with a DETECTOR is considered") + ")")
        key = cands[0]
    if key not in names:
        raise RuntimeFailure(step.span, f"PSF: object {key} was not part of the last TRACE (CONSIDER)")
    name = sc.objects[key].name
    m = eng._selected(step, "PSF", obj_filter=key)
    r = res.records
    if "opl" not in r or "start" not in r or not hasattr(pk, "src_kind"):
        raise RuntimeFailure(step.span, "PSF needs the ray records of a TRACE (optical paths and pupil positions); "
                                        "rays read by LOAD RAYS do not carry them")
    m &= (r["flags"] & FL_SCATTERED) == 0
    if not m.any():
        raise RuntimeFailure(step.span, f"PSF: no unscattered ray of the last TRACE ended on {name}")
    srcs = np.unique(r["source"][m])
    if len(srcs) != 1 or int(pk.src_kind[srcs[0]]) != 0 or int(pk.src_random[srcs[0]]) == 1:
        raise RuntimeFailure(step.span, "PSF needs the rays of one regular GRID RECT source (the pupil lattice; not "
                                        "RANDOM) with SOURCE DIRECTION, FIELD or POSITION; the last TRACE had "
                                        f"{len(srcs)} source(s) reaching {name}")
    s = int(srcs[0])
    par = np.asarray(pk.src_par[s], float)
    grid = (par[0], par[1], par[2], par[3], int(par[4]), int(par[5]))
    oi = names.index(key)
    R, T = _detector_frame(pk, oi)
    pos = (r["position"][m] - T) @ R            # R^T (p - T), row-wise
    dirs = r["direction"][m] @ R
    start, opl, flux, line = r["start"][m], r["opl"][m], r["flux"][m], r["line"][m]
    det = pk.detector_names.index(name) if name in pk.detector_names else None
    lines_nm = list(pk.lines_nm)
    L = len(lines_nm)
    qe = np.asarray(pk.d_qe[det], float) if det is not None else np.ones(L)
    if det is not None:
        x0, x1, y0, y1 = pk.d_ext[det]
        pitch = float((x1 - x0) / pk.d_nx[det])
    else:
        pitch = None
    size = int(p.get("size") or 65)
    pad = float(p.get("pad") or 8.0)
    p_ref = (pos * flux[:, None]).sum(0) / flux.sum()          # one reference point for every line
    psfs, perfect, weights = [None] * L, [None] * L, np.zeros(L)
    from .diffraction import DiffractionError
    try:
        for k in range(L):
            mk = line == k
            if mk.sum() < 3:
                continue
            sp = _start_path(pk, s, start[mk])
            kw = dict(start_xy=start[mk], opl=opl[mk], pos=pos[mk], dirs=dirs[mk], flux=flux[mk], grid=grid,
                      wavelength=lines_nm[k] * 1e-9, start_path=sp, p_ref=p_ref, pad=pad)
            psfs[k] = D.psf_from_rays(**kw)
            perfect[k] = D.psf_from_rays(**kw, perfect=True)
            weights[k] = flux[mk].sum() * qe[k]
    except DiffractionError as e:
        raise RuntimeFailure(step.span, f"PSF: {e}") from None
    have = [k for k in range(L) if psfs[k] is not None and weights[k] > 0]
    if not have:
        raise RuntimeFailure(step.span, f"PSF: no line has rays (and QE) on {name}")
    ps = [psfs[k] for k in have]
    pf = [perfect[k] for k in have]
    w = weights[have]
    fig = D.fine_figures(ps, w)
    peak0 = float(D.combine_density(pf, w, fig["step"], 41).max())     # the perfect PSF peaks at p_ref
    strehl = fig["peak"] / peak0
    unit, f = eng._lu()
    um = 1e-6
    w_lam = float((w * np.asarray([lines_nm[k] for k in have])).sum() / w.sum())
    opd = float(np.sqrt((w * np.array([psfs[k].opd_rms ** 2 for k in have])).sum() / w.sum()))

    def show(v):
        return "-" if v is None else f"{v / um:.4g} um"
    efl = float(np.average([psfs[k].efl for k in have], weights=w))
    eng.out(f"PSF {name}: {len(have)} line{'s' if len(have) > 1 else ''} "
            f"{lines_nm[have[0]]:g}-{lines_nm[have[-1]]:g} nm (mean {w_lam:.4g} nm, weighted by flux x QE), "
            f"{psfs[have[0]].n_rays:,} rays on a {grid[4]}x{grid[5]} pupil lattice, EFL {efl / f:.6g} {unit}, "
            f"rms wavefront {opd / (w_lam * 1e-9):.3g} waves\n"
            f"  FWHM {show(fig['fwhm'])}, EE80 diameter {show(fig['ee80_diameter'])}, first dark ring "
            f"{show(fig['ring_diameter'])}, outer ring {show(fig['outer_ring_diameter'])}, Strehl {strehl:.4f}")
    for var, v in (("PSF_FWHM", fig["fwhm"]), ("PSF_EE80", fig["ee80_diameter"]), ("PSF_RING", fig["ring_diameter"]),
                   ("PSF_OUTER", fig["outer_ring_diameter"])):
        interp.assign(var, Quantity(v or 0.0, LENGTH), step.span)
    interp.assign("PSF_STREHL", Quantity(strehl, NONE), step.span)
    interp.assign("PSF_EFL", Quantity(efl, LENGTH), step.span)
    pitch_out = pitch if pitch is not None else fig["step"] * 3
    eng.psf = PSFResult(name, det, lines_nm, psfs, perfect, weights, pitch_out, size)
    if p.get("file"):
        img = D.combine_pixels(ps, w, pitch_out, size)
        h = size * pitch_out / 2 / f
        eng._write_image(p["file"], img[None], "psf", extent=(-h, h, -h, h))
        eng.out(f"  PSF {size}x{size} pixels of {pitch_out / um:.4g} um (sum {img.sum():.4f}) -> {p['file']}")


def diffraction_image(eng, step, name, img, img2, pitch):
    """The detector image (L, ny, nx) convolved per line with the last PSF's aberration-free kernel."""
    ps = getattr(eng, "psf", None)
    if ps is None:
        raise RuntimeFailure(step.span, "EXPORT ... DIFFRACTION needs a PSF first (PSF after a TRACE of a GRID RECT)")
    lines_nm = list(eng.result.packed.lines_nm)
    ks = np.array([ps.kernel(k, lam, pitch, ps.size) for k, lam in enumerate(lines_nm)])
    out = D.convolve_lines(img, ks)
    out2 = D.convolve_lines(img2, ks * ks) if img2 is not None else None
    return out, out2, float(ks.sum(axis=(1, 2)).mean())
