"""Every example script runs through the CLI (in-process), exits 0, closes its energy ledger to 1e-12 and
reproduces at least one physical number that was worked out independently (see each script's header)."""
import csv
import math
import re
from pathlib import Path

import pytest

from irtlang.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples_scripts"
MINE = ["singlet_spot", "glass_plate", "prism_tir", "paraboloid_focus", "mesh_object", "adjoint_sphere",
        "polarization_bench", "polarized_planet"]


SETTINGS = {"polarized_planet": ["--set", "rays=400000"]}      # a shorter run than the script's default


def run_example(name, tmp_path, capsys):
    out_dir = tmp_path / name
    code = main(["run", str(EXAMPLES / f"{name}.inr"), "--out", str(out_dir)] + SETTINGS.get(name, []))
    cap = capsys.readouterr()
    assert code == 0, cap.out + cap.err
    return cap.out, out_dir


def read_ledger(path):
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["object", "incident_W", "reflected_W", "transmitted_W", "scattered_W", "absorbed_W"]
    return {r["object"]: {k: float(v) for k, v in r.items() if k != "object"} for r in rows}


def assert_closes(led):
    emitted = led["EMITTED"]["incident_W"]
    total = math.fsum(r["absorbed_W"] for r in led.values())
    assert emitted > 0
    assert abs(total - emitted) <= 1e-12 * emitted, (total, emitted)
    assert led["LOST"]["absorbed_W"] == 0.0


def focus_lines(out):
    return [(float(a), float(b)) for a, b in
            re.findall(r"FOCUS: best focus ([-+0-9.e]+) mm along [+-]Z .*?RMS radius ([-+0-9.e]+) mm there", out)]


@pytest.mark.parametrize("name", MINE)
def test_example_runs_and_closes(name, tmp_path, capsys):
    out, d = run_example(name, tmp_path, capsys)
    led = read_ledger(d / "ledger.csv")
    assert_closes(led)
    CHECKS[name](out, d, led)


def _singlet(out, d, led):
    """Best focus per line 99.5 mm + shift: F before d before C; the F-C shift is near the paraxial 1.495 mm
    (tests/physics/test_trace_focus.py checks it ray by ray against an independent trace)."""
    f = focus_lines(out)
    assert len(f) == 3
    zF, zd, zC = (99.5 + s for s, _ in f)
    assert zF < zd < zC
    assert 1.45 < zC - zF < 1.55
    assert all(rms < 2e-3 for _, rms in f)           # < 2 um at best focus, f/16
    assert led["edge"]["incident_W"] == 0.0
    assert (d / "spot_d.png").exists()


def _glass_plate(out, d, led):
    """T = (1 - R)/(1 + R) = 0.923077: binomial over 20000 rays, sigma = 1.9e-3, 5 sigma."""
    n = 20000
    T = 0.923077
    t = led["transmitted"]["incident_W"]
    assert abs(t - T) <= 5 * math.sqrt(T * (1 - T) / n) + 1e-6, t
    assert led["transmitted"]["incident_W"] + led["reflected"]["incident_W"] == pytest.approx(1.0, rel=1e-12)
    spec = (d / "transmitted.csv").read_text().splitlines()
    assert spec[0] == "wavelength_nm,flux_W,stderr_W"
    assert float(spec[1].split(",")[1]) == pytest.approx(t, rel=1e-12)


def _prism(out, d, led):
    """Total internal reflection at 45 deg in n = 1.5: the hypotenuse reflects all it receives, exactly; the
    beam leaves along -X."""
    h = led["hypotenuse"]
    assert h["incident_W"] > 0.9
    assert h["reflected_W"] == h["incident_W"]
    assert h["transmitted_W"] == 0.0 and h["absorbed_W"] == 0.0
    m = re.search(r"STATS DIRECTION: .*\n\s+X: mean ([-+0-9.e]+)", out)
    assert m and float(m.group(1)) == pytest.approx(-1.0, abs=1e-12)
    # the prism unfolds into a slab between its two legs (the hypotenuse is a perfect mirror):
    # T = (1 - R)/(1 + R) = 0.923077 over 1000 rays, binomial sigma = 8.4e-3, 5 sigma
    assert abs(led["screen"]["incident_W"] - 0.923077) <= 5 * math.sqrt(0.923077 * 0.076923 / 1000)


