"""Expressions and units: arithmetic with dimensions, degrees by default, functions, operators, strings,
`n@v`, the trailing-unit rule of lists and the keyword-abbreviation rule (LANGUAGE.md section 1)."""
from __future__ import annotations

import math

import pytest

from irtlang.lang.diagnostics import IrtError, Source, Span
from irtlang.lang.interp import Interpreter
from irtlang.lang.spec import match_keyword
from irtlang.lang.units import ANGLE, LENGTH, NONE, POWER, SPEED, TIME, IRRADIANCE, TEMPERATURE, AU_M, \
    Quantity, parse_qty_token, quantity

AREA = (2, 0, 0, 0, 0)


def run(text: str, units: str = "MM") -> Interpreter:
    it = Interpreter(check_only=True)
    it.run_source(Source("e.inr", f"UNITS {units}\n{text}"))
    assert not it.diags, "\n".join(d.render() for d in it.diags.items)
    return it


def ev(expr: str, units: str = "MM") -> Quantity | str:
    """The value of one expression (through an assignment, as a script would write it)."""
    return run(f"v_ = {expr}\n", units).lookup("v_")


def err(text: str):
    """The single diagnostic of a one-line script (line 1)."""
    it = Interpreter(check_only=True)
    try:
        it.run_source(Source("e.inr", text + "\n"))
    except IrtError as e:
        diags = e.diagnostics
    else:
        diags = it.diags.items
    assert len(diags) == 1, [d.render() for d in diags]
    return diags[0]


def printed(text: str, units: str = "MM") -> list[str]:
    out: list[str] = []
    it = Interpreter(out=out.append)
    it.run_source(Source("p.inr", f"UNITS {units}\n{text}"))
    assert not it.diags, "\n".join(d.render() for d in it.diags.items)
    return out


# ---------------------------------------------------------------- units of numbers
@pytest.mark.parametrize("token, number, unit", [
    ("550nm", 550.0, "nm"), ("550 NM", 550.0, "nm"), ("0.118 deg", 0.118, "deg"), ("6378.137 km", 6378.137, "km"),
    ("0.18 AU", 0.18, "au"), ("7 m/s", 7.0, "m/s"), ("1360.5 W/m2", 1360.5, "w/m2"), ("1e-3", 1e-3, None),
    (".5", 0.5, None), ("12", 12.0, None), ("5 arcsec", 5.0, "arcsec"), ("1%", 1.0, "%"), ("2.5e3mrad", 2500.0, "mrad"),
])
def test_quantity_tokens(token, number, unit):
    assert parse_qty_token(token) == (number, unit)


@pytest.mark.parametrize("unit, factor, dim", [
    ("nm", 1e-9, LENGTH), ("um", 1e-6, LENGTH), ("mm", 1e-3, LENGTH), ("cm", 1e-2, LENGTH), ("m", 1.0, LENGTH),
    ("km", 1e3, LENGTH), ("au", AU_M, LENGTH), ("in", 0.0254, LENGTH), ("deg", math.pi / 180, ANGLE),
    ("rad", 1.0, ANGLE), ("mrad", 1e-3, ANGLE), ("urad", 1e-6, ANGLE), ("arcsec", math.pi / 180 / 3600, ANGLE),
    ("s", 1.0, TIME), ("min", 60.0, TIME), ("h", 3600.0, TIME), ("w", 1.0, POWER), ("w/m2", 1.0, IRRADIANCE),
    ("m/s", 1.0, SPEED), ("k", 1.0, TEMPERATURE), ("%", 0.01, NONE),
])
def test_every_unit_converts_to_canonical(unit, factor, dim):
    q = quantity(3.0, unit)
    assert q.dim == dim and q.value == pytest.approx(3.0 * factor, rel=1e-15)


def test_numbers_in_expressions_carry_their_units():
    assert ev("0.18 AU") == Quantity(0.18 * AU_M, LENGTH)
    assert ev("550nm").value == pytest.approx(550e-9, rel=1e-15)
    assert ev("550 NM").value == pytest.approx(550e-9, rel=1e-15)
    assert ev("2 h").value == 7200.0 and ev("2 h").dim == TIME
    assert ev("10 min") == Quantity(600.0, TIME)
    assert ev("50%") == Quantity(0.5, NONE)
    assert ev("7") == Quantity(7.0, None)                   # a bare number stays bare until used


