"""Stray-light analysis against closed forms (issue 20).

* STATS PATHS: a collimated beam of power P on a Lambertian disk (albedo rho, radius a) under a coaxial absorbing
  detector disk (radius b, height h), behind a coated window (T = 0.9, R = 0.1, the same at every angle).  The leading
  path, wall (scatter) > window (transmit) > det, carries P rho F12 T, F12 the view factor between coaxial parallel
  disks (Howell's catalogue, C-40): R1 = a/h, R2 = b/h, X = 1 + (1 + R2^2) / R1^2,
  F12 = (X - sqrt(X^2 - 4 (R2/R1)^2)) / 2.  The rows (with `other`) add up to the total, which is the detector's
  incident flux in the ledger; a ray file loaded again gives the same table.
* PST: an ideal baffle, a tube (radius R, length L) with a Lambertian inner wall (rho) over a square detector,
  lit from past the angle where the beam can reach the detector directly.  With LEVEL 2 only single scattering
  reaches the detector: PST = rho cos(theta) (A_aperture / A_det) <F>, <F> the mean over the entrance aperture of
  the point-to-detector view factor (1/pi) int cos_w cos_d / r^2 dA of the wall point that the ray from there hits,
  integrated here by Gauss-Legendre quadrature (numpy only, no tracer).
Tolerances: 5 standard errors as the run reports them."""
import csv
import math
from pathlib import Path

import numpy as np
import pytest

from irtlang.cli import main

RHO, A, B, H, T_WIN = 0.5, 5.0, 10.0, 20.0, 0.9

VIEW = f"""MODEL white LAMBERTIAN {RHO}
COATING half REFLECT 0.1 TRANSMIT {T_WIN}
SURFACE
  PLANE Z 0 DISK {A}
OBJECT wall
  SCATTER MODEL white
SURFACE
  PLANE Z 15 DISK 12
OBJECT window
  INTERFACE COATING half AIR AIR
SURFACE
  PLANE Z {H} DISK {B}
OBJECT det
GRID DISK Z 10 {A} RAYS 200000 RANDOM
SOURCE DIRECTION 0 0 -1
FLUX TOTAL 1 W
SEED 7
TRACE
CONSIDER ONLY det
STATS PATHS 'paths.csv' TOP 1
STATS PATHS 'all_paths.csv'
STATS LEDGER 'ledger.csv'
APPEND 'vars.csv' PATHS_TOP_FLUX PATHS_TOP_FLUX_SE PATHS_FLUX PATHS_COUNT
STATS 'stats.csv'
SELECT HIT(window)
STATS 'stats_window.csv'
SELECT NOT HIT(window)
STATS 'stats_nowindow.csv'
APPEND 'vars2.csv' PATHS_TOP_FLUX STATS_FLUX
SELECT ALL
SAVE RAYS 'rays.h5'
"""

RELOAD = """LOAD RAYS '{rays}'
CONSIDER ONLY det
STATS PATHS 'paths_loaded.csv' TOP 1
STATS LEDGER 'ledger_loaded.csv'
SELECT SCATTERED(wall) AND HIT(window)
STATS 'stats_loaded.csv'
"""


def _run(tmp_path, name, text, capsys):
    f = tmp_path / f"{name}.inr"
    f.write_text(text)
    out = tmp_path / name
    code = main(["run", str(f), "--out", str(out)])
    cap = capsys.readouterr()
    assert code == 0, cap.out + cap.err
    return out, cap.out


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def view_factor_coaxial_disks(a, b, h):
    r1, r2 = a / h, b / h
    x = 1 + (1 + r2 * r2) / (r1 * r1)
    return 0.5 * (x - math.sqrt(x * x - 4 * (r2 / r1) ** 2))


