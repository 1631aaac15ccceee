"""TABLE's file format and interpolation, ABG's values and energy check, HG's ORDERS limit, SLAB flags."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from irtlang.lang.diagnostics import IrtError
from irtlang.lang.interp import Interpreter
from irtlang.plugins.bsdfs import REGISTRY

N_UP = (0.0, 0.0, 1.0)


def run(text: str, base: Path, lines: str = "450 550"):
    it = Interpreter(check_only=True)
    it.base_dir = base
    it.include_stack = [base / "snippet.inr"]
    try:
        it.run_text(f"WAVELENGTHS {lines} nm\n{text}\n")
    except IrtError as e:
        return it, list(e.diagnostics)
    return it, list(it.diags.items)


def model(text: str, base: Path, lines: str = "450 550"):
    it, diags = run(f"MODEL x {text}", base, lines)
    assert not diags, "\n".join(d.render() for d in diags)
    m = it.state.models["X"]
    mod = REGISTRY[m.kind]
    return mod, mod.pack(m.params, len(it.state.wavelengths_nm))


def errors(text: str, base: Path, lines: str = "450 550") -> str:
    _, diags = run(f"MODEL x {text}", base, lines)
    assert diags, "expected an error"
    return "\n".join(d.message for d in diags)


def _dir(theta_deg, phi_deg=0.0):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


def grid_rows(f, ti=(0, 30, 60), to=(0, 30, 60, 90), ph=(0, 90, 180)):
    return [f"{a},{b},{c},{f(a, b, c)}" for a in ti for b in to for c in ph]


# ---------------------------------------------------------------- TABLE
def test_table_reproduces_grid_values_and_interpolates_trilinearly(tmp_path):
    f = lambda a, b, c: 0.1 + 0.001 * a + 0.002 * b + 0.0003 * c       # trilinear: reproduced exactly
    rows = grid_rows(f)
    # shuffled order, a header, comments and blank lines are accepted
    text = "# a plane in (theta_i, theta_o, phi)\ntheta_i_deg,theta_o_deg,phi_deg,brdf\n\n" + \
           "\n".join(reversed(rows)) + "\n!! end\n"
    (tmp_path / "b.csv").write_text(text)
    mod, P = model("TABLE 'b.csv'", tmp_path)
    for a, b, c in ((30, 30, 90), (10, 45, 33), (45, 80, 170), (0, 0, 0)):
        wi, wo = _dir(a), _dir(b, c)
        for k in range(2):
            assert mod.eval(P, k, *wi, *wo, *N_UP) == pytest.approx(f(a, b, c), rel=1e-9)
    # outside the grid the edge values hold (theta_i 75 > 60)
    assert mod.eval(P, 0, *_dir(75), *_dir(30, 90), *N_UP) == pytest.approx(f(60, 30, 90), rel=1e-9)
    assert mod.eval(P, 0, *_dir(30), *_dir(30, 90, )[:2], -0.5, *N_UP) == 0.0   # transmission: none


def test_table_azimuth_convention(tmp_path):
    """phi = 0: viewer on the light's side (backscattering); 180: the mirror side."""
    f = lambda a, b, c: 0.05 if c < 90 else (0.15 if c > 90 else 0.1)
    (tmp_path / "b.csv").write_text("\n".join(grid_rows(f)) + "\n")
    mod, P = model("TABLE 'b.csv'", tmp_path)
    wi = _dir(30)
    back = mod.eval(P, 0, *wi, *wi, *N_UP)                      # wo = wi: the hot spot, phi = 0
    spec = mod.eval(P, 0, *wi, *_dir(30, 180), *N_UP)           # the mirror direction, phi = 180
    assert back == pytest.approx(0.05) and spec == pytest.approx(0.15)
    # phi and -phi are the same
    assert mod.eval(P, 0, *wi, *_dir(30, 120), *N_UP) == pytest.approx(mod.eval(P, 0, *wi, *_dir(30, -120), *N_UP))


def test_table_per_line_columns(tmp_path):
    rows = [f"{a},{b},{c},0.1,0.2" for a in (0, 60) for b in (0, 90) for c in (0, 180)]
    (tmp_path / "b.csv").write_text("\n".join(rows) + "\n")
    mod, P = model("TABLE 'b.csv'", tmp_path)
    wi, wo = _dir(20), _dir(40, 30)
    assert mod.eval(P, 0, *wi, *wo, *N_UP) == pytest.approx(0.1)
    assert mod.eval(P, 1, *wi, *wo, *N_UP) == pytest.approx(0.2)
    assert mod.albedo(P, 0, 0.7)[0] == pytest.approx(0.1 * math.pi, rel=1e-9)    # a constant BRDF: r = pi f
    assert mod.albedo(P, 1, 0.7)[0] == pytest.approx(0.2 * math.pi, rel=1e-9)


