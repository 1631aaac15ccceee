"""Ray-file schema v1: round trip through the reference writer, refusal of other schemas and broken files."""

import h5py
import numpy as np
import pytest

from analysis import AnalysisError, read_rays, write_rays_v1
from analysis.rayfile import FLAGS


def _write(path, n=50, **extra):
    rng = np.random.default_rng(0)
    d = rng.normal(size=(n, 3))
    kwargs = dict(
        wavelengths_nm=[450.0, 550.0, 650.0], objects=["primary", "secondary", "focal_plane"],
        position=rng.normal(size=(n, 3)), direction=d / np.linalg.norm(d, axis=1, keepdims=True),
        flux=rng.uniform(0, 1e-3, n), line=rng.integers(0, 3, n), source=np.zeros(n), object=rng.integers(-1, 3, n),
        events=rng.integers(0, 5, n), flags=rng.integers(0, 64, n), history=rng.integers(-1, 3, (n, 4)),
        detectors={"focal": {"sum": rng.uniform(size=(3, 6, 8)), "sum2": rng.uniform(size=(3, 6, 8)),
                             "x_range": (-1, 1), "y_range": (-0.75, 0.75), "pixel_size": (0.25, 0.25)}},
        length_unit="mm", seed=42, script_sha256="ab" * 32, data_tier="default", rays_traced=1000)
    kwargs.update(extra)
    write_rays_v1(path, **kwargs)
    return kwargs


def test_round_trip(tmp_path):
    path = tmp_path / "run.h5"
    src = _write(path)
    rf = read_rays(path)
    assert rf.attrs["schema"] == "irtlang-rays" and rf.attrs["schema_version"] == 1
    assert rf.attrs["seed"] == 42 and rf.attrs["length_unit"] == "mm" and rf.attrs["flux_unit"] == "W"
    assert rf.objects == src["objects"]
    np.testing.assert_array_equal(rf.wavelengths_nm, src["wavelengths_nm"])
    for col in ("position", "direction", "flux", "line", "object", "events", "flags", "history"):
        np.testing.assert_array_equal(getattr(rf, col), src[col])
    assert rf.line.dtype == np.int32 and rf.flags.dtype == np.uint32
    assert rf.n_rays == 50
    det = rf.detectors["focal"]
    np.testing.assert_array_equal(det.sum, src["detectors"]["focal"]["sum"])
    np.testing.assert_array_equal(det.stderr(), np.sqrt(src["detectors"]["focal"]["sum2"]))
    np.testing.assert_array_equal(det.pixel_size, [0.25, 0.25])
    np.testing.assert_array_equal(rf.has_flag("reflected"), (src["flags"] & FLAGS["reflected"]) != 0)
    assert [p.name for p in tmp_path.iterdir()] == ["run.h5"]


def test_detectors_only(tmp_path):
    path = tmp_path / "img.h5"
    write_rays_v1(path, wavelengths_nm=[550.0], detectors={"d": {"sum": np.ones((1, 2, 2)), "x_range": (0, 1),
                                                                 "y_range": (0, 1), "pixel_size": (0.5, 0.5)}})
    rf = read_rays(path)
    assert rf.n_rays == 0 and rf.position is None
    np.testing.assert_array_equal(rf.detectors["d"].sum2, 0.0)


@pytest.mark.parametrize("key, value, message", [
    ("schema_version", 2, "version 2 is not supported; this reader reads version 1"),
    ("schema", "other-rays", "schema is 'other-rays'"),
])
def test_other_schema_is_refused(tmp_path, key, value, message):
    path = tmp_path / "run.h5"
    _write(path)
    with h5py.File(path, "a") as fh:
        fh.attrs[key] = value
    with pytest.raises(AnalysisError, match=message):
        read_rays(path)


def test_broken_files_are_refused(tmp_path):
    path = tmp_path / "run.h5"
    _write(path)
    with h5py.File(path, "a") as fh:
        del fh["rays/flux"]
        fh["rays/flux"] = np.zeros(49)
    with pytest.raises(AnalysisError, match="/rays/flux has shape"):
        read_rays(path)
    _write(path)
    with h5py.File(path, "a") as fh:
        del fh.attrs["seed"]
    with pytest.raises(AnalysisError, match="missing root attribute"):
        read_rays(path)
    _write(path, line=np.full(50, 7))
    with pytest.raises(AnalysisError, match="wavelength lines"):
        read_rays(path)
    text = tmp_path / "fake.h5"
    text.write_text("not hdf5")
    with pytest.raises(AnalysisError, match="not a readable HDF5 file"):
        read_rays(text)
