"""Fuzzing the front end: whatever the text, parsing and checking raise nothing but IrtError, and every
diagnostic points inside the text it names and renders.

(a) random token streams from the language's vocabulary (keywords taken from the command table, names,
    numbers with and without units, strings with interpolations, operators, parentheses, ';', '&',
    newlines, '!!' comments, random unicode); (b) mutations of valid scripts (examples_scripts/, the
    reference's examples in docs/language.md, docs/examples/): characters and tokens deleted, duplicated,
    swapped, inserted, lines dropped or repeated; (c) valid scripts with their numbers replaced by extreme
    values.  Bounded: about 200 examples per property.

The crashes these properties found are kept below as plain regression tests (minimal reproducers).
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from irtlang.lang.commands import TABLE
from irtlang.lang.diagnostics import Diagnostic, IrtError, Source
from irtlang.lang.interp import Interpreter
from irtlang.lang.spec import Variants

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples_scripts"
NAME = "fuzz.inr"

FUZZ = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow],
                print_blob=True)


# ---------------------------------------------------------------- the property
def front_end(text: str, base: Path = EXAMPLES) -> list[Diagnostic]:
    """Parse and check `text` as a script in folder `base`; return its diagnostics.  Any exception other
    than IrtError propagates (and fails the test)."""
    it = Interpreter(check_only=True)
    it.base_dir = base
    it.include_stack = [base / NAME]
    try:
        it.run_source(Source(NAME, text))
        diags = list(it.diags.items)
    except IrtError as e:
        diags = list(e.diagnostics)
    for d in diags:
        assert_located(d)
    return diags


def assert_located(d: Diagnostic) -> None:
    s = d.span
    assert s.source is not None, f"diagnostic without a source: {d!r}"
    lines = s.source.text.split("\n")
    assert 1 <= s.line <= len(lines), f"line {s.line} outside {s.source.name} ({len(lines)} lines): {d!r}"
    assert 1 <= s.col <= len(lines[s.line - 1]) + 1, f"column {s.col} outside line {s.line}: {d!r}"
    text = d.render()
    assert text.startswith(f"{s.source.name}:{s.line}:{s.col}: error: {d.message}")
    caret = text.split("\n")[2]
    assert caret.index("^") == len("      | ") + s.col - 1


# ---------------------------------------------------------------- vocabulary
def _keywords() -> list[str]:
    words = set(TABLE)

    def walk(form):
        if form is None:
            return
        for p in form.params:
            if isinstance(p, Variants):
                for kw, sub in p.options.items():
                    words.add(kw)
                    walk(sub)
                walk(p.default)
            else:
                words.update(getattr(p, "words", ()))
        for c in form.clauses:
            words.add(c.kw)
            for p in c.params:
                words.update(getattr(p, "words", ()))

    for c in TABLE.values():
        walk(c.form)
    return sorted(w for w in words if " " not in w)


KEYWORDS = _keywords()
STRUCTURE = ["DO", "END", "IF", "THEN", "ELSE", "AND", "OR", "NOT", "END DO", "END IF", "END MACRO", "END GROUP",
             "ELSE IF", "PI", "E"]
NAMES = ["x", "i", "d", "M1", "fpa", "glass", "al", "sun", "paint", "telescope", "vane", "w", "mm", "deg", "au"]
FUNCS = ["sin(", "cos(", "atan2(", "sqrt(", "max(", "min(", "floor(", "round(", "log(", "HIT(", "PATH("]
UNITS = ["", "", "nm", "NM", " mm", "um", "cm", " m", "km", " AU", "in", "deg", " rad", "mrad", "arcsec", " s",
         "min", "h", " W", "W/m2", " m/s", " K", "%", "nmm", " furlongs", "x"]
NUMBERS = ["0", "1", "2", "3", "-1", "0.5", ".5", "1e-3", "12", "-3.5", "1e400", "1e-400", "100", "6371", "1e9",
           "4200", "999999999999999999999"]
STRINGS = ["'a'", "'M1'", "'VANE_{i}'", "'{x:.2f}'", "'{i:03d}'", "'{'", "'}'", "'{{}}'", "'{}'", "'{1+}'", "'x.npy'",
           "'image.fits'", "'spot.png'", "'run.h5'", "'cassegrain.inr'", "'data/icosphere_r10.stl'", "'nope.csv'",
           '"dq"', "'unterminated", "''"]
PUNCT = ["+", "-", "*", "/", "^", "(", ")", "(", ")", ",", "=", "==", "!=", "<", "<=", ">", ">=", "@", ";", "&",
         "{", "}", "!", "%", "'", '"', ".", "#", "$", "\\", "|"]
SEPARATORS = [" ", " ", " ", "", "\n", "\n", "\r\n", "\t", " &\n", " !! a comment\n", "; ", "\f"]

number_tokens = st.builds(lambda n, u: n + u, st.sampled_from(NUMBERS) | st.integers(-10**6, 10**6).map(str)
                          | st.floats(allow_nan=False, allow_infinity=False, width=32).map(repr), st.sampled_from(UNITS))
keyword_tokens = st.sampled_from(KEYWORDS).flatmap(
    lambda k: st.sampled_from([k, k.lower(), k.capitalize(), k[:3], k[:2], k + "X"]))
token = st.one_of(
    keyword_tokens, keyword_tokens, st.sampled_from(STRUCTURE), st.sampled_from(NAMES), st.sampled_from(FUNCS),
    number_tokens, number_tokens, st.sampled_from(STRINGS),
    st.text(max_size=6).map(lambda s: "'" + s.replace("'", "").replace("\n", "") + "'"),
    st.sampled_from(PUNCT), st.text(min_size=1, max_size=3),      # random unicode, control characters included
)
token_stream = st.lists(st.tuples(token, st.sampled_from(SEPARATORS)), max_size=40).map(
    lambda pairs: "".join(t + s for t, s in pairs))


@FUZZ
@given(token_stream)
def test_random_token_streams(text):
    front_end(text)


# ---------------------------------------------------------------- line-shaped streams: a command and its arguments
line = st.builds(lambda head, args: head + " " + " ".join(args), keyword_tokens,
                 st.lists(st.one_of(keyword_tokens, number_tokens, st.sampled_from(NAMES + STRINGS + PUNCT[:8])),
                          max_size=10))


@FUZZ
@given(st.lists(line, min_size=1, max_size=12).map("\n".join))
def test_random_command_lines(text):
    front_end(text)


# ---------------------------------------------------------------- mutations of valid scripts
VALID = """\
!! most of the language in one valid script
UNITS MM
WAVELENGTHS 450 550 650 NM
SEED 42
d = 1200 ; w = d / 2 + 5 mm
IF (d > 1000) THEN
  PRINT 'big {d}'
