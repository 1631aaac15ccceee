"""irt fmt: canonical formatting that is idempotent and keeps what a script means."""
from __future__ import annotations

import dataclasses
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from irtlang.lang.diagnostics import IrtError, Source, Span
from irtlang.lang.fmt import command_heads, format_file, format_source
from irtlang.lang.interp import Interpreter
from irtlang.lang.parser import parse_source
from irtlang.lang.spec import match_keyword

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples_scripts").rglob("*.inr"))


# ---------------------------------------------------------------- meaning of a script
def _norm(x):
    """A comparable form of scene values: spans (which move when text is reformatted) left out."""
    if isinstance(x, Span):
        return None
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return (type(x).__name__,) + tuple((f.name, _norm(getattr(x, f.name))) for f in dataclasses.fields(x)
                                           if not isinstance(getattr(x, f.name), Span))
    if isinstance(x, Mapping):
        return tuple((k, _norm(v)) for k, v in x.items())
    if isinstance(x, (list, tuple)):
        return tuple(_norm(v) for v in x)
    if hasattr(x, "shape") and hasattr(x, "tolist"):   # numpy arrays (a MESH's triangles)
        return ("array", tuple(x.shape), _norm(x.tolist()))
    return x


def _interp(text: str, name: str, path: Path | None, presets=(), **kw) -> Interpreter:
    it = Interpreter(**kw)
    it.preset(presets)
    if path is not None:  # inputs relative to the original script's folder
        it.base_dir = path.resolve().parent
        it.include_stack = [path.resolve()]
    it.run_source(Source(name, text))
    return it


def meaning(text: str, name: str = "t.inr", path: Path | None = None, presets=()):
    """What a script does under `irt check`: its scene, steps, variables, macros, diagnostics and output."""
    it = _interp(text, name, path, presets, check_only=True)
    printed: list[str] = []
    _interp(text, name, path, presets, out=printed.append)
    return {
        "scene": _norm(it.state.scene()),
        "steps": [(s.kind, _norm(s.params), _norm(s.scene)) for s in it.steps],
        "globals": _norm(it.globals),
        "macros": sorted((k, m.params) for k, m in it.macros.items()),
        "diags": [d.message for d in it.diags.items],
        "printed": printed,
        "state": (it.state.units, it.state.level, it.state.halt, it.state.seed, it.state.current,
                  tuple(it.state.group_stack)),
    }


def check_roundtrip(text: str, name: str = "t.inr", path: Path | None = None, clean: bool = False,
                    presets=()) -> str:
    out = format_source(text, name)
    parse_source(Source(name, out))                     # the formatted text parses
    assert format_source(out, name) == out, "not idempotent:\n" + out
    before = meaning(text, name, path, presets)
    if clean:
        assert before["diags"] == []
    assert meaning(out, name, path, presets) == before, "meaning changed:\n" + out
    return out


# ---------------------------------------------------------------- fixed examples
FULL = """\


!! a telescope, written carelessly
units mm ; wavelengths 450 550   650 nm   !! three lines
d=1200
MEDIUM glass index 1.5168 abs 0.001
medium bk7 sell 1.0396 0.2318 1.0105 0.0060007 0.020018 103.56
coat al refl 0.91 trans 0
coating ar fres
model paint lamb 0.5
model grass ross iso 0.03 0.08 0.30 vol 0.02 0.04 0.15 geo 0.005 0.01 0.03
model sea gli win 7 m/s ind 1.34 alb 0.02
model air ray tau 0.36 0.097 0.049 alb 1 dep 0.0279
model cloud hg g 0.85 tau 10 albedo 0.9999 ord 4
spec sun sol tsi 1360.5 W/m2
spectrum bb blac 5800 K
map clouds latl def cloud_fraction
SURFACE
conic z 0 radius -4200 con -1 ann 45 150 !! primary
object 'M1'
interface coating al AIR AIR
scat mod paint ray 4
SHIFT 0 0 -5 ; rot x 30 abo 0 0 1
surf
  plane Z 150 rect 10 5
obj fpa
det pix 64 64
SURFACE ; sphere 0 0 0 6371 km ; OBJECT earth
scatter map clouds models grass sea
SURFACE
ELLIPSOID 6378.137 km 6378.137 km 6356.752 km AT 0 0 0
obj ell
surface ; tube z 0 160 -900 160 ; object baffle
inter abs


do i=1,4,1
 if(i>2)then
print 'big {i}'
  else if (i == 2) then
  !! two
   print 'two'
 else
    print 'small'
 end if
enddo
macro vane angle width
  surface ; plane z (angle) disk width
  object 'VANE_{angle}'
end macro
call vane 45 8
x = 1 + &   !! first
  2 * &
  (3 - 1)
print (x and not 0) !! one value
group tel
 surface
 plane z 0 disk 5
 object m2
   shift z 5
end group
place tel at 0 0 0.18 AU aim 0 0 0 up 0 1 0
grid rect z -100 -10 10 -10 10 11 11
source dir 0 0 1
flux total 1 w
emit sphere 0 0 0 6.957e5 km rays 1e6 tow earth
flux spec sun
level 100 ; halt 1e-6 ; seed 42
trace until err 1% on fpa
save rays 'run.h5' at fpa
cons only fpa m2
cons all
select hit(m1) and not scattered(m2)
sel all
stats led 'ledger.csv'
window x -0.2 0.2 y -0.2 0.2 ; pixels 101 101
spots pos 'spot.png'
spots dir
focus
spectrum of fpa 'spectrum.csv'
export fpa 'image.fits'
reset
!! trailing comment
"""


