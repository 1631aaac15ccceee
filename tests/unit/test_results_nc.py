"""results.nc is written with netCDF4 alone (irtlang.io.results.write_results, no xarray at run time); read back
with xarray it must be the Dataset that ``build_dataset`` makes from the same results: every variable,
coordinate (dimension, auxiliary and scalar), dtype, value and attribute.  (A format check against xarray's own
reading, not physics.)"""
import numpy as np
import pytest

from irtlang.io.results import ResultsCollector, build_dataset, write_results

xr = pytest.importorskip("xarray")

INFO = {"irtlang_version": "0.test", "script": "s.inr", "script_sha256": "ab", "seed": 7, "data_tier": "default",
        "rays_traced": 123, "started_utc": "2026-12-02T00:00:00Z"}


def _collector(tmp_path, frames, epochs=True, spill=False):
    rng = np.random.default_rng(3)
    col = ResultsCollector(tmp_path / "spill" if spill else None)
    for f in range(frames):
        col.new_frame(f"2008-03-18T{18 + f:02d}:19:00" if epochs else None, 1000 + f)
        col.add_image(name="fpa", kind="image", img=rng.random((3, 4, 5)), se=rng.random((3, 4, 5)),
                      extent_mm=(-1, 1, -0.8, 0.8), lines_nm=(450, 550, 650), focal_m=2.0, file=f"fpa_{f}.npy")
        col.add_image(name="fpa", kind="image", img=rng.random((2, 4, 5)), se=None, extent_mm=(-1, 1, -0.8, 0.8),
                      bands=("blue", "red"), band_nm=(451.5, 649.0), focal_m=2.0, file=f"fpa_b_{f}.fits")
        col.add_spectrum("pupil", (450, 550, 650), rng.random(3), rng.random(3), file="spec.csv")
        col.add_ledger(("M1", "EMITTED"), rng.random((2, 5)), rng.random(2), file="ledger.csv")
    col.add_image(name="spots", kind="spots", img=rng.random((1, 6, 6)), se=None, extent_mm=(-0.1, 0.1, -0.1, 0.1),
                  coord_unit="1")
    return col


@pytest.mark.parametrize("frames,epochs,spill", [(1, True, False), (3, True, True), (2, False, False)])
def test_written_file_reads_back_as_the_dataset(tmp_path, frames, epochs, spill):
    col = _collector(tmp_path, frames, epochs, spill)
    p = write_results(col, INFO, tmp_path / "results.nc")
    want = build_dataset(col, INFO)
    with xr.open_dataset(p) as got:
        got = got.load()
    assert set(got.coords) == set(want.coords) and set(got.data_vars) == set(want.data_vars)
    for name in list(want.coords) + list(want.data_vars):
        a, b = got[name], want[name]
        assert a.dims == b.dims, name
        assert a.dtype == b.dtype or (a.dtype.kind in "OU" and b.dtype.kind in "OU"), (name, a.dtype, b.dtype)
        assert a.attrs == b.attrs, (name, a.attrs, b.attrs)
        if b.dtype.kind in "OU":
            assert [str(x) for x in np.ravel(a.values)] == [str(x) for x in np.ravel(b.values)], name
        else:
            np.testing.assert_array_equal(a.values, b.values, err_msg=name)
    assert got.attrs == want.attrs
    if frames > 1 and epochs:
        assert got["time"].dims == ("time",) and got["frame"].dims == ("time",)


def test_writing_does_not_import_xarray(tmp_path):
    import subprocess
    import sys

    code = ("import sys, numpy as np\n"
            "from irtlang.io.results import ResultsCollector, write_results\n"
            "c = ResultsCollector()\nc.new_frame('2008-03-18T18:19:00', 10)\n"
            "c.add_image(name='fpa', kind='image', img=np.ones((1, 2, 2)), se=None, extent_mm=(0, 1, 0, 1))\n"
            f"write_results(c, {{}}, {str(tmp_path / 'r.nc')!r})\n"
            "print(sorted(m for m in ('xarray', 'dask', 'distributed') if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_one_object_spectra_from_two_folders(tmp_path):
    """The flagship writes the pupil's spectrum every hour to spectra/ (the camera-side trace) and in the first
    hour also to spectra_forward/ (the forward trace): two variables, the hourly one keeping the plain name, not
    one variable per spectrum.  Written and read back as build_dataset makes it."""
    col = ResultsCollector()
    rng = np.random.default_rng(5)
    for f in range(3):
        col.new_frame(f"2008-03-18T{18 + f:02d}:19:00", 10)
        if f == 0:
            col.add_spectrum("pupil", (450, 550), rng.random(2), rng.random(2), file="spectra_forward/a.csv")
        col.add_spectrum("pupil", (450, 550), rng.random(2), rng.random(2), file=f"spectra/{f}.csv")
    want = build_dataset(col, INFO)
    assert want["spectrum_pupil"].dims == ("time", "wavelength")
    assert want["spectrum_pupil"].shape == (3, 2)
    assert want["spectrum_pupil_spectra_forward"].shape == (2,)
    p = write_results(col, INFO, tmp_path / "results.nc")
    with xr.open_dataset(p) as got:
        assert set(got.data_vars) == set(want.data_vars)
        np.testing.assert_array_equal(got["spectrum_pupil"].values, want["spectrum_pupil"].values)
