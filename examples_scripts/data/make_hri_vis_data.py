"""Writes the HRI-VIS filter and CCD quantum-efficiency tables that examples_scripts/cassegrain.inr reads.

Run: ``python examples_scripts/data/make_hri_vis_data.py`` (rewrites the .csv files beside this script).

THESE ARE MODELS, NOT MEASURED CURVES.  What is known about the real filters (PDS catalog file HRIV.CAT of the
Deep Impact / EPOXI archive, after Hampton et al. 2005, Space Sci. Rev. 117, 43-93): five filters are "roughly
100 nanometers in bandwidth, centered at 450, 550, 650, 750 and 850 nanometers"; the 350 nm filter "is
effectively a short-wavelength pass filter starting at 400 nanometers and limited to about 340 nanometers on
the short end by the rapid decline in beamsplitter reflectivity"; the 950 nm filter "is actually a long-pass
filter starting at 900 nanometers" (limited at the long end by the dichroic beam splitter, whose transmission
and reflection are equal at about 1.05 um, and by the silicon CCD).  The model below encodes exactly that and
nothing more:

    T(lambda) = T_peak * s((lambda - lo) / w) * s((hi - lambda) / w),    s(x) = 1 / (1 + exp(-x))

with 50 % points ``lo`` and ``hi`` (so the FWHM is hi - lo to within 0.1 nm), edge scale w = 5 nm (10-90 %
rise over 4.39 w = 22 nm, typical of interference filters) and T_peak = 0.90 (an assumed in-band transmission):

    band  350: lo 340, hi 400 (FWHM  60 nm; the dichroic's UV cut-off and the 400 nm short-pass edge)
    band  450 ... 850: lo = centre - 50, hi = centre + 50 (FWHM 100 nm)
    band  950: lo 900, hi 1050 (FWHM 150 nm; the 900 nm long-pass edge and the dichroic at 1.05 um)

The dichroic beam splitter itself is not modelled elsewhere: its two edges are folded into bands 350 and 950.
``band = 'clear'`` (one of the wheel's two clear apertures) is the dichroic alone: 50 % points 340 and 1050 nm,
peak 1.0.

CCD quantum efficiency: a generic thinned, back-illuminated silicon CCD with a broadband anti-reflection coating
(the HRI-VIS CCD is a Fairchild 1024 x 1024 split-frame-transfer device; its measured QE is not used here).
Piecewise-linear through the knots below: the blue side limited by surface recombination, the peak near
600 nm, the red fall-off set by silicon's absorption length growing past the ~15 um thick layer, zero at
1100 nm (the silicon band gap).  Model values, labelled as such in docs/instrument.md.
"""
from __future__ import annotations

import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
BANDS = {350: (340.0, 400.0), 450: (400.0, 500.0), 550: (500.0, 600.0), 650: (600.0, 700.0), 750: (700.0, 800.0),
         850: (800.0, 900.0), 950: (900.0, 1050.0), "clear": (340.0, 1050.0)}
T_PEAK = 0.90
PEAK = {"clear": 1.0}
EDGE_NM = 5.0
QE_KNOTS = [(300, 0.10), (350, 0.30), (400, 0.55), (450, 0.70), (500, 0.78), (550, 0.82), (600, 0.84), (650, 0.83),
            (700, 0.80), (750, 0.74), (800, 0.65), (850, 0.52), (900, 0.37), (950, 0.23), (1000, 0.11),
            (1050, 0.03), (1100, 0.0)]
# 290 .. 1100 nm every 2 nm, then to 2600 nm every 20 nm (the filters' far wings and the QE are 0 there): the
# tables cover the Earth script's lines, 300-2500 nm, with their bands' edges
GRID = [290 + 2 * i for i in range(406)] + [1120 + 20 * i for i in range(75)]


def _s(x: float) -> float:
    return 1.0 / (1.0 + math.exp(-x))


def filter_transmission(band: int, lam_nm: float) -> float:
    lo, hi = BANDS[band]
    return PEAK.get(band, T_PEAK) * _s((lam_nm - lo) / EDGE_NM) * _s((hi - lam_nm) / EDGE_NM)


def qe(lam_nm: float) -> float:
    for (x0, y0), (x1, y1) in zip(QE_KNOTS, QE_KNOTS[1:]):
        if x0 <= lam_nm <= x1:
            return y0 + (y1 - y0) * (lam_nm - x0) / (x1 - x0)
    return 0.0


def main() -> None:
    for band in BANDS:
        lo, hi = BANDS[band]
        rows = [f"# HRI-VIS band {band}: MODEL bandpass (see make_hri_vis_data.py), 50% points {lo:g} and "
                f"{hi:g} nm, peak {PEAK.get(band, T_PEAK)}, logistic edges w = {EDGE_NM:g} nm",
                "wavelength_nm,transmission"]
        rows += [f"{x},{filter_transmission(band, x):.6f}" for x in GRID]
        (HERE / f"hri_vis_filter_{band}.csv").write_text("\n".join(rows) + "\n")
    rows = ["# CCD quantum efficiency: MODEL of a thinned back-illuminated silicon CCD (see make_hri_vis_data.py)",
            "wavelength_nm,qe"] + [f"{x},{qe(x):.6f}" for x in GRID]
    (HERE / "ccd_qe_model.csv").write_text("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