def test_full_script_canonical_form():
    out = check_roundtrip(FULL, clean=True)
    lines = out.splitlines()
    assert lines[0] == "!! a telescope, written carelessly"
    assert "UNITS MM" in lines
    assert "WAVELENGTHS 450 550 650 nm  !! three lines" in lines
    assert "d = 1200" in lines
    assert "MEDIUM glass INDEX 1.5168 ABSORB 0.001" in lines
    assert "MEDIUM bk7 SELLMEIER 1.0396 0.2318 1.0105 0.0060007 0.020018 103.56" in lines
    assert "COATING al REFLECT 0.91 TRANSMIT 0" in lines
    assert "COATING ar FRESNEL" in lines
    assert "MODEL grass ROSSLI ISO 0.03 0.08 0.30 VOL 0.02 0.04 0.15 GEO 0.005 0.01 0.03" in lines
    assert "MODEL sea GLINT WIND 7 m/s INDEX 1.34 ALBEDO 0.02" in lines
    assert "MODEL air RAYLEIGH TAU 0.36 0.097 0.049 ALBEDO 1 DEPOL 0.0279" in lines
    assert "MODEL cloud HG G 0.85 TAU 10 ALBEDO 0.9999 ORDERS 4" in lines
    assert "SPECTRUM sun SOLAR TSI 1360.5 W/m2" in lines
    assert "SPECTRUM bb BLACKBODY 5800 K" in lines
    assert "MAP clouds LATLON DEFAULT CLOUD_FRACTION" in lines
    assert "  CONIC Z 0 RADIUS -4200 CONIC -1 ANNULUS 45 150  !! primary" in lines
    assert "OBJECT 'M1'" in lines
    assert "  INTERFACE COATING al AIR AIR" in lines
    assert "  SCATTER MODEL paint RAYS 4" in lines
    assert "  SHIFT 0 0 -5" in lines and "  ROTATE X 30 ABOUT 0 0 1" in lines
    assert "  DETECTOR PIXELS 64 64" in lines
    assert "  SCATTER MAP clouds MODELS grass sea" in lines
    assert "  ELLIPSOID 6378.137 km 6378.137 km 6356.752 km AT 0 0 0" in lines
    assert "  INTERFACE ABSORB" in lines
    assert lines.count("") == 1  # runs of blank lines shrink to one, none at the start
    i = lines.index("DO i = 1, 4, 1")
    assert lines[i + 1:i + 11] == [
        "  IF (i>2) THEN", "    PRINT 'big {i}'", "  ELSE IF (i == 2) THEN", "    !! two", "    PRINT 'two'",
        "  ELSE", "    PRINT 'small'", "  END IF", "END DO", "MACRO vane angle width"]
    i = lines.index("MACRO vane angle width")
    assert lines[i + 1:i + 5] == ["  SURFACE", "    PLANE Z (angle) DISK width", "  OBJECT 'VANE_{angle}'",
                                  "END MACRO"]
    i = lines.index("GROUP tel")
    assert lines[i + 1:i + 6] == ["  SURFACE", "    PLANE Z 0 DISK 5", "  OBJECT m2", "    SHIFT Z 5", "END GROUP"]
    assert "PLACE tel AT 0 0 0.18 AU AIM 0 0 0 UP 0 1 0" in lines
    assert "x = 1 + &   !! first" in lines and "    2 * &" in lines and "    (3 - 1)" in lines
    assert "PRINT (x AND NOT 0) !! one value" in lines
    assert "SOURCE DIRECTION 0 0 1" in lines and "FLUX TOTAL 1 w" in lines
    assert "EMITTING SPHERE 0 0 0 6.957e5 km RAYS 1e6 TOWARD earth" in lines
    assert "FLUX SPECTRUM sun" in lines
    assert ["LEVEL 100", "HALT 1e-6", "SEED 42"] == lines[lines.index("LEVEL 100"):lines.index("LEVEL 100") + 3]
    assert "TRACE UNTIL ERROR 1% ON fpa" in lines
    assert "SAVE RAYS 'run.h5' AT fpa" in lines
    assert "CONSIDER ONLY fpa m2" in lines and "CONSIDER ALL" in lines
    assert "SELECT HIT(m1) AND NOT SCATTERED(m2)" in lines and "SELECT ALL" in lines
    assert "STATS LEDGER 'ledger.csv'" in lines
    assert "WINDOW X -0.2 0.2 Y -0.2 0.2" in lines and "PIXELS 101 101" in lines
    assert "SPOTS POSITION 'spot.png'" in lines and "SPOTS DIRECTION" in lines
    assert "SPECTRUM OF fpa 'spectrum.csv'" in lines and "EXPORT fpa 'image.fits'" in lines
    assert lines[-1] == "!! trailing comment"
    assert out.endswith("!! trailing comment\n")