def _paraboloid(out, d, led):
    """f = R/2 = 200 mm; the detector is 0.5 mm short of it: FOCUS +0.5 mm along +Z, RMS radius 0 there."""
    (s, rms), = focus_lines(out)
    assert s == pytest.approx(0.5, abs=1e-6)           # 1 nm (in mm)
    assert rms < 1e-9
    import numpy as np

    img = np.load(d / "detector.npy")
    assert img.shape == (1, 64, 64)
    assert img.sum() == pytest.approx(led["detector"]["incident_W"], rel=1e-12)
    # the blur at 0.5 mm from focus is a disk centred on the axis: symmetric image
    assert np.allclose(img[0], img[0, ::-1, :], atol=img.max() * 0.35)


def _mesh(out, d, led):
    """The convex icosphere's silhouette along z: sum over faces of area x max(n_z, 0) = 307.86 mm2, a share
    of 0.43554 of the beam of radius 15 mm (computed from the STL with trimesh below); random rays: binomial
    sigma over 20000 rays 3.5e-3, 5 sigma.  The coating reflects 60 %."""
    trimesh = pytest.importorskip("trimesh")
    import numpy as np

    m = trimesh.load(str(EXAMPLES / "data" / "icosphere_r10.stl"), force="mesh")
    assert m.is_watertight and len(m.faces) == 320
    share = float((m.area_faces * np.clip(m.face_normals[:, 2], 0, None)).sum()) / (math.pi * 15 ** 2)
    assert share == pytest.approx(0.43554, abs=1e-5)
    b = led["ball"]
    assert abs(b["incident_W"] - share) <= 5 * math.sqrt(share * (1 - share) / 20000)
    assert b["reflected_W"] == pytest.approx(0.6 * b["incident_W"], rel=1e-12)


def _adjoint(out, d, led):
    """The adjoint image is the radiance (W/m2/sr, E = 1 W/m2): at most A/pi = 0.190986 (the sub-solar point), and
    sum(L Omega_pix) is the Lambert sphere's flux density at the pinhole, (2/3) A E (R/D)^2 Phi(57.7 deg)
    (ORACLES.md) times 1 + 2.75e-4 at D = 1000 R (the finite distance).  The 4 x 4 lattice per pixel is
    deterministic; what is left is its quadrature error on the limb and terminator pixels (2.5e-5 when this was
    written): 1e-3 allowed.  tests/physics/test_adjoint_image.py checks every pixel."""
    import numpy as np

    img = np.load(d / "adjoint.npy")
    assert img.shape == (1, 64, 64)
    A, H, F, D = 0.6, 1.05, 1000.0, 1000.0
    assert 0.95 * A / math.pi < img.max() <= A / math.pi * (1 + 1e-5)
    c = -H + 2 * H * (np.arange(64) + 0.5) / 64
    X, Y = np.meshgrid(c, c)
    om = (2 * H / 64) ** 2 * F / (F * F + X * X + Y * Y) ** 1.5
    a = math.radians(57.7)
    phi = (math.sin(a) + (math.pi - a) * math.cos(a)) / math.pi
    oracle = 2 / 3 * A / D ** 2 * phi * (1 + 2.75e-4)
    assert float((img[0] * om).sum()) == pytest.approx(oracle, rel=1e-3)
    # the sun is at -x from the camera's axis and the pinhole inverts: the lit side is at the detector's +x
    assert img[0, :, 40:].sum() > 3 * img[0, :, :24].sum()