def test_leading_path_is_the_view_factor(tmp_path, capsys):
    out, text = _run(tmp_path, "view", VIEW, capsys)
    rows = _rows(out / "paths.csv")
    assert list(rows[0]) == ["rank", "path", "events", "flux_W", "stderr_W", "fraction"]
    top = rows[0]
    assert top["path"] == "wall > window > det" and top["events"] == "scatter > transmit > absorb"
    expected = RHO * view_factor_coaxial_disks(A, B, H) * T_WIN
    f, se = float(top["flux_W"]), float(top["stderr_W"])
    assert se > 0 and abs(f - expected) < 5 * se, (f, se, expected)
    # TOP 1: the leading path, an `other` row, then the total; the rows add up to it, the ledger's flux on det
    assert [r["rank"] for r in rows] == ["1", "other", "total"]
    total = float(rows[-1]["flux_W"])
    assert math.isclose(math.fsum(float(r["flux_W"]) for r in rows[:-1]), total, rel_tol=1e-12)
    assert math.isclose(math.fsum(float(r["fraction"]) for r in rows[:-1]), 1.0, rel_tol=1e-12)
    led = {r["object"]: float(r["incident_W"]) for r in _rows(out / "ledger.csv")}
    assert math.isclose(total, led["det"], rel_tol=1e-9)
    all_rows = _rows(out / "all_paths.csv")
    assert all_rows[-1]["rank"] == "total" and "other" not in [r["rank"] for r in all_rows]
    fl = [float(r["flux_W"]) for r in all_rows[:-1]]
    assert fl == sorted(fl, reverse=True) and len(fl) >= 2
    # the window's reflection back onto the wall: one more round trip, far below the first
    assert all_rows[1]["path"] == "wall > window > wall > window > det"
    assert all_rows[1]["events"] == "scatter > reflect > scatter > transmit > absorb"
    assert fl[1] < 0.01 * fl[0]
    # STATS respects SELECT: every path to det crosses the window, so NOT HIT(window) leaves nothing
    st = _rows(out / "stats.csv")
    assert math.isclose(float(st[-1]["flux_W"]), total, rel_tol=1e-12)
    assert math.isclose(float(_rows(out / "stats_window.csv")[-1]["flux_W"]), total, rel_tol=1e-12)
    assert not (out / "stats_nowindow.csv").exists() or float(_rows(out / "stats_nowindow.csv")[-1]["flux_W"]) == 0
    assert "STATS: no rays selected" in text
    # the variables, collected by APPEND
    v = _rows(out / "vars.csv")
    assert list(v[0])[:3] == ["PATHS_TOP_FLUX (W)", "PATHS_TOP_FLUX_SE (W)", "PATHS_FLUX (W)"]
    assert math.isclose(float(v[0]["PATHS_TOP_FLUX (W)"]), f, rel_tol=1e-9)
    assert math.isclose(float(v[0]["PATHS_FLUX (W)"]), total, rel_tol=1e-9)
    assert float(v[0]["PATHS_COUNT"]) == len(all_rows) - 1
    assert len(v) == 1
    v2 = _rows(out / "vars2.csv")
    assert float(v2[0]["STATS_FLUX (W)"]) == 0.0     # the last STATS (NOT HIT(window)) selected nothing
    assert (out / "paths_layout.png").stat().st_size > 10000

    # the ray file keeps the names, the events and the ledger: the same report after LOAD RAYS
    out2, text2 = _run(tmp_path, "reload", RELOAD.format(rays=out / "rays.h5"), capsys)
    again = _rows(out2 / "paths_loaded.csv")
    assert [(r["path"], r["events"]) for r in again] == [(r["path"], r["events"]) for r in rows]
    for r1, r2 in zip(rows, again):
        assert math.isclose(float(r1["flux_W"]), float(r2["flux_W"]), rel_tol=1e-12)
        assert math.isclose(float(r1["stderr_W"]), float(r2["stderr_W"]), rel_tol=1e-9)
    assert _rows(out2 / "ledger_loaded.csv") == _rows(out / "ledger.csv")
    assert math.isclose(float(_rows(out2 / "stats_loaded.csv")[-1]["flux_W"]), total, rel_tol=1e-12)


# ------------------------------------------------------------------------------------------------ PST
R_T, L_T, S_DET, RHO_T = 10.0, 100.0, 5.0, 0.1
ANGLES = (20.0, 35.0, 50.0)

BAFFLE = f"""MODEL black LAMBERTIAN {RHO_T}
SURFACE
  TUBE Z 0 {R_T} {L_T} {R_T}
OBJECT tube
  SCATTER MODEL black TOWARD det RAYS 4
SURFACE
  PLANE Z 0 RECT {S_DET} {S_DET}
OBJECT det
  DETECTOR PIXELS 1
LEVEL 2
SEED 11
GRID DISK Z {L_T} {R_T} RAYS 200000 RANDOM
SOURCE FIELD 0 0
TRACE
PST 'pst.csv' ON det ANGLES {ANGLES[0]} {ANGLES[-1]} {len(ANGLES)}
APPEND 'pst_vars.csv' PST_LAST PST_LAST_SE
"""


