"""Regenerate the small input files the examples in docs/language.md use (run from anywhere).

    python docs/examples/make_fixtures.py

water.csv      wavelength_nm, n, k of water (a smooth stand-in, 200-3000 nm)
grass.csv      wavelength_nm, reflectance of grass (a smooth stand-in, 200-3000 nm)
blue.csv       wavelength_nm, transmission of a blue filter (a smooth stand-in, 200-3000 nm)
landcover.npy  a 90 x 180 LATLON class map (uint8, classes 0..4: water forest grass desert snow)
clouds.npy     a 90 x 180 LATLON fraction map (float16 in [0, 1])
baffle.stl     a 20 x 20 x 40 box, ASCII STL (made with trimesh)
run.h5         an empty ray file in the docs/rayfile.md schema (for LOAD RAYS)
telescope.inr  a script that the INCLUDE examples include
spectra/       three disk spectra <YYYYmmddTHHMM>.csv, an hour apart (for ANALYZE SERIES)
rgb/           three 16 x 16 PNG frames (for ANALYZE ANIMATE)
"""
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def main() -> None:
    w = np.arange(200.0, 3001.0, 200.0)
    n = 1.34 - 0.01 * (w - 200.0) / 2800.0
    k = 1e-9 * (w / 200.0) ** 3
    with open(HERE / "water.csv", "w") as f:
        f.write("# a smooth stand-in for water, not measured data\nwavelength_nm,n,k\n")
        for row in zip(w, n, k):
            f.write("%g,%.5f,%.3e\n" % row)
    refl = np.where(w < 700.0, 0.05, 0.45)
    with open(HERE / "grass.csv", "w") as f:
        f.write("# a stand-in for the reflectance of grass, not measured data\nwavelength_nm,value\n")
        for row in zip(w, refl):
            f.write("%g,%.3f\n" % row)
    wb = np.arange(200.0, 3001.0, 50.0)
    blue = np.clip(1.0 - np.abs(wb - 450.0) / 100.0, 0.0, 1.0) * 0.9
    with open(HERE / "blue.csv", "w") as f:
        f.write("# a stand-in for a blue band-pass filter, not measured data\nwavelength_nm,value\n")
        for row in zip(wb, blue):
            f.write("%g,%.3f\n" % row)

    lat = np.linspace(89.0, -89.0, 90)[:, None]
    lon = np.linspace(-179.0, 179.0, 180)[None, :]
    cls = np.where(np.abs(lat) > 70, 4, np.where(np.sin(np.radians(3 * lon)) > 0.3, 1 + (np.abs(lat) > 25) + (np.abs(lat) > 45), 0))
    np.save(HERE / "landcover.npy", cls.astype(np.uint8))
    frac = 0.5 + 0.5 * np.cos(np.radians(2 * lat)) * np.cos(np.radians(lon))
    np.save(HERE / "clouds.npy", np.clip(frac, 0.0, 1.0).astype(np.float16))

    import trimesh

    box = trimesh.creation.box(extents=(20.0, 20.0, 40.0))
    (HERE / "baffle.stl").write_bytes(trimesh.exchange.stl.export_stl_ascii(box).encode())

    import h5py

    with h5py.File(HERE / "run.h5", "w") as f:
        f.attrs.update({"schema": "irtlang-rays", "schema_version": 1, "irtlang_version": "0.1.0",
                        "script_sha256": "", "seed": 0, "length_unit": "mm", "flux_unit": "W",
                        "data_tier": "none", "rays_traced": 0, "created_utc": "2024-01-01T00:00:00Z"})
        f["wavelengths_nm"] = np.array([550.0])
        f.create_dataset("objects", (0,), dtype=h5py.string_dtype())
        g = f.create_group("rays")
        g["position"] = np.zeros((0, 3))
        g["direction"] = np.zeros((0, 3))
        g["flux"] = np.zeros(0)
        for name in ("line", "source", "object", "events"):
            g[name] = np.zeros(0, np.int32)
        g["flags"] = np.zeros(0, np.uint32)
        g["history"] = np.zeros((0, 1), np.int32)

    (HERE / "telescope.inr").write_text(
        "!! telescope.inr: included by the INCLUDE examples of docs/language.md\n"
        "!! (its own inputs would be found next to this file)\n"
        "focal_length = 10500\n"
        "PRINT 'telescope.inr: focal length {focal_length} mm'\n")

    series_and_frames()


def series_and_frames() -> None:
    """The inputs of the ANALYZE SERIES and ANIMATE examples (scripts that pass irt check also run)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    (HERE / "spectra").mkdir(exist_ok=True)
    w = np.array([450.0, 550.0, 650.0])
    for h in range(3):
        with open(HERE / "spectra" / f"20080318T{18 + h:02d}19.csv", "w") as f:
            f.write("wavelength_nm,flux_W,stderr_W\n")
            for lam, fl in zip(w, (1.0 + 0.1 * h) * np.array([2.0e-9, 1.8e-9, 1.5e-9])):
                f.write(f"{lam:g},{float(fl)!r},{float(0.01 * fl)!r}\n")
    (HERE / "rgb").mkdir(exist_ok=True)
    y, x = np.mgrid[0:16, 0:16] / 15.0
    for k in range(3):
        img = np.stack([x, y, np.full_like(x, k / 2.0)], axis=-1)
        plt.imsave(HERE / "rgb" / f"frame_{k:02d}.png", img)


if __name__ == "__main__":
    main()