# ---------------------------------------------------------------- arithmetic with units
def test_a_bare_number_added_to_a_length_takes_units():
    assert ev("2 + 3 mm").dim == LENGTH
    assert ev("2 + 3 mm").value == pytest.approx(0.005, rel=1e-15)
    assert ev("2 + 3 mm", units="CM").value == pytest.approx(0.023, rel=1e-15)
    assert ev("1 m - 2", units="KM").value == pytest.approx(-1999.0, rel=1e-15)
    assert ev("2 + 3 deg").value == pytest.approx(math.radians(5), rel=1e-15)   # a bare angle is in degrees


def test_adding_a_length_and_an_angle_is_an_error():
    d = err("x = 1 mm + 2 deg")
    assert (d.span.line, d.span.col) == (1, 10)
    assert d.message == "cannot add a length and an angle (1 mm and 2 deg)"
    d = err("x = 1 mm - 2 s")
    assert d.message == "cannot subtract a length and a time (1 mm and 2 s)"
    d = err("x = (1 mm < 2 W)")
    assert d.message == "cannot compare a length and a power (1 mm and 2 W)"


def test_length_over_length_is_a_pure_number():
    q = ev("(6 mm) / (2 cm)")
    assert q.dim == NONE and q.value == pytest.approx(0.3, rel=1e-15)
    assert ev("3 mm * 2").dim == LENGTH and ev("3 mm * 2").value == pytest.approx(0.006, rel=1e-15)
    assert ev("2 mm * 3 mm") == Quantity(pytest.approx(6e-6, rel=1e-15), AREA)
    assert ev("(1 mm) ^ 2").dim == AREA
    assert ev("7 m/s * 2 s").dim == LENGTH and ev("7 m/s * 2 s").value == pytest.approx(14.0)
    assert ev("sin(6 mm / 2 mm * 10)").value == pytest.approx(0.5, abs=1e-15)    # a ratio is pure: 30 degrees


def test_sqrt_of_an_area_is_a_length():
    q = ev("sqrt(4 mm * 1 mm)")
    assert q.dim == LENGTH and q.value == pytest.approx(0.002, rel=1e-15)
    assert ev("sqrt(16)") == Quantity(4.0, None)
    d = err("x = sqrt(2 mm)")
    assert (d.span.col, d.message) == (10, "sqrt() of 2 mm has no unit")


def test_functions_that_need_pure_numbers():
    assert err("x = exp(1 mm)").message == "exp() needs a pure number, got 1 mm"
    assert err("x = log(0)").message == "log() of a number <= 0"
    assert err("x = sin(1 mm)").message == "expected an angle, got 1 mm"
    assert ev("log10(1000)").value == pytest.approx(3.0, rel=1e-15)
    assert ev("log(E)").value == pytest.approx(1.0, rel=1e-15)


# ---------------------------------------------------------------- angles: degrees by default
@pytest.mark.parametrize("expr, value", [
    ("sin(30)", 0.5), ("cos(60)", 0.5), ("tan(45)", 1.0), ("sin(90 deg)", 1.0), ("cos(180)", -1.0), ("cos(3.141592653589793 rad)", -1.0),
    ("sin(1800 arcsec)", math.sin(math.radians(0.5))), ("tan(-45)", -1.0),
])
def test_trigonometry_reads_bare_angles_as_degrees(expr, value):
    q = ev(expr)
    assert q.value == pytest.approx(value, rel=1e-14, abs=1e-15)
    assert q.dim is None


@pytest.mark.parametrize("expr, degrees", [
    ("asin(0.5)", 30.0), ("acos(0.5)", 60.0), ("atan(1)", 45.0), ("atan2(1, 1)", 45.0), ("atan2(1, -1)", 135.0),
    ("atan2(-1, 0)", -90.0), ("atan2(1 mm, 1 cm)", math.degrees(math.atan2(1, 10))),
])
def test_inverse_trigonometry_returns_degrees(expr, degrees):
    q = ev(expr)
    assert q.dim == ANGLE
    assert math.degrees(q.value) == pytest.approx(degrees, rel=1e-13)