INLINE = [
    # separators, tabs, comments with quotes and '&', strings holding '!!' and ';'
    "x = 3 ;\n;;\n\tprint x ; !! c1\nif (x>1) print \"a!!b;c\" !! a & comment\n",
    # a continuation line holding only a comment; CRLF line ends
    "y = 1 + & !! one\r\n  & !! two\r\n  2\r\nprint y\r\n",
    # macro written with a prefix, ENDMACRO / ENDDO / ENDIF as one word
    "mac m a\nprint a\nendmacro\nDO i = 1, 2\ncall m i\nENDDO\nIF (1) THEN\nprint 1\nENDIF\n",
    # statements after a continued one on its last line
    "a = 1 ; b = 2 + &\n 3 ; print b !! end\n",
    # variables that look like keywords stay as written
    "pos = 2\nrect = 3\nSURFACE\nPLANE Z pos RECT rect rect\nOBJECT p\nprint pos\n",
    # a variable named like SPECTRUM's prefix in a per-line position: left alone
    "spec = 0.5\nMODEL m LAMBERTIAN spec\nCOATING c REFLECT spec\n",
    # semantic errors are kept (and still reported the same way)
    "SHIFT Z 5 deg\nSURFACE\nPLANE Z 0 RECT 1\nOBJECT a\nfoo 3\nMEDIUM g IN 1.5 AB\n",
    # ambiguous abbreviations are left as written
    "SPOTS POSI\nSTATS L\nwavelengths ra 400 700 4 nm\n",
    # deep nesting and a GROUP around a loop
    "group g\ndo i = 1, 2\nif (i == 1) then\ndo j = 1, 2\nprint '{i}{j}'\nend do\nelse\nprint i\nend if\nend do\nend group\n",
    # n@v repeats, units with spaces, interpolation, functions
    "WAVELENGTHS 450 550 650 NM\nCOATING c REFLECT 3@0.9\nq = sin(30) * 2   mm\nprint 'q={q:.3f}'\n",
    # IF on one line with a modifier inside an object's modifiers
    "SURFACE\nPLANE Z 0 DISK 1\nOBJECT a\nflag = 1\nIF (flag) SHIFT Z 3\nROTATE Z 10\n",
    # STOP ends the script: what follows is formatted but not run
    "print 1\nstop\nprint 2\n",
    # empty script and comments only
    "",
    "!! only\n   !! comments\n\n",
    # keywords run together with their arguments and strings
    "PRINT'x'\nx=(1)\nDO k=1,(2)\nEND DO\n",
]


@pytest.mark.parametrize("text", INLINE)
def test_inline_scripts(text):
    check_roundtrip(text)


def test_keywords_expanded_names_kept():
    out = format_source("spo pos 'Spot.PNG'\nsurf\nplan z 0 disk 5\nobje 'My Mirror'\ninte refl\n")
    assert out == ("SPOTS POSITION 'Spot.PNG'\nSURFACE\n  PLANE Z 0 DISK 5\nOBJECT 'My Mirror'\n"
                   "  INTERFACE REFLECT\n")


def test_one_statement_per_line_and_trailing_comment():
    out = format_source("UNITS CM ; SEED 3 !! both\n")
    assert out == "UNITS CM\nSEED 3  !! both\n"


def test_comment_column_kept_when_it_fits():
    src = "x = 1          !! aligned\nlong_name = 2  !! aligned\n"
    assert format_source(src) == src


