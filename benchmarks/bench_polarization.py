"""The cost of POLARIZATION: the same scene traced scalar and polarized, in one process.

Run: ``python -m benchmarks.bench_polarization [--rays N] [--repeat K] [--quick]`` (also part of
``python -m benchmarks``).

Scenes (the polarization tests' own, tests/physics/test_polarization.py):
* a Rayleigh layer (optical depth 0.5) over a Lambertian ground of albedo 0.25, every volume and ground
  scattering sending a ray toward a far eye (mu0 0.92, mu 0.64, phi 90 deg): volume scattering with the Mueller
  matrix, its azimuth drawn from the polarized density, rays toward the eye rotated into its frame;
* a glass plate tilted at 40 deg, a beam split by Fresnel onto two detectors (interfaces only);
* the Earth: the first frame's forward trace of examples_scripts/earth.inr (800 Sun rays per line, 295 lines),
  scalar and with ``--set polarization=1`` (Stokes vectors through the 30 refracting shells, the Rayleigh slabs,
  the glint and the telescope; the fpa's Stokes maps on its 128 x 128 grid).  Each run is run_trace alone
  (pack, trace, reduction), the scene's models packed once before;
* camera-side Stokes images: examples_scripts/camera_cassegrain.inr (the glint ocean under a Rayleigh slab,
  through a quarter-wave retarder), ``TRACE CAMERA ... STOKES`` (six traces behind analyzers) against the plain
  polarized camera trace (I only), the whole ``irt run`` timed, with the images' median standard errors.
Ratio: the polarized trace's time over the scalar trace's (best of the repeats, kernels compiled first).  The
polarized layer's I also differs from the scalar one: the scalar code's error at that geometry is reported
(ORACLES.md: up to about 10 % on the tables' grid).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests" / "physics"))

CASE = (0.25, 0.92, 0.64, 90, True)

PLATE = """UNITS MM
WAVELENGTHS 550 NM
SEED 2
MEDIUM glass INDEX 1.5
SURFACE
  PLANE Z 0 RECT 20 20
OBJECT face
  INTERFACE TRANSMIT glass AIR
  ROTATE Y 40
SURFACE
  PLANE X 30 RECT 60 60
OBJECT rdet
  INTERFACE ABSORB
  DETECTOR PIXELS 16
SURFACE
  PLANE Z -10 RECT 40 40
OBJECT tdet
  INTERFACE ABSORB
  DETECTOR PIXELS 16
  ROTATE Y 40