def test_an_angle_from_asin_compares_and_prints_in_degrees():
    assert ev("abs(asin(0.5) - 30) < 1e-9").value == 1.0     # the bare 30 is 30 degrees
    assert ev("abs(asin(0.5) - 30) < 1e-9 rad").value == 1.0
    assert ev("asin(0.5) > 29.9 AND asin(0.5) < 30.1").value == 1.0
    assert printed("a = asin(0.5)\nPRINT '{a:.6f}'\nPRINT atan2(0, -1)\n") == ["30.000000", "180 deg"]


def test_atan2_takes_a_bare_value_in_units():
    # atan2(bare, length): the bare value is in the UNITS unit
    assert math.degrees(ev("atan2(10, 1 cm)").value) == pytest.approx(45.0)
    assert math.degrees(ev("atan2(10, 1 cm)", units="CM").value) == pytest.approx(math.degrees(math.atan(10)))
    assert err("x = atan2(1 mm, 1 deg)").message == "cannot compare a length and an angle (1 mm and 1 deg)"


# ---------------------------------------------------------------- min max floor ceil round abs
def test_min_and_max():
    assert ev("min(3, 1, 2)") == Quantity(1.0, None)
    assert ev("max(3, 1, 2)") == Quantity(3.0, None)
    assert ev("max(1 cm, 5 mm)").value == pytest.approx(0.01, rel=1e-15)
    q = ev("min(3, 2 mm)")                               # the bare 3 is 3 mm
    assert q.dim == LENGTH and q.value == pytest.approx(0.002, rel=1e-15)
    q = ev("max(3, 2 mm)")
    assert q.dim == LENGTH and q.value == pytest.approx(0.003, rel=1e-15)
    assert err("x = min()").message == "min() needs at least one argument"
    assert err("x = max(1 mm, 1 s)").message == "cannot compare a length and a time (1 mm and 1 s)"


def test_floor_ceil_round_act_in_the_display_unit():
    assert ev("floor(2.5 mm)").value == pytest.approx(0.002, rel=1e-15)
    assert ev("floor(25 mm)", units="CM").value == pytest.approx(0.02, rel=1e-15)
    assert ev("ceil(25 mm)", units="CM").value == pytest.approx(0.03, rel=1e-15)
    assert ev("round(26 mm)", units="CM").value == pytest.approx(0.03, rel=1e-15)
    assert math.degrees(ev("floor(30.7 deg)").value) == pytest.approx(30.0, rel=1e-15)
    assert ev("floor(-0.5)").value == -1.0 and ev("ceil(0.2)").value == 1.0
    assert ev("abs(-2 mm)").value == pytest.approx(0.002) and ev("abs(-2 mm)").dim == LENGTH


@pytest.mark.parametrize("x, r", [(2.5, 3.0), (-2.5, -3.0), (2.4, 2.0), (3.5, 4.0), (0.49999999999999994, 0.0),
                                  (-0.49999999999999994, 0.0), (1e300, 1e300), (-3.7, -4.0)])
def test_round_rounds_halves_away_from_zero(x, r):
    assert ev(f"round({x!r})").value == r