def test_table_single_values_on_an_axis(tmp_path):
    (tmp_path / "b.csv").write_text("45,0,0,0.2\n45,90,0,0.1\n")
    mod, P = model("TABLE 'b.csv'", tmp_path)
    # constant in theta_i and phi, linear in theta_o
    assert mod.eval(P, 0, *_dir(5), *_dir(45, 77), *N_UP) == pytest.approx(0.15)
    # int f cos dOmega = 2 pi int_0^{pi/2} (0.2 - 0.1 t/(pi/2)) cos t sin t dt
    want = 2 * math.pi * (0.2 * 0.5 - 0.1 / (math.pi / 2) * (math.pi / 8))
    assert mod.albedo(P, 0, 0.3)[0] == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("content,message", [
    ("0,0,0,0.1\n0,90,0,0.1\n30,0,0,0.1\n", "complete grid"),
    ("0,0,0,0.1\n0,0,0,0.2\n0,90,0,0.1\n0,90,0,0.1\n", "complete grid"),
    ("0,0,0,0.1,0.1,0.1\n", "columns"),
    ("0,0,0\n", "columns"),
    ("0,0,0,0.1\n0,95,0,0.1\n", "outside [0, 90]"),
    ("0,0,0,0.1\n0,0,200,0.1\n", "outside [0, 180]"),
    ("0,0,0,0.1\n0,90,0,-0.1\n", "negative"),
    ("0,0,0,1\n0,90,0,1\n", "reflects"),
    ("0,0,0,0.1\n0,x,0,0.1\n", "not a number"),
    ("# nothing\n", "no rows"),
])
def test_table_format_errors(tmp_path, content, message):
    (tmp_path / "b.csv").write_text(content)
    assert message in errors("TABLE 'b.csv'", tmp_path)


def test_table_missing_file(tmp_path):
    assert "not found" in errors("TABLE 'nope.csv'", tmp_path)


# ---------------------------------------------------------------- ABG
def test_abg_values_and_normal_albedo(tmp_path):
    mod, P = model("ABG A 0.001 0.002 B 0.0001 0.001 G 2 1.5", tmp_path)
    wi = _dir(30)
    spec = _dir(30, 180)
    assert mod.eval(P, 0, *wi, *spec, *N_UP) == pytest.approx(0.001 / 0.0001, rel=1e-9)       # A / B at beta0
    # |beta - beta0| = |sin(theta_o) - sin 30| in the plane of incidence, forward side
    wo = _dir(50, 180)
    d = math.sin(math.radians(50)) - 0.5
    assert mod.eval(P, 1, *wi, *wo, *N_UP) == pytest.approx(0.002 / (0.001 + d ** 1.5), rel=1e-9)
    # g = 2: the normal-incidence albedo is pi A ln(1 + 1/B)
    assert mod.albedo(P, 0, 1.0)[0] == pytest.approx(math.pi * 0.001 * math.log(1 + 1 / 0.0001), rel=1e-9)


def test_abg_refuses_more_energy_than_it_receives(tmp_path):
    assert "reflects" in errors("ABG A 1 B 0.01 G 2", tmp_path)
    assert "B" in errors("ABG A 0.001 B 0 G 2", tmp_path)


# ---------------------------------------------------------------- HG, flags
def test_hg_orders_limit(tmp_path):
    assert "at most 32" in errors("HG G 0.8 TAU 1 ALBEDO 0.9 ORDERS 40", tmp_path)
    model("HG G 0.8 TAU 1 ALBEDO 0.9 ORDERS 32", tmp_path)


def test_slab_flags_and_transmits():
    assert REGISTRY["RAYLEIGH"].SLAB and REGISTRY["HG"].SLAB
    for k in ("LAMBERTIAN", "ROSSLI", "GLINT", "ABG", "TABLE"):
        assert not getattr(REGISTRY[k], "SLAB", False)
    for k, mod in REGISTRY.items():
        assert callable(mod.pack) and all(callable(getattr(mod, f)) for f in
                                          ("eval", "pdf", "sample", "albedo", "direct_transmission")), k


def test_fixed_size_blocks_match_n_params(tmp_path):
    for text in ("ROSSLI ISO 0.1 VOL 0.1 GEO 0.01", "GLINT WIND 5 INDEX 1.34", "RAYLEIGH TAU 0.1",
                 "HG G 0.5 TAU 1 ALBEDO 1", "ABG A 0.001 B 0.01 G 2", "LAMBERTIAN 0.3"):
        mod, P = model(text, tmp_path)
        assert P.shape == (mod.N_PARAMS, 2) and P.dtype == np.float64