ELSE IF (d > 10) THEN
  PRINT 'medium'
ELSE
  PRINT 'small'
END IF
MEDIUM glass INDEX 1.5168 ABSORB 0.001
MEDIUM bk7 SELLMEIER 1.0396 0.2318 1.0105 0.0060007 0.020018 103.56
COATING al REFLECT 0.91 TRANSMIT 0
COATING ar TRANSMIT 0.98 0.97 0.96
COATING bare FRESNEL
SPECTRUM sun SOLAR TSI 1360.5 W/m2
MODEL paint LAMBERTIAN 0.5 TRANSMIT 0
MODEL grass ROSSLI ISO 0.03 0.08 0.30 VOL 0.02 0.04 0.15 GEO 0.005 0.01 0.03
MODEL sea GLINT WIND 7 m/s INDEX 1.34 ALBEDO 0.02
MODEL air RAYLEIGH TAU 0.36 0.097 0.049 ALBEDO 1 DEPOL 0.0279
MODEL cloud HG G 0.85 TAU 10 ALBEDO 0.9999 ORDERS 4
MACRO vane angle width
  SURFACE
    PLANE Z 0 RECT width 5
  OBJECT 'VANE_{angle}'
    ROTATE Z angle
    INTERFACE ABSORB
END MACRO
DO i = 1, 4
  CALL vane (i * 45) 8
