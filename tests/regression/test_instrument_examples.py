"""The instrument's example scripts run end to end through the CLI and print the numbers docs/instrument.md
quotes.  telescope_spots.inr is in the fast tier; defocus_study.inr (about 4 minutes on 2 cores) is slow:

    python -m pytest -m slow tests/regression/test_instrument_examples.py
"""
import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest

from irtlang.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples_scripts"


def _run(name, tmp_path, capsys):
    out_dir = tmp_path / name
    code = main(["run", str(EXAMPLES / f"{name}.inr"), "--out", str(out_dir)])
    cap = capsys.readouterr()
    assert code == 0, cap.out + cap.err
    return cap.out, out_dir


def test_telescope_spots(tmp_path, capsys):
    """Nine fields of +-0.045 deg: spot RMS radii 0 (axis), 2.96 (edges), 5.90 um (corners; ORACLES.md 5.9, its
    two digits), the centroids at EFL tan(field) (1e-4), the least-RMS foci toward the secondary; the ledger
    closes to 1e-12; the corner's saved rays give the same RMS radius through `irt analyze psf --rays`."""
    out, d = _run("telescope_spots", tmp_path, capsys)
    spots = re.findall(r"centroid X ([-+0-9.e]+), Y ([-+0-9.e]+) mm; rms radius ([-+0-9.e]+) mm", out)
    assert len(spots) == 9
    rms = sorted(float(s[2]) * 1e3 for s in spots)          # um
    assert rms[0] < 1e-6
    assert rms[1:5] == pytest.approx([2.962] * 4, abs=0.002)
    assert rms[5:] == pytest.approx([5.90] * 4, abs=0.05)
    for x, y, _ in spots:
        for v in (float(x), float(y)):
            assert abs(v) < 1e-12 or abs(v) == pytest.approx(10500.1 * math.tan(math.radians(0.045)), rel=1e-4)
    foci = re.findall(r"FOCUS: best focus ([-+0-9.e]+) mm along -Z", out)
    assert len(foci) == 9 and sum(float(f) < -0.2 for f in foci) == 8
    with open(d / "ledger.csv", newline="") as fh:
        rows = {r["object"]: r for r in csv.DictReader(fh)}
    total = math.fsum(float(r["absorbed_W"]) for r in rows.values())
    emitted = float(rows["EMITTED"]["incident_W"])
    assert abs(total - emitted) <= 1e-12 * emitted
    assert (d / "rays_corner.h5").exists() and (d / "fpa_last_field.fits").exists()
    code = main(["analyze", "psf", "--rays", str(d / "rays_corner.h5"), "--object", "fpa"])
    got = capsys.readouterr().out
    assert code == 0, got
    assert re.search(r"rms_radius", got)
    val = float(re.search(r"rms_radius\W+([-+0-9.e]+)", got).group(1))
    assert val * 1e3 == pytest.approx(5.90, abs=0.05)


@pytest.mark.slow
def test_defocus_study(tmp_path, capsys):
    """The sweep: +55.498 um moves the least-RMS focus 5.772 mm toward the primary (0.7 % short of ORACLES.md's
    paraxial 5.813, tests/physics/test_instrument_defocus.py explains), linear in the spacing to 1 %; the PSFs: in
    focus a flat wavefront (Strehl 1), the broadband (clear) FWHM within 10 % of the seed paper's 17.0 um, the
    defocused EE80 diameter near the geometric blur dz / N = 166 um (the annulus's EE80 is 0.91 of its outer
    diameter, diffraction adds; within 10 %), the pixel PSFs and the convolved images written."""
    out, d = _run("defocus_study", tmp_path, capsys)
    sweep = {float(a): float(b) for a, b in re.findall(r"spacing\s+([-+0-9.]+) um: best focus ([-+0-9.]+) mm", out)}
    assert len(sweep) == 12
    assert sweep[55.498] == pytest.approx(5.772, abs=0.002)
    assert sweep[55.498] == pytest.approx(5.813, rel=0.01)
    slope = np.polyfit(list(sweep), list(sweep.values()), 1)[0] * 1e3        # mm per mm
    assert slope == pytest.approx(10.207 ** 2 + 1, rel=0.02)
    psf = re.findall(r"-> FWHM ([0-9.]+) um, EE80 ([0-9.]+) um, outer ring ([0-9.]+) um, Strehl ([0-9.]+)", out)
    assert len(psf) == 4
    (f550, e550, _, s550), (fd550, ed550, od550, sd550), (fclr, eclr, _, sclr), (fdc, edc, odc, sdc) = \
        [[float(x) for x in p] for p in psf]
    assert s550 == pytest.approx(1.0, abs=1e-3) and sclr == pytest.approx(1.0, abs=1e-3)
    assert fclr == pytest.approx(17.0, rel=0.10)
    assert ed550 == pytest.approx(166, rel=0.10) and edc == pytest.approx(166, rel=0.10)
    assert sd550 < 0.1 and sdc < 0.1
    for tag in ("550_focus", "550_defocus", "clear_focus", "clear_defocus"):
        assert (d / f"psf_{tag}.fits").exists() and (d / f"fpa_{tag}_diffraction.fits").exists()
        head = (d / f"fpa_{tag}_diffraction.fits").read_bytes()[:2880].decode("ascii")
        naxis3 = [head[i + 10:i + 30].strip() for i in range(0, 2880, 80) if head[i:i + 8].strip() == "NAXIS3"]
        assert naxis3 == ["1"]     # EXPORT ... DIFFRACTION SUM: the band's image, not a cube of 15 or 38 lines