# ---------------------------------------------------------------- operators
@pytest.mark.parametrize("expr, value", [
    ("2 + 3 * 4", 14.0), ("(2 + 3) * 4", 20.0), ("2 * 3 ^ 2", 18.0), ("2 ^ 3 ^ 2", 512.0), ("(2 ^ 3) ^ 2", 64.0),
    ("-2 ^ 2", -4.0), ("(-2) ^ 2", 4.0), ("2 ^ -1", 0.5), ("- - 3", 3.0), ("-(1 + 2) * 3", -9.0),
    ("10 - 4 - 3", 3.0), ("64 / 4 / 2", 8.0), ("2 - -3", 5.0), ("+4 - +1", 3.0), ("sin(30) + 1", 1.5),
    ("1 + max(1, 2) * 2", 5.0),
])
def test_precedence_and_associativity(expr, value):
    assert ev(expr).value == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize("expr, value", [
    ("1 < 2", 1.0), ("2 <= 2", 1.0), ("3 > 4", 0.0), ("3 >= 4", 0.0), ("1 == 1", 1.0), ("1 != 1", 0.0),
    ("1 < 2 AND 3 > 2", 1.0), ("1 > 2 OR 3 > 2", 1.0), ("NOT 1 == 2", 1.0), ("NOT (1 == 1)", 0.0),
    ("1 OR 0 AND 0", 1.0), ("(1 OR 0) AND 0", 0.0), ("NOT 0 AND 0", 0.0), ("1 mm < 1 cm", 1.0),
    ("10 == 1 cm", 1.0), ("'Abc' == 'aBC'", 1.0), ("'a' != 'b'", 1.0), ("2 + 1 > 2", 1.0),
    ("0 AND (1 / 0)", 0.0), ("1 OR (1 / 0)", 1.0),
])
def test_comparisons_and_logic(expr, value):
    assert ev(expr) == Quantity(value)


def test_the_right_operand_is_evaluated_when_it_decides():
    assert err("x = 1 AND (1 / 0)").message == "division by zero"


def test_unary_minus_keeps_the_unit():
    q = ev("-(3 mm)")
    assert q.dim == LENGTH and q.value == pytest.approx(-0.003, rel=1e-15)
    assert err("x = -'a'").message == "expected a number, got the string 'a'"


def test_strings_join_and_do_not_do_arithmetic():
    assert ev("'ab' + 'cd'") == "abcd"
    d = err("x = 'a' * 2")
    assert d.message == "'*' does not apply to a string"


# ---------------------------------------------------------------- constants and variables
@pytest.mark.parametrize("name", ["PI", "pi", "E", "e"])
def test_constants_are_not_assignable(name):
    d = err(f"{name} = 3")
    assert (d.span.line, d.span.col, d.message) == (1, 1, f"{name} is a constant and cannot be assigned")


def test_constants_have_their_values():
    assert ev("PI").value == math.pi and ev("E").value == math.e
    assert ev("2 * pi").value == 2 * math.pi


def test_variables_are_case_insensitive():
    it = run("d = 1200\nX = D / 2\n")
    assert it.lookup("x") == Quantity(600.0, None)
    assert it.lookup("D") == Quantity(1200.0, None)


# ---------------------------------------------------------------- strings and interpolation
def test_interpolation_and_format_specs():
    out = printed("i = 7\nx = 1.5\nPRINT 'VANE_{i}' '{x:.3f}' '{i:03d}' '{{lit}}' 'sum={i + 1}' '{x:>6}'\n"
                  "w = 2.5 cm\nPRINT '{w}' w\na = asin(0.5)\nPRINT '{a:.1f}'\n")
    assert out == ["VANE_7 1.500 007 {lit} sum=8    1.5", "25 25 mm", "30.0"]


def test_interpolation_in_names():
    it = run("DO i = 1, 3\n  SURFACE\n    PLANE Z i RECT 1 1\n  OBJECT 'VANE_{i}'\nEND DO\n")
    assert [o.name for o in it.state.objects.values()] == ["VANE_1", "VANE_2", "VANE_3"]


def test_bad_interpolations():
    d = err("x = 1\nPRINT '{x:q}'")
    assert d.message == "bad format 'q' in an interpolation"
    d = err("PRINT 'a{1 +}'")
    assert (d.span.line, d.span.col, d.message) == (1, 13, "the expression ends too early")
    d = err("PRINT 'a{(1 + 2}'")
    assert (d.span.line, d.span.col, d.message) == (1, 10, "unterminated parenthesis: '(' is never closed")
    d = err("x = 2\nPRINT 'n = {x + y}'")
    assert (d.span.line, d.span.col, d.message) == (2, 17, "undefined variable 'y'")