END DO
GROUP telescope
  SURFACE
    CONIC Z 0 RADIUS -4200 CONIC -1 ANNULUS 45 150
  OBJECT 'M1'
    INTERFACE COATING al AIR AIR
  SURFACE
    CONIC Z 0 RADIUS 800 CONIC -1.2 ASPHERE 1e-10 -2e-16 DISK 20
  OBJECT M2
    SHIFT 0 0 -5 ; ROTATE X 30 ABOUT 0 0 0
    SCATTER MODEL paint RAYS 4 TOWARD M1
  SURFACE
    TUBE Z 0 160 -900 160
  OBJECT baffle
    INTERFACE ABSORB
  SURFACE
    PLANE Z -50 RECT 10 5
  OBJECT fpa
    DETECTOR PIXELS 64 64
END GROUP
PLACE telescope AT 0 0 0.18 AU AIM 0 0 0 UP 0 1 0
SURFACE
  ELLIPSOID 6378.137 km 6378.137 km 6356.752 km AT 0 0 0
OBJECT earth
  SCATTER MODEL grass
SURFACE
  SPHERE 0 0 0 6371 km
  MESH 'data/icosphere_r10.stl' SCALE 2
OBJECT ball
  INTERFACE TRANSMIT air glass
MAP clouds LATLON DEFAULT CLOUD_FRACTION
GRID RECT Z -100 -10 10 -10 10 11 11
SOURCE DIRECTION 0 0 1
GRID DISK Z -100 150 RAYS 1000 RANDOM
SOURCE FIELD 0.05 0.02 deg
FLUX SPECTRUM sun
EMITTING SPHERE 0 0 0 6.957e5 km RAYS 1e3 TOWARD earth
EMITTING DISK Z 0 5 RAYS 1e3 CONE 10
FLUX TOTAL 1 W
LEVEL 100
HALT 1e-6
TRACE UNTIL ERROR 1% ON fpa
SAVE RAYS 'run.h5' AT fpa
CONSIDER ONLY fpa M2
SELECT HIT(M2) AND NOT SCATTERED(baffle)
STATS LEDGER
WINDOW X -0.2 0.2 Y -0.2 0.2 ; PIXELS 101 101
SPOTS POSITION 'spot.png'
FOCUS
SPECTRUM OF fpa 'spectrum.csv'
EXPORT fpa 'image.fits'
CONSIDER ALL
SELECT ALL
RESET
STOP
PRINT 'never'
"""


def _doc_blocks() -> list[tuple[str, Path]]:
    doc = ROOT / "docs" / "language.md"
    if not doc.exists():
        return []
    blocks = re.findall(r"^```irt\s*\n(.*?)^```\s*$", doc.read_text(encoding="utf-8"), re.S | re.M)
    return [(b, ROOT / "docs" / "examples") for b in blocks]


# the long examples enter the corpus shortened (their loops run once): the front end sees every statement of them
SHORTER = {"earth.inr": ("DEFAULT hours 25", "DEFAULT hours 1"),
           "earth_defocus.inr": ("DEFAULT sweep_step 10 ", "DEFAULT sweep_step 100")}


def _example(p: Path) -> str:
    text = p.read_text(encoding="utf-8")
    if p.name in SHORTER:
        old, new = SHORTER[p.name]
        assert old in text, f"{p.name} no longer has {old!r}: update SHORTER"
        text = text.replace(old, new)
    return text


CORPUS: list[tuple[str, Path]] = (
    [(VALID, EXAMPLES)]
    + [(_example(p), p.parent) for p in sorted(EXAMPLES.glob("*.inr"))]
    + [(p.read_text(encoding="utf-8"), p.parent) for p in sorted((ROOT / "docs" / "examples").glob("*.inr"))]
    + _doc_blocks()
)

_TOKEN = re.compile(r"\s+|[A-Za-z_]\w*|\d+\.?\d*(?:[eE][+-]?\d+)?|'[^'\n]*'|\"[^\"\n]*\"|.", re.S)


def test_the_valid_scripts_are_valid():
    """The mutation corpus starts from scripts that check clean (all but the INCLUDE-only cassegrain.inr)."""
    assert len(CORPUS) >= 5
    diags = front_end(VALID)
    assert diags == [], "\n".join(d.render() for d in diags)


@st.composite
def mutated(draw):
    text, base = draw(st.sampled_from(CORPUS))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["del", "dup", "ins", "chr", "swap", "tok", "deltok", "line", "dupline"]))
        n = max(1, len(text))
        i = draw(st.integers(0, n - 1))
        j = min(len(text), i + draw(st.integers(0, 4)))
        if op == "del":
            text = text[:i] + text[j:]
        elif op == "dup":
            text = text[:j] + text[i:j] + text[j:]
        elif op == "ins":
            text = text[:i] + draw(token) + text[i:]
        elif op == "chr":
            text = text[:i] + draw(st.characters()) + text[j:]
        elif op in ("swap", "tok", "deltok"):
            parts = _TOKEN.findall(text) or [""]
            a = draw(st.integers(0, len(parts) - 1))
            b = draw(st.integers(0, len(parts) - 1))
            if op == "swap":
                parts[a], parts[b] = parts[b], parts[a]
            elif op == "tok":
                parts[a] = draw(token)
            else:
                del parts[a]
            text = "".join(parts)
        else:
            rows = text.split("\n")
            k = draw(st.integers(0, len(rows) - 1))
            if op == "line":
                del rows[k]
            else:
                rows.insert(k, rows[draw(st.integers(0, len(rows) - 1))])
            text = "\n".join(rows)
    return text, base


@FUZZ
@given(mutated())
def test_mutated_valid_scripts(case):
    text, base = case
    front_end(text, base)


_NUMBER = re.compile(r"(?<![A-Za-z_\d.])\d+\.?\d*(?:[eE][+-]?\d+)?")
EXTREMES = ["0", "-0", "-1", "1e400", "-1e400", "1e-400", "1e308", "1e-320", "(1e200*1e200)", "(0/1)", "0.5",
            "2.5", "1e9", "-(1e308)", "45 deg", "2 mm", "1 au", "3 W", "999999999999999999999"]


@st.composite
def extreme_values(draw):
    text, base = draw(st.sampled_from(CORPUS))
    spots = list(_NUMBER.finditer(text))
    if not spots:
        return text, base
    chosen = draw(st.lists(st.sampled_from(spots), min_size=1, max_size=6, unique_by=lambda m: m.start()))
    for m in sorted(chosen, key=lambda m: -m.start()):
        text = text[:m.start()] + draw(st.sampled_from(EXTREMES)) + text[m.end():]
    return text, base


@FUZZ
@given(extreme_values())
def test_valid_scripts_with_extreme_numbers(case):
    text, base = case
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)    # no NaN or overflow leaks into the model
        front_end(text, base)


# ---------------------------------------------------------------- regressions: the crashes found, minimized
def one(text: str) -> Diagnostic:
    diags = front_end(text)
    assert len(diags) == 1, [d.render() for d in diags]
    return diags[0]


@pytest.mark.parametrize("text, line, col, message", [
    # int() of an infinite or NaN value: OverflowError / ValueError escaped
    ("LEVEL 1e400\n", 1, 7, "number out of range"),
    ("SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  DETECTOR PIXELS (1e200*1e200 - 1e200*1e200)\n", 4, 20,
     "arithmetic overflow: the result is not a finite number"),
    ("GRID RECT Z -100 -10 10 -10 10 11 1e400\n", 1, 35, "number out of range"),
    ("WAVELENGTHS RANGE 300 2500 1e400 NM\n", 1, 28, "number out of range"),
    ("COATING c REFLECT 1e400@0.5\n", 1, 19, "number out of range"),
    ("COATING c REFLECT (1e200*1e200 - 1e200*1e200)@0.5\n", 1, 20,
     "arithmetic overflow: the result is not a finite number"),
    ("DO i = 1, 1e400\nEND DO\n", 1, 11, "number out of range"),
    ("DO i = -1e308, 1e308, 1e-300\nEND DO\n", 1, 1, "DO loop of more than 10000000 iterations"),
    ("x = floor(1e200*1e200 - 1e200*1e200)\n", 1, 11, "arithmetic overflow: the result is not a finite number"),
    ("x = 2 mm ^ 1e400\n", 1, 12, "number out of range"),
    # OverflowError / ZeroDivisionError of a power with a unit
    ("x = 2 mm ^ -10000\n", 1, 5, "arithmetic overflow or 0 to a negative power"),
    ("x = 0 mm ^ -1\n", 1, 5, "arithmetic overflow or 0 to a negative power"),
    # ZeroDivisionError in CONIC (an infinite RADIUS gave c = 0)
    ("SURFACE\n  CONIC Z 0 RADIUS -(1e200*1e200) DISK 1\nOBJECT a\n", 2, 22,
     "arithmetic overflow: the result is not a finite number"),
    ("UNITS AU\nSURFACE\n  CONIC Z 0 RADIUS 1e308 DISK 1\nOBJECT a\n", 3, 20, "CONIC RADIUS: R is out of range"),
    # math domain error in ROTATE (cos of an infinite angle)
    ("SURFACE\n  PLANE Z 0\nOBJECT a\n  ROTATE X 1e400\n", 4, 12, "number out of range"),
    # OverflowError (or a list of a billion values) from a huge n@v or RANGE count
    ("COATING al REFLECT 1e308@0.9\n", 1, 20, "the count of n@v is 1e+308; at most 100000 values"),
    ("WAVELENGTHS RANGE 300 2500 1e9 NM\n", 1, 28, "WAVELENGTHS RANGE count is 1e+09; at most 100000 lines"),
    # NaN from the Planck law of an absurd temperature (a RuntimeWarning in the rebinning)
    ("WAVELENGTHS RANGE 400 900 11 NM\nSPECTRUM star BLACKBODY 1e308 K\n", 2, 25,
     "SPECTRUM BLACKBODY: temperature must be in (0, 1e6] K, got 1e+308"),
    # a continuation swallowed the last newline: the end of the script was reported on a line after it
    ("DO & ", 1, 6, "the script ends too early: expected a name"),
    # RecursionError: a long expression, deeply nested blocks
    ("x = 1" + " + 1" * 600 + "\n", 1, 1, "this statement nests too deeply (602 levels of operators or calls)"),
    ("PRINT '{" + "1+" * 600 + "1}'\n", 1, 9, "this statement nests too deeply (601 levels of operators or calls)"),
])
def test_crash_reproducers(text, line, col, message):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        d = one(text)
    assert (d.span.line, d.span.col, d.message) == (line, col, message)


def test_deeply_nested_blocks_are_an_error_not_a_crash():
    diags = front_end("DO i = 1, 1\n" * 600 + "PRINT i\n" + "END DO\n" * 600)
    assert len(diags) == 1
    assert diags[0].message == "too deeply nested (blocks, macro calls or expressions)"


def test_a_long_chain_of_macros_is_an_error_not_a_crash():
    n = 300
    text = "".join(f"MACRO m{i}\n  CALL m{i + 1}\nEND MACRO\n" for i in range(n)) + f"MACRO m{n}\nEND MACRO\nCALL m0\n"
    diags = front_end(text)
    assert [(d.span.line, d.message) for d in diags] == [(3 * 63 + 2, "MACRO calls nested more than 64 deep")]  # the CALL in m63


def test_a_tiny_blackbody_temperature_warns_nothing():
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        it = Interpreter(check_only=True)
        it.run_text("SPECTRUM star BLACKBODY 1e-320 K\n")
    assert not it.diags
    (v,) = it.state.spectra["STAR"].on_lines
    assert 0.0 <= v < 1e-290          # finite and negligible (the exponent is clamped at 700)


def test_repeated_wavelengths_are_an_error_not_nan():
    """Two equal lines gave a zero-width band: the solar spectrum rebinned to NaN (a RuntimeWarning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        d = one("WAVELENGTHS 450 450 NM\nSPECTRUM s SOLAR\n")
    assert (d.span.line, d.span.col, d.message) == (1, 13, "WAVELENGTHS lists 450 nm more than once")


@pytest.mark.parametrize("text, shown", [
    ("PRINT 1 \f PRINT q\n", "    1 | PRINT 1   PRINT q"),     # a form feed is blank space, not a line break
    ("x = 1\u2028y = z\n", "    1 | x = 1 y = z"),
    ("x = 1\ry = z\n", "    1 | x = 1 y = z"),
    ("x = 1\r\ny = z\r\n", "    2 | y = z"),
])
def test_the_excerpt_is_the_line_the_lexer_counted(text, shown):
    """Source.line split with str.splitlines (\\f, \\r, \\u2028 ... are breaks there, not for the lexer)."""
    d = one(text)
    assert d.render().split("\n")[1] == shown