def single_scatter_pst(theta_deg, n_ap=48, n_det=24):
    """rho cos(theta) (A_ap / A_det) <F> over the aperture (see the module docstring), by quadrature."""
    th = math.radians(theta_deg)
    s, c = math.sin(th), math.cos(th)
    # aperture: polar Gauss-Legendre in r (weight r) x uniform phi
    xr, wr = np.polynomial.legendre.leggauss(n_ap)
    r = 0.5 * R_T * (xr + 1)
    wr = 0.5 * R_T * wr * r
    phi = (np.arange(2 * n_ap) + 0.5) * math.pi / n_ap
    wphi = np.full(phi.size, math.pi / n_ap)
    x0 = (r[:, None] * np.cos(phi)[None, :]).ravel()
    y0 = (r[:, None] * np.sin(phi)[None, :]).ravel()
    w_ap = (wr[:, None] * wphi[None, :]).ravel()
    t = (-x0 * s + np.sqrt((x0 * s) ** 2 + s * s * (R_T * R_T - x0 * x0 - y0 * y0))) / (s * s)
    wx, wy, wz = x0 + t * s, y0, L_T - t * c
    assert wz.min() > 0                                  # every ray meets the wall before the detector plane
    # detector: Gauss-Legendre on the square
    xd, wd = np.polynomial.legendre.leggauss(n_det)
    qx = (S_DET * xd)[:, None] * np.ones(n_det)[None, :]
    qy = np.ones(n_det)[:, None] * (S_DET * xd)[None, :]
    wq = (S_DET * wd)[:, None] * (S_DET * wd)[None, :]
    qx, qy, wq = qx.ravel(), qy.ravel(), wq.ravel()
    nx, ny = -wx / R_T, -wy / R_T                        # the wall's inward normal
    vx, vy, vz = qx[None, :] - wx[:, None], qy[None, :] - wy[:, None], -wz[:, None] * np.ones_like(qx)[None, :]
    r2 = vx * vx + vy * vy + vz * vz
    cos_w = (nx[:, None] * vx + ny[:, None] * vy) / np.sqrt(r2)
    cos_d = wz[:, None] / np.sqrt(r2)
    F = (cos_w * cos_d / r2 * wq[None, :]).sum(1) / math.pi
    mean_F = (F * w_ap).sum() / (math.pi * R_T * R_T)
    return RHO_T * c * (math.pi * R_T * R_T) / (4 * S_DET * S_DET) * mean_F


def test_quadrature_converged():
    for th in ANGLES:
        a, b = single_scatter_pst(th), single_scatter_pst(th, n_ap=80, n_det=40)
        assert abs(a - b) < 1e-4 * b


def test_pst_of_an_ideal_baffle_is_the_single_scatter_integral(tmp_path, capsys):
    out, text = _run(tmp_path, "baffle", BAFFLE, capsys)
    rows = _rows(out / "pst.csv")
    assert list(rows[0]) == ["angle_deg", "pst", "stderr", "flux_W", "flux_stderr_W"]
    assert [float(r["angle_deg"]) for r in rows] == pytest.approx(ANGLES)
    for r in rows:
        p, se = float(r["pst"]), float(r["stderr"])
        want = single_scatter_pst(float(r["angle_deg"]))
        assert se > 0 and abs(p - want) < 5 * se, (r, want)
        assert se < 0.01 * p                             # next-event rays (TOWARD det): 0.1-0.2 %
    v = _rows(out / "pst_vars.csv")
    assert math.isclose(float(v[0]["PST_LAST"]), float(rows[-1]["pst"]), rel_tol=1e-9)
    assert (out / "pst.png").stat().st_size > 10000


# ------------------------------------------------------------------------------------ paraxial report
PARAXIAL = """SURFACE
  CONIC Z 0 RADIUS 200 CONIC CK DISK 30
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z ZD RECT 2 2
OBJECT det
GRID DISK Z 150 10 RAYS 2000
SOURCE SRC
TRACE
CONSIDER ONLY det
SELECT HIT(mirror)                  !! not the rays that meet the detector's back on their way in
FOCUS
SELECT ALL
APPEND 'paraxial.csv' FOCUS_EFL FOCUS_BFL FOCUS_FNUM FOCUS_MAG FOCUS_Z
CONSIDER ALL
"""


def test_paraxial_report_closed_forms(tmp_path, capsys):
    """A paraboloid (R = 200 mm) from infinity: EFL = BFL = R / 2 = 100 mm, f/5 for a 20 mm pupil, m = 0, focus at
    z = 100.  A sphere (R = 200 mm) with the point source at its centre of curvature images it onto itself:
    m = -1, BFL = R, focus at z = 200 (the report gives no EFL for a finite conjugate)."""
    text = (PARAXIAL.replace("CK", "-1").replace("ZD", "100").replace("SRC", "FIELD 0 0")
            + PARAXIAL.replace("CK", "0").replace("ZD", "200").replace("SRC", "POSITION 0 0 200")
            .replace("SURFACE", "SYSTEM NEW\nSURFACE", 1))
    out, log = _run(tmp_path, "paraxial", text, capsys)
    (a, b) = _rows(out / "paraxial.csv")
    assert abs(float(a["FOCUS_EFL (mm)"]) - 100) < 1e-6 and abs(float(a["FOCUS_BFL (mm)"]) - 100) < 1e-6
    assert abs(float(a["FOCUS_FNUM"]) - 100 / 20) < 0.05          # the lattice's outermost ray: D = 19.9.. mm
    assert float(a["FOCUS_MAG"]) == 0 and abs(float(a["FOCUS_Z (mm)"]) - 100) < 1e-6
    assert abs(float(b["FOCUS_MAG"]) + 1) < 1e-5 and abs(float(b["FOCUS_BFL (mm)"]) - 200) < 1e-6
    assert abs(float(b["FOCUS_Z (mm)"]) - 200) < 1e-6
    assert "magnification -1" in log and "magnification 0 (object at infinity)" in log