def test_comment_only_lines_take_the_block_indentation():
    out = format_source("DO i = 1, 2\n!! inside\nPRINT i\n!! before the end\nEND DO\n!! after\n")
    assert out == "DO i = 1, 2\n  !! inside\n  PRINT i\n  !! before the end\nEND DO\n!! after\n"


def test_endgroup_without_group_does_not_crash():
    out = check_roundtrip("end group\nprint 1\n")
    assert out == "END GROUP\nPRINT 1\n"


@pytest.mark.parametrize("bad, message", [
    ("DO i = 1, 3\nPRINT i\n", "DO without END DO"),
    ("PRINT (1 + 2\n", "unterminated parenthesis"),
    ("END IF\n", "END IF without its opener"),
    ("PRINT 'abc\n", "unterminated string"),
])
def test_syntax_errors_are_reported_like_check(bad, message, tmp_path, capsys):
    from irtlang.cli import main

    with pytest.raises(IrtError) as e:
        format_source(bad, "bad.inr")
    assert message in e.value.render()
    f = tmp_path / "bad.inr"
    f.write_text(bad)
    assert main(["fmt", str(f)]) == 2
    err = capsys.readouterr().err
    assert f"{f}:" in err and message in err and "1 error" in err
    assert main(["check", str(f)]) == 2
    assert message in capsys.readouterr().err