GRID RECT Z 50 -1 1 -1 1 {n} 1 RANDOM
SOURCE DIRECTION 0 0 -1
FLUX TOTAL 1 W
TRACE
"""


def _scene(text: str):
    from irtlang.lang.interp import Interpreter

    it = Interpreter(check_only=True)
    it.run_text(text)
    assert not it.diags, it.diags.items
    st = [s for s in it.steps if s.kind == "TRACE"][-1]
    return st.scene, st.params


def _earth_scene(polarized: bool, sun_rays: int = 800):
    """The first TRACE (the forward one) of one Earth frame."""
    from irtlang.lang.interp import check_file

    it = check_file(HERE.parent / "examples_scripts" / "earth.inr",
                    ("hours=1", f"sun_rays={sun_rays}", "save_rays=0", f"polarization={int(polarized)}"))
    st = next(s for s in it.steps if s.kind == "TRACE" and not s.params.get("camera"))
    return st.scene, st.params


def _timed(text):
    from irtlang.tracer import Progress, run_trace

    scene, p = _scene(text) if isinstance(text, str) else text
    t0 = time.perf_counter()
    res = run_trace(scene, seed=scene.seed, level=p["level"], halt=p["halt"], progress=Progress(0, enabled=False))
    return res, time.perf_counter() - t0


def _camera(stokes: bool, rays: int = 16):
    """(seconds, median over the lit pixels of the standard errors of I, and of Q, U, V if any, over I)."""
    import tempfile

    import numpy as np

    from irtlang.cli import main

    out = Path(tempfile.mkdtemp()) / "run"
    args = ["run", str(HERE.parent / "examples_scripts" / "camera_cassegrain.inr"), "--out", str(out), "--quiet"]
    for kv in ("scene='slab'", "retarder=30", f"camera_rays={rays}", f"stokes={int(stokes)}", "polarized=1"):
        args += ["--set", kv]
    t0 = time.perf_counter()
    assert main(args) == 0
    t = time.perf_counter() - t0
    i = np.load(out / ("image_I.npy" if stokes else "image.npy"))
    lit = i > 0.05 * i.max()
    comps = "IQUV" if stokes else "I"
    se = {k: float(np.median(np.load(out / (f"image_{k}.stderr.npy" if stokes else "image.stderr.npy"))[lit]
                             / i[lit])) for k in comps}
    return t, se


def _texts(n_layer: int, n_plate: int):
    import test_polarization as T

    layer = T.layer_script(*CASE[:4], CASE[4], n_layer)
    plate = PLATE.format(n=n_plate)
    return {"layer": (layer.replace("POLARIZATION\n", ""), layer),
            "plate": (plate, plate.replace("SEED 2\n", "SEED 2\nPOLARIZATION\n"))}


def run(n_layer: int = 2_000_000, n_plate: int = 4_000_000, repeat: int = 3, quick: bool = False) -> dict:
    import test_polarization as T

    if quick:
        n_layer, n_plate, repeat = 200_000, 400_000, 1
    small = _texts(2000, 2000)
    for a, b in small.values():           # compile every kernel first
        _timed(a)
        _timed(b)
    out = {"n_layer": n_layer, "n_plate": n_plate}
    for name, (scalar, polar) in _texts(n_layer, n_plate).items():
        ts = min(_timed(scalar)[1] for _ in range(repeat))
        runs = [_timed(polar) for _ in range(repeat)]
        tp = min(t for _, t in runs)
        out[name] = {"scalar_s": ts, "polar_s": tp, "ratio": tp / ts}
        if name == "layer":
            albedo, mu0, mu, phi, up = CASE
            ref = T.cds_table("I", "UP")[(albedo, mu0, mu)][[0, 30, 60, 90, 120, 150, 180].index(phi)]
            (i, *_), (si, *_) = T.eye_stokes(runs[0][0], mu0, mu)
            res_s, _t = _timed(scalar)
            f, se = res_s.flux_on([n.upper() for n in res_s.rows].index("EYE"))
            k = math.pi * mu0 / (mu * T.OMEGA)
            out[name].update(table=ref, polar_I=i, polar_se=si, scalar_I=f * k, scalar_se=se * k)
    if not quick:
        earth = {pol: _earth_scene(pol) for pol in (False, True)}
        for pol in (False, True):       # untimed: compile, and pack the Earth's models once
            _timed(earth[pol])
        ts = min(_timed(earth[False])[1] for _ in range(repeat))
        runs = [_timed(earth[True]) for _ in range(repeat)]
        tp = min(t for _, t in runs)
        out["earth"] = {"scalar_s": ts, "polar_s": tp, "ratio": tp / ts, "rays": runs[0][0].n_traced}
        _camera(False, 1)                   # compile
        _camera(True, 1)
        tc, sc = min((_camera(False) for _ in range(repeat)), key=lambda x: x[0])
        ts6, s6 = min((_camera(True) for _ in range(repeat)), key=lambda x: x[0])
        out["camera"] = {"plain_s": tc, "stokes_s": ts6, "ratio": ts6 / tc, "plain_se": sc, "stokes_se": s6}
    return out


def report(r: dict) -> str:
    lay, pl = r["layer"], r["plate"]
    return "\n".join([
        "## Polarization: the cost of POLARIZATION", "",
        "| scene | rays | scalar | polarized | ratio |", "|---|---|---|---|---|",
        f"| Rayleigh layer over ground, rays toward an eye | {r['n_layer']:,} | {lay['scalar_s']:.2f} s | "
        f"{lay['polar_s']:.2f} s | {lay['ratio']:.2f} |",
        f"| glass plate, Fresnel onto two detectors | {r['n_plate']:,} | {pl['scalar_s']:.2f} s | "
        f"{pl['polar_s']:.2f} s | {pl['ratio']:.2f} |"] + ([
        f"| the Earth, one frame's forward trace (earth.inr) | {r['earth']['rays']:,} Sun rays | "
        f"{r['earth']['scalar_s']:.2f} s | "
        f"{r['earth']['polar_s']:.2f} s | {r['earth']['ratio']:.2f} |"] if "earth" in r else []) + ([
        "", "| camera-side (camera_cassegrain.inr, slab, 16 rays per pixel and line) | plain polarized TRACE CAMERA "
        "(I) | TRACE CAMERA ... STOKES (I, Q, U, V) | ratio |", "|---|---|---|---|",
        f"| whole run | {r['camera']['plain_s']:.2f} s | {r['camera']['stokes_s']:.2f} s | "
        f"{r['camera']['ratio']:.2f} |",
        "| median standard error over I, lit pixels | I: " + f"{r['camera']['plain_se']['I']:.3f} | " +
        ", ".join(f"{k}: {v:.3f}" for k, v in r["camera"]["stokes_se"].items()) + " | |"] if "camera" in r else []) + ["",
        f"The layer's I at (albedo 0.25, mu0 0.92, mu 0.64, phi 90): Coulson-Dave-Sekera (Natraj et al. 2009) "
        f"{lay['table']:.5f}; polarized {lay['polar_I']:.5f} +/- {lay['polar_se']:.5f} "
        f"({100 * (lay['polar_I'] / lay['table'] - 1):+.2f} %); scalar {lay['scalar_I']:.5f} +/- "
        f"{lay['scalar_se']:.5f} ({100 * (lay['scalar_I'] / lay['table'] - 1):+.2f} %).", ""])


def readme_rows(r: dict) -> list:
    rows = [("Polarization cost (Rayleigh layer, polarized / scalar time)", f"{r['layer']['ratio']:.2f}x",
             "measured (no target)")]
    if "earth" in r:
        rows.append(("Polarization cost (an Earth frame's forward trace, polarized / scalar)",
                     f"{r['earth']['ratio']:.2f}x", "measured (no target)"))
    return rows


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    print(report(run(repeat=a.repeat, quick=a.quick)))
