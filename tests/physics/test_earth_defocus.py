"""examples_scripts/earth_defocus.inr: the defocus study on Earth frames (issue 15), as identical twins.

The observation is an Earth frame traced camera-side through the Cassegrain with its mirrors 47 um further apart
than the design (a spacing the sweep does not contain) and its own seed; the sweep traces the same frame at
20 .. 80 um by 10 um with another seed.  The fit must find 47 um within 3 of its stated standard uncertainties,
and the uncertainty must be at most 5 um.  The oracle is the spacing the twin was traced at; the refocus is
checked against ORACLES.md's paraxial value in tests/analysis/test_despace.py.

Slow tier: 8 camera-side Earth frames of 256 x 256 pixels (about 6 min on 2 cores).
"""
import json
from pathlib import Path

import pytest

from irtlang.cli import main

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples_scripts" / "earth_defocus.inr"
TRUTH = 47.0


def test_spacing_delta_is_a_default_of_the_earth_script():
    """`irt run examples_scripts/earth.inr --set spacing_delta=40` moves the traced secondary 40 um away from the
    primary (earth_scene.inr's DEFAULT; the design spacing is f1 (1 - k) of cassegrain_design.inr)."""
    from irtlang.lang.interp import check_file

    f1, m, e = 1028.7, 10.207, 300.0
    d0 = f1 * (1 - (f1 + e) / (m * f1 + f1))     # mm
    for sd in (0.0, 40.0):
        it = check_file(ROOT / "examples_scripts" / "earth.inr", ["hours=1", f"spacing_delta={sd}"])
        st = next(s for s in it.steps if s.kind == "TRACE")
        z = st.scene.objects["SECONDARY"].surfaces[0].frame.T[2]      # m: the scene model's canonical unit
        assert z * 1e3 == pytest.approx(d0 + sd * 1e-3, abs=1e-9), sd


def test_an_observation_of_a_later_hour_gets_that_hour(tmp_path):
    """An observed frame of 20:19 UTC (hour 2 of the default day) is traced at its epoch with the generated clouds
    two hours on, as earth.inr traced it; its time comes from the file name."""
    from irtlang.lang.interp import check_file

    obs = tmp_path / "20080318T2019_550nm.npy"
    obs.write_bytes(b"")        # irt check needs the input to exist, not to be read
    it = check_file(SCRIPT, [f"observed='{obs}'", "sweep_last=0"])
    traces = [s for s in it.steps if s.kind == "TRACE"]
    assert len(traces) == 1           # the sweep's one frame (no demo observation)
    assert Path(traces[0].scene.maps["CLOUD_LOW"].path).name == "CLOUD_LOW_T+0002.000H.npy"
    assert it.lookup("EPOCH_UTC") == "2008-03-18T20:19:00"


@pytest.mark.slow
def test_identical_twin_recovers_the_spacing(tmp_path, capsys):
    out = tmp_path / "run"
    sets = [f"demo_spacing={TRUTH}", "demo_seed=11", "sweep_seed=5", "sweep_first=20", "sweep_last=80",
            "sweep_step=10", "spectral_samples=4"]
    argv = ["run", str(SCRIPT), "--out", str(out), "--quiet"]
    for s in sets:
        argv += ["--set", s]
    assert main(argv) == 0, capsys.readouterr().err
    fit = json.loads((out / "despace_fit.json").read_text())
    assert fit["truth_um"] == TRUTH
    assert not fit["at_edge_of_sweep"]
    assert fit["uncertainty_um"] <= 5.0
    assert abs(fit["best_spacing_um"] - TRUTH) <= 3 * fit["uncertainty_um"], fit
    assert [r["spacing_um"] for r in fit["table"]] == [20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0]
    # the seed's maps and the mismatch curve are written
    for name in ("despace_maps.png", "despace_curve.png"):
        assert (out / name).stat().st_size > 20000
    # the sharper frames have steeper edges along the limb (the ESF slope falls with the despace)
    slopes = [r["esf_slope_per_px"] for r in fit["table"]]
    assert slopes[0] > slopes[-1]