def test_cli_fmt_prints_the_formatted_file(tmp_path):
    f = tmp_path / "a.inr"
    f.write_text("\ufeffunits cm ; print 'hi'  !! x\n")   # a BOM is read like `irt run` reads it
    r = subprocess.run([sys.executable, "-m", "irtlang.cli", "fmt", str(f)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "UNITS CM\nPRINT 'hi'  !! x\n"
    assert format_file(f) == r.stdout


# the long examples run shorter (every statement still runs; loops run fewer times)
SHORT = {"earth.inr": ["hours=1"], "earth_defocus.inr": ["sweep_last=0"]}


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_scripts(path):
    text = path.read_text(encoding="utf-8-sig")
    out = check_roundtrip(text, path.name, path, presets=SHORT.get(path.name, ()))
    assert out == format_file(path)


# ---------------------------------------------------------------- generated scripts
HEADS = command_heads()


def _kw(kw: str, allowed=None):
    """A keyword spelled as a user might: any case, possibly shortened to a unique prefix of >= 3 letters."""
    allowed = list(allowed or [kw])
    lengths = [len(kw)]
    if len(kw) > 3:
        for n in range(3, len(kw)):
            try:
                if match_keyword(kw[:n], allowed, Span(None, 0, 0, 0, 0)) == kw:
                    lengths.append(n)
            except IrtError:
                pass
    return st.tuples(st.sampled_from(lengths), st.sampled_from(["upper", "lower", "title"])).map(
        lambda lc: getattr(kw[:lc[0]], lc[1])())


def _head(kw):
    return _kw(kw, HEADS)


def _stmt(*parts):
    return st.tuples(*[p if isinstance(p, st.SearchStrategy) else st.just(p) for p in parts]).map(list)


NUM = st.sampled_from(["0", "1", "2.5", "-3", "1e-2", ".5", "(a + 1)", "b", "5 mm"])
VAR = st.sampled_from(["a", "b", "Cee"])
EXPR = st.sampled_from(["2", "a + 1", "(b * 2)", "3 mm", "sin(30)", "a^2 - b", "max(a, b)"])
OBJ = st.sampled_from(["o1", "o2", "'Obj {a}'", "fpa"])
APER = st.sampled_from([("RECT", "10", "5"), ("DISK", "4"), ("ANNULUS", "1", "4"), ("ELLIPSE", "3", "2")])
APERTURES = ("RECT", "DISK", "ANNULUS", "ELLIPSE")

SIMPLE = st.one_of(
    _stmt(VAR, "=", EXPR),
    _stmt(_head("PRINT"), st.sampled_from(["'a = {a}'", "a", "b a", "'x' (a + b)"])),
    _stmt(_head("UNITS"), st.sampled_from(["MM", "cm", "M"])),
    _stmt(_head("SEED"), st.sampled_from(["1", "42"])),
    _stmt(_head("MEDIUM"), st.sampled_from(["g", "Glass"]), _kw("INDEX", ["INDEX", "SELLMEIER", "TABLE"]), "1.5",
          st.one_of(st.just(""), _kw("ABSORB").map(lambda k: k + " 0.001"))),
    _stmt(_head("COATING"), "c", _kw("REFLECT", ["REFLECT", "TRANSMIT", "FRESNEL"]), "0.9",
          st.one_of(st.just(""), _kw("TRANSMIT").map(lambda k: k + " 0.05"))),
    _stmt(_head("MODEL"), "m", _kw("LAMBERTIAN", ["LAMBERTIAN", "ROSSLI", "GLINT", "RAYLEIGH", "HG"]), NUM),
    _stmt(_head("MODEL"), "r", _kw("ROSSLI", ["LAMBERTIAN", "ROSSLI", "GLINT", "RAYLEIGH", "HG"]),
          _kw("ISO", ["ISO", "VOL", "GEO"]), "0.03", _kw("VOL", ["ISO", "VOL", "GEO"]), "0.02",
          _kw("GEO", ["ISO", "VOL", "GEO"]), "0.005"),
    _stmt(_head("SURFACE")),
    _stmt(_head("PLANE"), _kw("Z", ["X", "Y", "Z"]), NUM,
          APER.flatmap(lambda a: _kw(a[0], APERTURES).map(lambda k: " ".join((k,) + a[1:])))),
    _stmt(_head("OBJECT"), OBJ),
    _stmt(_head("INTERFACE"), _kw("REFLECT", ["COATING", "REFLECT", "ABSORB", "TRANSMIT"])),
    _stmt(_head("SHIFT"), st.sampled_from(["0 0 1", "Z 2", "x (a)"])),
    _stmt(_head("ROTATE"), _kw("X", ["X", "Y", "Z"]), "30",
          st.one_of(st.just(""), _kw("ABOUT").map(lambda k: k + " 0 0 1"))),
    _stmt(_head("GRID"), _kw("RECT", ["RECT", "DISK"]), "Z -100 -10 10 -10 10 3 3"),
    _stmt(_head("SOURCE"), _kw("DIRECTION", ["DIRECTION", "POSITION", "FIELD"]), "0 0 1"),
    _stmt(_head("FLUX"), _kw("TOTAL", ["TOTAL", "SPECTRUM"]), "2 W"),
    _stmt(_head("WINDOW"), "X -1 1 y -1 1"),
    _stmt(_head("SPOTS"), _kw("POSITION", ["POSITION", "DIRECTION"])),
    _stmt(_head("STATS"), _kw("LEDGER", ["LEDGER", "POSITION", "DIRECTION"])),
    _stmt(_head("TRACE")),
)


def _flatten(chunks):
    return [stmt for chunk in chunks for stmt in chunk]


def _block(depth: int):
    """A DO, IF or GROUP block: a list of statements, each a list of parts."""
    inner = SIMPLE.map(lambda s: [s]) if depth >= 2 else st.one_of(SIMPLE.map(lambda s: [s]), _block(depth + 1))
    body = st.lists(inner, max_size=3).map(_flatten)
    do = st.tuples(st.just([["DO", "i", "=", "1,", "2"]]), body, st.just([["END", "DO"]]))
    iff = st.tuples(st.just([["IF", "(a > 0)", "THEN"]]), body,
                    st.lists(st.just([["ELSE"]]), max_size=1).map(_flatten), body, st.just([["end", "if"]]))
    grp = st.tuples(st.just([["GROUP", "grp"]]), body, st.just([["END", "GROUP"]]))
    return st.one_of(do, iff, grp).map(_flatten)


STATEMENTS = st.lists(st.one_of(SIMPLE.map(lambda s: [s]), _block(0)), min_size=1, max_size=10).map(_flatten)


@st.composite
def scripts(draw):
    stmts = draw(STATEMENTS)
    out = ["a = 1 ; b = 2 ; Cee = 3\n"]
    for k, parts in enumerate(stmts):
        parts = [p for p in parts if p != ""]
        indent = draw(st.sampled_from(["", "  ", "\t", "    "]))
        text = parts[0]
        for p in parts[1:]:
            sep = draw(st.sampled_from([" ", " ", "  ", "\t", " &\n   ", " & !! more\n"]))
            text += sep + p
        out.append(indent + text)
        end = draw(st.sampled_from(["\n", "\n", " ; ", ";", "  !! note\n", "\n\n", "\n!! comment\n"]))
        if end in (" ; ", ";") and k == len(stmts) - 1:
            end = "\n"
        out.append(end)
    return "".join(out)


@settings(max_examples=int(__import__("os").environ.get("FMT_EXAMPLES", "60")), deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(scripts())
def test_generated_scripts_idempotent_and_equivalent(text):
    parse_source(Source("gen.inr", text))   # the generator writes valid syntax
    check_roundtrip(text, "gen.inr")
