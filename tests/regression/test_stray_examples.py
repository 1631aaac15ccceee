"""The stray-light and optical-engineering examples (issue 20) run and reproduce their independent numbers:
stray_hri_pst.inr (path report and PST of the HRI-like Cassegrain), ghost_filter.inr (a filter's ghost, R^2 over the
image) and spot_diagrams.inr (3 x 3 field spots, through focus, the paraxial report).  Tolerances: 5 standard errors
where the run gives one; design numbers (ORACLES.md "Instrument") to the lattice's sampling."""
import csv
import math
from pathlib import Path

from irtlang.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples_scripts"


def _run(name, tmp_path, capsys, *sets):
    out = tmp_path / name
    argv = ["run", str(EXAMPLES / f"{name}.inr"), "--out", str(out)]
    for s in sets:
        argv += ["--set", s]
    code = main(argv)
    cap = capsys.readouterr()
    assert code == 0, cap.out + cap.err
    return out, cap.out


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_hri_pst_and_paths(tmp_path, capsys):
    out, text = _run("stray_hri_pst", tmp_path, capsys)
    pst = _rows(out / "pst.csv")
    p = {float(r["angle_deg"]): (float(r["pst"]), float(r["stderr"])) for r in pst}
    # in the field: the geometric collecting area (primary annulus outside the 97 mm obscuration) over the
    # detector's, times two aluminium reflections; the mirrors' ABG scatter takes a few per cent more
    geometric = 0.91 ** 2 * math.pi * (150 ** 2 - 48.5 ** 2) / 21.504 ** 2
    assert 0.93 * geometric < p[0.0][0] < geometric
    # outside the field the enclosure, vanes and baffles keep it more than 5 decades down
    for ang, (v, e) in p.items():
        if ang >= 2:
            assert 0 <= v < 1e-5 * p[0.0][0]
    assert p[20.0][0] < p[2.0][0]
    assert (out / "pst.png").stat().st_size > 10000
    paths = _rows(out / "paths_2deg.csv")
    assert paths[0]["path"] == "primary > obscuration > fpa" and paths[0]["events"] == "reflect > scatter > absorb"
    total = float(paths[-1]["flux_W"])
    assert math.isclose(math.fsum(float(r["flux_W"]) for r in paths[:-1]), total, rel_tol=1e-12)
    led = {r["object"]: float(r["incident_W"]) for r in _rows(out / "ledger.csv")}
    assert math.isclose(total, led["fpa"], rel_tol=1e-9)


def test_filter_ghost_is_r_squared(tmp_path, capsys):
    out, text = _run("ghost_filter", tmp_path, capsys)
    rows = _rows(out / "ghosts.csv")
    assert [float(r["pct"]) for r in rows] == [4.0, 1.0]
    for r in rows:
        R = float(r["pct"]) / 100
        top, se_top = float(r["PATHS_TOP_FLUX (W)"]), float(r["PATHS_TOP_FLUX_SE (W)"])
        gh, se_gh = float(r["PATHS_SECOND_FLUX (W)"]), float(r["PATHS_SECOND_FLUX_SE (W)"])
        # both ride on the rays that reach the 4 x 4 mm detector: the image with T^2 of them, the ghost R^2 T^2
        ratio = gh / top
        se_ratio = ratio * math.hypot(se_gh / gh, se_top / top)
        assert abs(ratio - R * R) < 5 * se_ratio, (R, ratio, se_ratio)
        assert abs(top - (1 - R) ** 2) < 5 * se_top + 1e-12 or top < (1 - R) ** 2  # some rays miss the plate's rim
    paths = _rows(out / "paths_4.csv")
    assert paths[1]["events"] == "transmit > reflect > reflect > transmit > absorb"


def test_spot_diagrams_and_paraxial_report(tmp_path, capsys):
    out, text = _run("spot_diagrams", tmp_path, capsys)
    assert "effective focal length EFL 1049" in text or "effective focal length EFL 1050" in text
    efl = float(text.split("effective focal length EFL ")[1].split()[0])
    assert abs(efl - 10500) < 0.001 * 10500
    bfl = float(text.split("back focal length BFL ")[1].split()[0])
    sep = float(text.split("(separation + 300 mm = ")[1].split()[0])
    assert abs(bfl - sep) < 0.05
    fnum = float(text.split("f-number f/")[1].split()[0])
    assert abs(fnum - 35.0) < 0.1
    field = _rows(out / "spots_field.csv")
    poly = [r for r in field if r["wavelength_nm"] == "all"]
    assert len(poly) == 9
    for r in poly:
        n_off = (float(r["field_x_deg"]) != 0) + (float(r["field_y_deg"]) != 0)
        want = {0: 0.0, 1: 2.96, 2: 5.90}[n_off]
        assert abs(float(r["rms_um"]) - want) < 0.02 * max(want, 0.5), r
    # per line: the mirrors are achromatic (the same spots); the Airy radius scales with lambda
    by_line = {float(r["wavelength_nm"]): float(r["airy_um"]) for r in field if float(r["field_x_deg"]) == 0 and
               float(r["field_y_deg"]) == 0 and r["wavelength_nm"] != "all"}
    assert math.isclose(by_line[450] / by_line[650], 450 / 650, rel_tol=1e-9)
    assert abs(by_line[550] - 1.22 * 0.550 * 35.0) < 0.01 * by_line[550]
    tf = _rows(out / "through_focus.csv")
    for r in tf:
        dz = float(r["focus_shift_mm"])
        # the marginal ray's blur: |dz| D / (2 EFL)
        assert abs(float(r["geo_um"]) - abs(dz) * 1e3 * 300 / (2 * 10500)) < 0.02 + 0.01 * abs(dz) * 1e3 / 70
    for png in ("spots_field.png", "spots_chief.png", "through_focus.png"):
        assert (out / png).stat().st_size > 20000


def test_ghost_rays_read_again(tmp_path, capsys):
    """examples_scripts/data/ghost_rays_4.h5 is ghost_filter.inr's ghost rays (R = 4 %) with the trace's ledger."""
    out, text = _run("ghost_reload", tmp_path, capsys)
    assert "LOAD RAYS: 589 rays on 3 objects (front_4, back_4, det_4)" in text and "does not hold" not in text
    paths = _rows(out / "ghost_paths.csv")
    assert paths[0]["events"] == "transmit > reflect > reflect > transmit > absorb"
    led = {r["object"]: float(r["incident_W"]) for r in _rows(out / "ledger.csv")}
    ghost, se = float(paths[0]["flux_W"]), float(paths[0]["stderr_W"])
    image = led["det_4"] - float(paths[-1]["flux_W"])          # the ledger holds every ray; the file the ghosts
    assert abs(ghost / image - 0.04 ** 2) < 5 * se / image
    stats = _rows(out / "ghost_stats.csv")
    assert math.isclose(float(stats[-1]["flux_W"]), float(paths[-1]["flux_W"]), rel_tol=1e-12)