# ---------------------------------------------------------------- n@v and lists
def test_repeat_in_a_list():
    it = run("WAVELENGTHS 450 550 650 NM\nCOATING c REFLECT 3@0.9\nCOATING d REFLECT 2@0.5 0.7\nn = 3\n"
             "COATING e TRANSMIT (n - 1)@0.1 0.2\nSURFACE\n  PLANE Z 0\nOBJECT a\n  SHIFT 3@5\n")
    assert it.state.coatings["C"].reflect == (0.9, 0.9, 0.9)
    assert it.state.coatings["D"].reflect == (0.5, 0.5, 0.7)
    assert it.state.coatings["E"].transmit == (0.1, 0.1, 0.2)
    assert it.state.objects["A"].transform.T == pytest.approx((0.005, 0.005, 0.005), rel=1e-15)


def test_trailing_unit_of_a_list():
    it = run("WAVELENGTHS 450 550 650 NM\n")
    assert it.state.wavelengths_nm == pytest.approx((450.0, 550.0, 650.0), rel=1e-15)
    it = run("WAVELENGTHS 0.45 0.55 UM\n")
    assert it.state.wavelengths_nm == pytest.approx((450.0, 550.0), rel=1e-15)
    it = run("SURFACE\n  PLANE Z 0\nOBJECT a\n  SHIFT 1 2 3 cm\n")
    assert it.state.objects["A"].transform.T == pytest.approx((0.01, 0.02, 0.03), rel=1e-15)
    # a unit inside the list is that value's own: the others stay in UNITS
    it = run("SURFACE\n  PLANE Z 0\nOBJECT a\n  SHIFT 1 2 mm 3 cm\n", units="CM")
    assert it.state.objects["A"].transform.T == pytest.approx((0.01, 0.002, 0.03), rel=1e-15)
    it = run("WAVELENGTHS RANGE 300 2500 295 NM\n")
    w = it.state.wavelengths_nm
    assert len(w) == 295 and w[0] == pytest.approx(300.0) and w[-1] == pytest.approx(2500.0)


def test_trailing_unit_of_the_wrong_kind():
    d = err("SURFACE\n  PLANE Z 0\nOBJECT a\n  SHIFT 1 2 3 deg")
    # issue 21: the error points at the number that carries the wrong unit
    assert (d.span.line, d.span.col, d.message) == (4, 13, "expected a length, got 3 deg")


# ---------------------------------------------------------------- keyword abbreviations
AT = Span(None, 1, 1, 1, 2)


@pytest.mark.parametrize("word, allowed, expected", [
    ("POSITION", ["POSITION", "DIRECTION"], "POSITION"),
    ("position", ["POSITION", "DIRECTION"], "POSITION"),
    ("POS", ["POSITION", "DIRECTION"], "POSITION"),
    ("pos", ["POSITION", "DIRECTION"], "POSITION"),
    ("Dir", ["POSITION", "DIRECTION"], "DIRECTION"),
    ("PO", ["POSITION", "DIRECTION"], None),             # 2 letters: not a keyword
    ("P", ["POSITION"], None),
    ("POSX", ["POSITION"], None),                        # not a prefix
    ("MAP", ["MAP", "MAPS"], "MAP"),                     # an exact match wins over a longer keyword
    ("TO", ["TO", "TOWARD"], "TO"),                      # exact, even under 3 letters
])
def test_keyword_matching(word, allowed, expected):
    assert match_keyword(word, allowed, AT) == expected


def test_ambiguous_prefix_lists_the_candidates():
    with pytest.raises(IrtError) as ei:
        match_keyword("lan", ["LAND_MASK", "LANDCOVER", "ELEVATION"], AT)
    (d,) = ei.value.diagnostics
    assert d.message == "ambiguous abbreviation 'lan': it could be LANDCOVER, LAND_MASK"
    assert d.hint == "write more letters"
    assert match_keyword("LANDC", ["LAND_MASK", "LANDCOVER"], AT) == "LANDCOVER"


def test_abbreviated_commands_and_keywords_in_a_script():
    it = run("WAVE 450 550 NM\nSURF\n  PLAN Z 0 REC 1 2\nOBJ a\n  INTERF REFL\nCOAT c REFL 0.5 TRANS 0.2\n")
    assert it.state.wavelengths_nm == pytest.approx((450.0, 550.0))
    a = it.state.objects["A"]
    assert a.surfaces[0].aperture.kind == "RECT" and a.interface.kind == "reflect"
    assert it.state.coatings["C"].transmit == (0.2, 0.2)
