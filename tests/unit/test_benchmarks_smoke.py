"""The benchmark modules import, their pure helpers hold, and `python -m benchmarks --quick` writes a report
(a tiny configuration: the Earth hook only; no speed is asserted anywhere)."""
import importlib
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))   # benchmarks/ is a folder of the repository, not packaged
from benchmarks import __main__ as bench_main  # noqa: E402
from benchmarks._common import time_to_error  # noqa: E402


@pytest.mark.parametrize("name", bench_main.MODULES)
def test_every_benchmark_module_imports_and_has_run_and_report(name):
    mod = importlib.import_module(f"benchmarks.{name}")
    assert callable(mod.run) and callable(mod.report)


def test_time_to_error_interpolates_and_extrapolates():
    t, how = time_to_error([(1.0, 0.04), (4.0, 0.02), (16.0, 0.005)], 0.01)
    assert how == "measured" and 4.0 < t < 16.0
    # log-log interpolation: 0.02 -> 0.005 over 4 -> 16 s is a slope of -1, so 1 % at 8 s
    assert t == pytest.approx(8.0)
    t, how = time_to_error([(1.0, 0.04), (4.0, 0.02)], 0.01)
    assert how == "extrapolated" and t == pytest.approx(16.0)
    # a run below the target followed by one above it does not count: the series must stay below
    t, how = time_to_error([(1.0, 0.005), (2.0, 0.02), (4.0, 0.008)], 0.01)
    assert how == "measured" and 2.0 < t < 4.0


def test_lambert_sphere_reference_image_integrates_to_the_oracle():
    from benchmarks import bench_mitsuba as bm

    fo, fd = bm.oracle_flux(), bm.finite_distance_flux(200)
    assert fd / fo - 1 == pytest.approx(2.75e-4, abs=2e-5)       # the finite-distance term at D = 1000 R
    for dirs in (bm.irt_dirs, bm.mi_dirs):
        img = bm.analytic(48, dirs, ss=4, ss_edge=16)
        assert abs((img * bm.pixel_solid_angle(48)).sum() / fd - 1) < 1e-3
    # the two cameras see the same image, mirrored left to right
    a, b = bm.analytic(32, bm.irt_dirs, 4, 8), bm.analytic(32, bm.mi_dirs, 4, 8)
    assert np.abs(a - b[:, ::-1]).max() < 1e-9
    assert bm.phi(math.radians(57.7)) == pytest.approx(0.63212, abs=1e-5)


def test_quick_run_writes_a_report_and_leaves_the_readme_alone(tmp_path):
    readme = bench_main.HERE.parent / "README.md"
    before = readme.read_text() if readme.exists() else None
    assert bench_main.main(["--quick", "--only", "bench_earth", "--out", str(tmp_path), "--no-readme"]) == 0
    text = (tmp_path / "REPORT.md").read_text()
    assert "# Benchmarks" in text and "## The Earth (benchmarks/bench_earth.py)" in text and "peers:" in text
    assert (readme.read_text() if readme.exists() else None) == before


def test_startup_import_table_parser():
    from benchmarks.bench_startup import top_imports

    err = ("import time: self [us] | cumulative | imported package\n"
           "import time:       100 |       2000 |   numpy.core\n"
           "import time:       300 |       5000 | numpy\n"
           "import time:       200 |       9000 | matplotlib.pyplot\n")
    assert top_imports(err, 2) == [("matplotlib.pyplot", 9.0), ("numpy", 5.0)]


def test_first_run_benchmark_lists_the_runnable_examples():
    """bench_startup --examples times the examples a user runs: not the files other scripts include (the
    instrument's parts), nor the bare mirrors that only tests include; each listed one checks cleanly."""
    from benchmarks.bench_startup import runnable_examples
    from irtlang.lang.interp import check_file

    names = {f.stem for f in runnable_examples()}
    assert {"earth", "telescope_spots", "stray_hri_pst", "ghost_reload"} <= names
    assert not names & {"cassegrain", "cassegrain_design", "cassegrain_optics", "earth_scene"}
    for f in runnable_examples():
        if f.stem not in ("earth", "earth_defocus"):      # (their checks load the Earth's data: seconds)
            assert not check_file(f, ()).diags.items, f.name