def _polarization(out, d, led):
    """Circular light at Brewster's angle on n = 1.5 (the script's header, worked out by hand): the window reflects
    0.25 Rs = 0.036982 W (binomial over 20000 rays of 0.5 W, 5 sigma), s-polarized (degree 1 in every lit pixel, no
    circular part left: rp = 0), the rest is transmitted."""
    import numpy as np

    R = 0.25 * 0.14792899408284016
    r = led["reflected"]["incident_W"]
    p = R / 0.5                         # each ray carries 0.5 W past the polarizer and reflects with chance p
    assert abs(r - R) <= 5 * 0.5 * math.sqrt(p * (1 - p) / 20000), r
    assert r + led["transmitted"]["incident_W"] == pytest.approx(0.5, rel=1e-12)
    i = np.load(d / "reflected_I.npy")
    dolp = np.load(d / "reflected_DOLP.npy")
    lit = i > 0
    assert lit.sum() > 50 and i.sum() == pytest.approx(r, rel=1e-12)
    assert np.allclose(dolp[lit], 1.0, atol=1e-9)
    assert np.allclose(np.load(d / "reflected_V.npy"), 0.0, atol=1e-15)
    for k in "IQUV":
        assert (d / f"reflected_{k}.png").exists() and (d / f"transmitted_{k}.npy").exists()
    # the transmitted light is partly polarized along p: Tp = 1, Ts = 1 - Rs, so its degree is
    # (Tp - Ts) / (Tp + Ts) = Rs / (2 - Rs) on every lit pixel
    it, dt = np.load(d / "transmitted_I.npy"), np.load(d / "transmitted_DOLP.npy")
    Rs = 0.14792899408284016
    assert np.allclose(dt[it > 0], Rs / (2 - Rs), atol=1e-9)


def _planet(out, d, led):
    """The planet at quadrature (the script's header).  Mirror symmetry about the scattering plane z = 0 (the image's
    rows flip): I and Q are even, U odd, pixel by pixel: chi-square of the differences with both standard
    errors, per degree of freedom within 5 sigma of 1 (sqrt(2/dof)).  Rayleigh scattering at 90 deg polarizes
    perpendicular to the scattering plane (E along z, which is -e2 here: Q < 0) and strongly: the disk's
    degree of linear polarization is above 0.5 (single scattering alone gives 0.946 at 90 deg; multiple scattering
    and the ocean lower it)."""
    import numpy as np

    img = {k: (np.load(d / f"planet_{k}.npy")[0], np.load(d / f"planet_{k}.stderr.npy")[0]) for k in "IQUV"}
    # nothing here makes circular light: Rayleigh scattering only carries V along (P44), and reflection off the
    # facets without total internal reflection has real Fresnel amplitudes
    assert not np.any(img["V"][0])
    for k, sign in (("I", 1), ("Q", 1), ("U", -1)):
        a, s = img[k]
        diff = a - sign * a[::-1]
        var = s ** 2 + s[::-1] ** 2
        m = (var > 0) & (np.arange(a.shape[0])[:, None] < a.shape[0] // 2)     # each pair once
        chi = float(np.sum(diff[m] ** 2 / var[m]) / m.sum())
        assert abs(chi - 1) <= 5 * math.sqrt(2 / m.sum()), (k, chi, m.sum())
    i, q, u = img["I"][0].sum(), img["Q"][0].sum(), img["U"][0].sum()
    assert q < 0 and math.hypot(q, u) / i > 0.5, (q / i, u / i)
    assert (d / "planet_DOLP.png").exists() and (d / "planet_AOLP.png").exists()


CHECKS = {"singlet_spot": _singlet, "glass_plate": _glass_plate, "prism_tir": _prism,
          "paraboloid_focus": _paraboloid, "mesh_object": _mesh, "adjoint_sphere": _adjoint,
          "polarization_bench": _polarization, "polarized_planet": _planet}


OTHERS = sorted(p.stem for p in EXAMPLES.glob("*.inr")
                if p.stem not in MINE and re.search(r"^\s*STATS\s+LEDGER\s+'", p.read_text(), re.M | re.I))


@pytest.mark.slow
@pytest.mark.parametrize("name", OTHERS)
def test_other_examples_close_their_ledger(name, tmp_path, capsys):
    out, d = run_example(name, tmp_path, capsys)
    for f in d.rglob("*.csv"):
        if f.read_text().startswith("object,incident_W"):
            assert_closes(read_ledger(f))
