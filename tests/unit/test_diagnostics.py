"""The front end fails like a good compiler: one located, precise diagnostic per mistake.

Every case below is a malformed script with the exact ``line:col`` of its diagnostic, its message and its
hint.  Each case must give exactly one diagnostic: a mistake never cascades into follow-on errors.  Then:
several independent errors are all reported in one pass; the first syntax error stops parsing; errors in
an INCLUDEd file name that file; an error inside a DO loop (or a macro called many times) is reported once.
"""
from __future__ import annotations

import numpy as np
import pytest

from irtlang.lang.diagnostics import Diagnostic, DiagnosticBag, IrtError, Source
from irtlang.lang.interp import Interpreter, check_file

NAME = "t.inr"


def diagnose(text: str, name: str = NAME) -> list[Diagnostic]:
    """Every diagnostic `irt check` would give for `text` (a syntax error: only that one)."""
    it = Interpreter(check_only=True)
    try:
        it.run_source(Source(name, text))
    except IrtError as e:
        return list(e.diagnostics)
    return list(it.diags.items)


def diagnose_file(path) -> list[Diagnostic]:
    try:
        check_file(path)
    except IrtError as e:
        return list(e.diagnostics)
    return []


def assert_renders(d: Diagnostic, file: str = NAME) -> None:
    """file:line:col: error: message, the source line, a caret under the span, then the hint."""
    lines = d.render().splitlines()
    assert lines[0] == f"{file}:{d.span.line}:{d.span.col}: error: {d.message}"
    src_line = d.span.source.line(d.span.line)
    assert lines[1] == f"{d.span.line:5d} | {src_line}"
    caret = lines[2]
    assert caret.startswith("      | ")
    assert caret[len("      | "):].index("^") == d.span.col - 1
    if d.hint:
        assert lines[-1] == f"hint: {d.hint}"
    else:
        assert not any(x.startswith("hint:") for x in lines)


KNOWN_UNITS = "known units: nm um mm cm m km au in deg rad mrad urad arcsec s min h w w/m2 m/s k"

# (id, script, line, col, message, hint): hint is the exact text, None for no hint, or a tuple of substrings
CASES = [
    # ---- undefined names, with did-you-mean
    ("undefined-medium", "MEDIUM glas INDEX 1.5\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  INTERFACE TRANSMIT air glass\n",
     5, 26, "undefined medium 'glass'", "did you mean glas?"),
    ("undefined-coating", "COATING alum REFLECT 0.9\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  INTERFACE COATING alu AIR AIR\n",
     5, 21, "undefined coating 'alu'", "did you mean alum?"),
    ("undefined-model", "MODEL paint LAMBERTIAN 0.5\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  SCATTER MODEL pant\n",
     5, 17, "undefined model 'pant'", "did you mean paint?"),
    ("undefined-object", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\nEXPORT fap 'x.npy'\n",
     4, 8, "undefined object 'fap'", "did you mean fpa?"),
    ("undefined-spectrum", "SPECTRUM sun SOLAR\nGRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE DIRECTION 0 0 1\nFLUX SPECTRUM son\n",
     4, 15, "undefined spectrum 'son'", "did you mean sun?"),
    ("undefined-map", "MAP clouds LATLON DEFAULT CLOUD_FRACTION\nMODEL a LAMBERTIAN 0.1\nSURFACE\n  PLANE Z 0\nOBJECT e\n"
     "  SCATTER MAP cloud MODELS a\n", 6, 15, "undefined map 'cloud'", "did you mean clouds?"),
    ("undefined-group", "GROUP telescope\nEND GROUP\nPLACE telescop AT 0 0 0\n",
     3, 7, "undefined group 'telescop'", "did you mean telescope?"),
    ("undefined-variable", "spacing = 10\nSHIFT Z (spacng / 2)\n",
     2, 10, "undefined variable 'spacng'", "did you mean spacing?"),
    ("undefined-macro", "MACRO vane a\nEND MACRO\nCALL vain 1\n", 3, 6, "undefined macro 'vain'", "did you mean vane?"),
    ("undefined-function", "x = sine(30)\n", 1, 5, "unknown function 'sine'", "did you mean sin or asin?"),
    ("undefined-predicate", "SURFACE\n  PLANE Z 0\nOBJECT a\nSELECT HITS(a)\n", 4, 8, "unknown predicate 'HITS'",
     "did you mean HIT?"),
    # ---- a name of another namespace
    ("medium-not-coating", "MEDIUM glass INDEX 1.5\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  INTERFACE COATING glass AIR AIR\n",
     5, 21, "'glass' is a medium, not a coating", None),
    ("coating-not-object", "COATING al REFLECT 0.9\nEXPORT al 'x.npy'\n", 2, 8, "'al' is a coating, not an object", None),
    # ---- units
    ("unit-wrong-kind", "SURFACE\n  PLANE Z 5 deg\nOBJECT a\n", 2, 11, "expected a length, got 5 deg", None),
    ("unit-wrong-kind-angle", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  ROTATE X 3 mm\n", 4, 12,
     "expected an angle, got 3 mm", None),
    ("unit-unknown-attached", "WAVELENGTHS 550nmm\n", 1, 16, "unknown unit 'nmm'", "did you mean nm or mm?"),
    ("unit-unknown-attached-expr", "x = 550nmm\n", 1, 8, "unknown unit 'nmm'", "did you mean nm or mm?"),
    ("unit-unknown-spaced", "SURFACE\n  PLANE Z 5 furlongs\nOBJECT a\n", 2, 13, "unknown unit 'furlongs'",
     (KNOWN_UNITS, "PLANE takes RECT, DISK, ANNULUS, ELLIPSE here")),
    ("unit-unknown-after-list", "WAVELENGTHS 450 550 650 NMM\n", 1, 25, "unknown unit 'NMM'", "did you mean nm or mm?"),
    ("unit-mm-plus-deg", "x = 3 mm + 2 deg\n", 1, 10, "cannot add a length and an angle (3 mm and 2 deg)", None),
    ("unit-exponent", "x = 2 ^ (3 mm)\n", 1, 10, "an exponent must be a pure number, got 3 mm", None),
    ("unit-fractional-power", "x = (2 mm) ^ 0.5\n", 1, 14, "a length can only be raised to an integer power", None),
    ("units-command", "UNITS FURLONG\n", 1, 7, "UNITS: expected NM or UM or MM or CM or M or KM or AU or IN, got 'FURLONG'",
     None),
    # ---- counts of values and arguments
    ("sellmeier-5-values", "MEDIUM bk7 SELLMEIER 1.0396 0.2318 1.0105 0.0060007 0.020018\n", 1, 22,
     "MEDIUM SELLMEIER expects 6 values for coefficients, got 5", None),
    ("shift-2-values", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  SHIFT 1 2\n", 4, 9,
     "SHIFT expects 3 values for d, got 2", None),
    ("call-wrong-count", "MACRO vane angle width\n  PRINT angle\nEND MACRO\nCALL vane 45\n", 4, 1,
     "wrong number of arguments: macro vane takes 2 (angle width), got 1", None),
    ("perline-count", "WAVELENGTHS 450 550 650 NM\nCOATING al REFLECT 0.9 0.8\n", 2, 20,
     "COATING REFLECT: 2 values for reflect, but WAVELENGTHS has 3 lines",
     "give one value for all lines, or one per line"),
    ("function-arity", "x = atan2(1)\n", 1, 5, "atan2() takes 2 arguments, got 1", None),
    ("repeat-count-zero", "WAVELENGTHS 450 550 650 NM\nCOATING c REFLECT 0@0.5\n", 2, 19,
     "the count of n@v must be a whole number >= 1", None),
    ("repeat-count-fraction", "WAVELENGTHS 450 550 650 NM\nCOATING c REFLECT 1.5@0.5\n", 2, 19,
     "the count of n@v must be a whole number >= 1", None),
    ("repeat-count-mismatch", "WAVELENGTHS 450 550 650 NM\nCOATING c REFLECT 2@0.5\n", 2, 21,
     "COATING REFLECT: 2 values for reflect, but WAVELENGTHS has 3 lines",
     "give one value for all lines, or one per line"),
    ("clause-twice", "COATING c REFLECT 0.5 TRANSMIT 0.1 TRANSMIT 0.2\n", 1, 36, "TRANSMIT given twice in COATING", None),
    # ---- physical consistency and ranges
    ("coating-r-plus-t", "COATING half REFLECT 0.6 TRANSMIT 0.5\n", 1, 1,
     "coating half: R + T = 0.6 + 0.5 = 1.1 > 1 on line 1 (550 nm)", "R + T + A = 1 with A >= 0"),
    ("albedo-1.5", "MODEL air RAYLEIGH TAU 0.1 ALBEDO 1.5\n", 1, 35,
     "MODEL RAYLEIGH ALBEDO: albedo must be in [0, 1], got 1.5", None),
    ("tau-negative", "MODEL cloud HG G 0.85 TAU -1 ALBEDO 0.9\n", 1, 27, "MODEL HG TAU: tau must be >= 0, got -1", None),
    ("reflectance-1.2", "MODEL paint LAMBERTIAN 1.2\n", 1, 24, "MODEL LAMBERTIAN: reflect must be in [0, 1], got 1.2", None),
    ("index-negative", "MEDIUM glass INDEX -1.5\n", 1, 20, "MEDIUM INDEX: index must be > 0, got -1.5", None),
    ("detector-0-pixels", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\n  DETECTOR PIXELS 0 10\n", 4, 19,
     "a detector needs at least 1 pixel, got 0", None),
    ("detector-qe-1.5", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\n  DETECTOR PIXELS 10 10 QE 1.5\n", 4, 28,
     "DETECTOR QE: qe must be in [0, 1], got 1.5", None),
    ("detector-qe-count", "WAVELENGTHS 450 550 NM\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\n"
     "  DETECTOR PIXELS 10 10 QE 0.5 0.6 0.7\n", 5, 28, "DETECTOR QE: 3 values for qe, but WAVELENGTHS has 2 lines",
     "give one value for all lines, or one per line"),
    ("rays-0", "EMITTING DISK Z 0 5 RAYS 0\n", 1, 26, "EMITTING DISK RAYS: rays must be > 0, got 0", None),
    ("seed-negative", "SEED -1\n", 1, 6, "SEED: seed must be >= 0, got -1", None),
    ("level-fraction", "LEVEL 2.5\n", 1, 7, "LEVEL: level must be a whole number, got 2.5", None),
    ("wavelength-no-unit", "WAVELENGTHS 450 550 650\n", 1, 13, "wavelength 450 mm (4.5e+08 nm) is outside 1 nm .. 1 mm",
     "give the unit: WAVELENGTHS 450 550 650 NM"),
    ("wavelength-twice", "WAVELENGTHS 450 450 NM\n", 1, 13, "WAVELENGTHS lists 450 nm more than once",
     "give each line a different wavelength"),
    ("conic-domain", "SURFACE\n  CONIC Z 0 RADIUS 100 CONIC 0 DISK 150\nOBJECT m\n", 2, 32,
     "the aperture reaches r = 150 but this conic only exists for r <= 100 (1 - (1+k) c^2 r^2 < 0 beyond)",
     "shrink the aperture or change RADIUS / CONIC"),
    ("conic-radius-0", "SURFACE\n  CONIC Z 0 RADIUS 0 DISK 5\nOBJECT a\n", 2, 20, "RADIUS 0 is not a curvature",
     "use a PLANE for a flat surface"),
    ("annulus-order", "SURFACE\n  PLANE Z 0 ANNULUS 5 2\nOBJECT a\n", 2, 13, "ANNULUS needs r_in < r_out", None),
    ("two-apertures", "SURFACE\n  PLANE Z 0 RECT 1 1 DISK 2\nOBJECT a\n", 2, 22,
     "one aperture per surface: RECT and DISK both given", None),
    ("direction-zero", "GRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE DIRECTION 0 0 0\n", 2, 18,
     "SOURCE DIRECTION needs a non-zero vector", None),
    ("window-same-axes", "WINDOW X -1 1 X -1 1\n", 1, 15, "WINDOW needs two different axes", None),
    ("window-order", "WINDOW X 1 -1 Y -1 1\n", 1, 12, "WINDOW X: the maximum must exceed the minimum", None),
    # ---- geometry structure
    ("duplicate-object", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT M1\nSURFACE\n  PLANE Z 1 RECT 1 1\nOBJECT m1\n", 6, 1,
     "duplicate object name 'm1'", "names are case-insensitive; m1 was defined at line 3"),
    ("modifier-no-object", "INTERFACE REFLECT\n", 1, 1, "INTERFACE has no current object to modify",
     "modifiers apply to the object of the last SURFACE ... OBJECT name; put it after OBJECT"),
    ("surface-outside-block", "PLANE Z 0\n", 1, 1, "PLANE must be inside a SURFACE block", "write SURFACE on the line before"),
    ("object-no-surface", "SURFACE\nOBJECT a\n", 2, 1, "object a has no surface",
     "put PLANE, CONIC, SPHERE, ... between SURFACE and OBJECT"),
    ("surface-never-closed", "SURFACE\n  PLANE Z 0\n", 1, 1, "SURFACE block is never closed by OBJECT name", None),
    ("group-never-closed", "GROUP g\n", 1, 1, "GROUP g without END GROUP", None),
    ("group-inside-itself", "GROUP g\n  PLACE g AT 0 0 0\nEND GROUP\n", 2, 9, "GROUP g cannot be placed inside itself", None),
    ("group-placed-twice", "GROUP g\nEND GROUP\nPLACE g AT 0 0 0\nPLACE g AT 0 0 1\n", 4, 1, "GROUP g is already placed",
     "a group may be placed again only after a TRACE (it moves between traces)"),
    ("aim-at-same-point", "GROUP g\nEND GROUP\nPLACE g AT 0 0 1 AIM 0 0 1\n", 3, 22, "AIM is the same point as AT", None),
    ("scatter-toward-itself", "MODEL p LAMBERTIAN 0.5\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT a\n  SCATTER MODEL p TOWARD a\n",
     5, 3, "object a cannot scatter TOWARD itself", None),
    # ---- sources and trace
    ("trace-no-source", "TRACE\n", 1, 1, "TRACE has no source", "define GRID + SOURCE, or EMITTING ..., before TRACE"),
    ("grid-without-source", "GRID RECT Z 0 -1 1 -1 1 3 3\nTRACE\n", 2, 1, "a GRID has no SOURCE direction", None),
    ("source-without-grid", "SOURCE DIRECTION 0 0 1\n", 1, 1, "SOURCE DIRECTION needs a GRID before it",
     "GRID RECT ... or GRID DISK ... first"),
    ("flux-without-source", "FLUX TOTAL 1 W\n", 1, 1, "FLUX has no source to apply to",
     "define a source first (GRID + SOURCE, or EMITTING)"),
    ("export-extension", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\nEXPORT fpa 'image.bmp'\n", 4, 12,
     "EXPORT cannot write '.bmp' files", "use .fits, .png, .npy or .csv"),
    ("export-log-not-png", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\nEXPORT fpa 'image.npy' LOG\n", 4, 1,
     "EXPORT ... LOG draws a picture, not a '.npy' file", "use a .png file name (the data files keep their values)"),
    ("export-log-stokes", "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\nEXPORT fpa 'image.png' STOKES LOG\n", 4, 1,
     "EXPORT ... LOG cannot be combined with STOKES (Q, U and V take both signs)",
     "export the Stokes images on a linear scale"),
    # ---- control flow and macros
    ("macro-recursive-direct", "MACRO a\n  CALL a\nEND MACRO\nCALL a\n", 2, 3, "recursive MACRO: a -> a", None),
    ("macro-recursive-indirect", "MACRO Vane\n  CALL b\nEND MACRO\nMACRO b\n  CALL vane\nEND MACRO\nCALL vane\n",
     5, 3, "recursive MACRO: Vane -> b -> Vane", None),
    ("do-step-0", "DO i = 1, 3, 0\n  PRINT i\nEND DO\n", 1, 14, "DO step of 0 would never end", None),
    ("string-condition", "IF ('a') THEN\nEND IF\n", 1, 5, "a condition must be a number, got a string", None),
    ("constant-assigned", "PI = 3\n", 1, 1, "PI is a constant and cannot be assigned", None),
    # ---- arithmetic
    ("division-by-zero", "d = 0\nx = 1 / d\n", 2, 9, "division by zero", None),
    ("sqrt-negative", "x = sqrt(-4)\n", 1, 10, "sqrt() of a negative number", None),
    ("asin-domain", "x = asin(2)\n", 1, 10, "asin() needs a value in [-1, 1], got 2", None),
    ("overflow-literal", "x = 1e400\n", 1, 5, "number out of range", None),
    ("overflow-arithmetic", "x = 1e200 * 1e200\n", 1, 5, "arithmetic overflow: the result is not a finite number", None),
    ("bad-format-spec", "x = 2\nPRINT '{x:q}'\n", 2, 7, "bad format 'q' in an interpolation", "use a Python format such as :.3f"),
    # ---- keywords and commands
    ("unknown-command", "TRACEE\n", 1, 1, "unknown command 'TRACEE'", "did you mean TRACE, INTERFACE or SURFACE?"),
    ("ambiguous-abbreviation", "CON ONLY a\n", 1, 1, "ambiguous abbreviation 'CON': it could be CONIC, CONSIDER",
     "write more letters"),
    ("ambiguous-abbreviation-2", "PLA Z 0\n", 1, 1, "ambiguous abbreviation 'PLA': it could be PLACE, PLANE",
     "write more letters"),
    ("abbreviation-2-letters", "SP POSITION\n", 1, 1, "unknown command 'SP'",
     "an abbreviation needs at least 3 letters: SPECTRUM, SPHERE, SPOTS"),
    ("keyword-typo", "SURFACE\n  PLANE Z 0 RECTT 1 1\nOBJECT a\n", 2, 13,
     "unexpected 'RECTT' in PLANE: expected RECT, DISK, ANNULUS, ELLIPSE", "did you mean RECT?"),
    ("keyword-typo-in-list", "COATING c REFLECT 0.9 TRANSMITT 0.1\n", 1, 23,
     "unknown keyword or undefined variable 'TRANSMITT' in COATING REFLECT", "did you mean TRANSMIT?"),
    # ---- syntax: the first error stops parsing
    ("unterminated-string", "PRINT 'abc\n", 1, 7, "unterminated string", "close it with ' on the same line"),
    ("unterminated-string-double", 'x = "abc\n', 1, 5, "unterminated string", 'close it with " on the same line'),
    ("unterminated-parenthesis", "SHIFT Z (d / 2 + 5\n", 1, 9, "unterminated parenthesis: '(' is never closed",
     "add the missing ')'"),
    ("end-do-without-do", "x = 1\nEND DO\n", 2, 1, "END DO without its opener: no DO is open", None),
    ("end-if-without-if", "END IF\n", 1, 1, "END IF without its opener: no IF is open", None),
    ("end-macro-without-macro", "END MACRO\n", 1, 1, "END MACRO without its opener: no MACRO is open", None),
    ("end-group-without-group", "END GROUP\n", 1, 1, "END GROUP without its opener: no GROUP is open", None),
    ("end-mismatch", "DO i = 1, 2\nEND IF\n", 2, 1, "END IF without its opener: the open block is DO",
     "close the DO first with END DO"),
    ("else-without-if", "x = 1\nELSE\n", 2, 1, "ELSE without IF", None),
    ("else-after-else", "IF (1) THEN\nELSE\nELSE\nEND IF\n", 3, 1, "ELSE after ELSE", None),
    ("do-without-end", "DO i = 1, 3\n  PRINT i\n", 1, 1, "DO without END DO", "close the block with END DO"),
    ("if-without-end", "IF (1) THEN\n", 1, 1, "IF without END IF", "close the block with END IF"),
    ("macro-in-macro", "MACRO a\nMACRO b\nEND MACRO\nEND MACRO\n", 2, 1, "a MACRO cannot be defined inside another MACRO", None),
    ("macro-parameter", "MACRO m 5\nEND MACRO\n", 1, 9, "a MACRO parameter must be a plain name", None),
    ("interpolation-unterminated", "i = 1\nPRINT 'VANE_{i'\n", 2, 13, "unterminated interpolation: '{' without its '}'",
     "write {{ for a literal brace"),
    ("interpolation-empty", "PRINT 'a{}'\n", 1, 9, "empty interpolation '{}'", None),
    ("interpolation-close", "PRINT 'a}'\n", 1, 9, "'}' without its '{'", "write }} for a literal brace"),
    ("ampersand-not-at-end", "PRINT 'a' & PRINT 'b'\n", 1, 11, "'&' continues a line only as the last thing on it", None),
    ("brace-outside-string", "PRINT {x}\n", 1, 7, "unexpected '{': braces belong inside a quoted string ('NAME_{i}')", None),
    ("single-bang", "PRINT 1 ! comment\n", 1, 9, "unexpected '!': a comment starts with '!!'", None),
    ("equals-in-command", "SHIFT Z = 5\n", 1, 9,
     "unexpected '=': an assignment is 'name = value' at the start of a statement", "compare with '=='"),
    ("line-ends-early", "x = 1 +\n", 1, 8, "the line ends too early", None),
    ("repeat-in-expression", "x = 3@0.9\n", 1, 6, "unexpected '@'", None),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_malformed_script(case):
    _, text, line, col, message, hint = case
    diags = diagnose(text)
    assert len(diags) == 1, "\n".join(d.render() for d in diags)
    d = diags[0]
    assert (d.span.line, d.span.col) == (line, col), d.render()
    assert d.message == message
    if isinstance(hint, tuple):
        assert d.hint is not None and all(h in d.hint for h in hint), d.hint
    else:
        assert d.hint == hint
    assert d.span.file == NAME
    assert_renders(d)


def test_at_least_forty_cases():
    assert len(CASES) >= 40 and len({c[0] for c in CASES}) == len(CASES)


def test_render_is_exact():
    (d,) = diagnose("UNITS MM\nSURFACE\n  PLANE Z 5 deg\nOBJECT a\n")
    assert d.render() == ("t.inr:3:11: error: expected a length, got 5 deg\n"
                          "    3 |   PLANE Z 5 deg\n"
                          "      |           ^^^^^")
    (d,) = diagnose("MEDIUM glas INDEX 1.5\nSURFACE\n PLANE Z 0\nOBJECT a\n INTERFACE TRANSMIT air glass\n")
    assert d.render() == ("t.inr:5:25: error: undefined medium 'glass'\n"
                          "    5 |  INTERFACE TRANSMIT air glass\n"
                          "      |                         ^^^^^\n"
                          "hint: did you mean glas?")


def test_duplicate_object_notes_the_first_definition():
    (d,) = diagnose("SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT M1\nSURFACE\n  PLANE Z 1 RECT 1 1\nOBJECT m1\n")
    assert [(n.line, n.col, text) for n, text in d.notes] == [(3, 1, "first defined here")]
    assert "t.inr:3:1: note: first defined here" in d.render()


def test_wrong_argument_count_notes_the_macro():
    (d,) = diagnose("MACRO vane angle width\n  PRINT angle\nEND MACRO\nCALL vane 1 2 3\n")
    assert d.message == "wrong number of arguments: macro vane takes 2 (angle width), got 3"
    assert [(n.line, text) for n, text in d.notes] == [(1, "defined here")]


def test_keyword_abbreviations_in_a_command():
    # a unique prefix of >= 3 letters is the keyword; 2 letters are not a keyword
    assert diagnose("SPOTS POS\n") == []
    assert diagnose("SURFACE\n  PLANE Z 0 ELL 1 2\nOBJECT a\n") == []
    (d,) = diagnose("SPOTS PO\n")
    assert (d.span.line, d.span.col, d.message) == (1, 7, "SPOTS: expected POSITION or DIRECTION or DIAGRAM, got 'PO'")
    assert d.hint is None


def test_ambiguous_keyword_inside_a_command_lists_the_candidates():
    (d,) = diagnose("MAP m LATLON DEFAULT LAN\n")
    assert (d.span.line, d.span.col) == (1, 22)
    assert d.message == "ambiguous abbreviation 'LAN': it could be LANDCOVER, LAND_MASK"
    assert d.hint == "write more letters"
    assert diagnose("MAP m LATLON DEFAULT LANDC\n") == []


# ---------------------------------------------------------------- one pass, no cascades
def test_independent_errors_are_all_reported_in_one_pass():
    text = ("x = y + 1\n"                            # 1: undefined variable
            "SURFACE\n"
            "  PLANE Z 5 deg\n"                      # 3: wrong unit kind
            "OBJECT a\n"
            "COATING c REFLECT 0.7 TRANSMIT 0.6\n"   # 5: R + T > 1
            "MEDIUM m SELLMEIER 1 2 3\n"             # 6: 3 values, not 6
            "TRACEE\n"                               # 7: unknown command
            "d = 1 / 0\n"                            # 8: division by zero
            "INTERFACE REFLECT\n")                   # 9: quiet: it modifies OBJECT a, whose surface failed
    diags = diagnose(text)
    got = [(d.span.line, d.message) for d in diags]
    assert got == [
        (1, "undefined variable 'y'"),
        (3, "expected a length, got 5 deg"),
        (5, "coating c: R + T = 0.7 + 0.6 = 1.3 > 1 on line 1 (550 nm)"),
        (6, "MEDIUM SELLMEIER expects 6 values for coefficients, got 3"),
        (7, "unknown command 'TRACEE'"),
        (8, "division by zero"),
    ], got


def test_errors_are_reported_in_source_order_and_counted():
    text = "".join(f"x{i} = undefined_{i}\n" for i in range(12))
    diags = diagnose(text)
    assert [d.span.line for d in diags] == list(range(1, 13))
    assert all(d.message == f"undefined variable 'undefined_{i}'" for i, d in enumerate(diags))


def test_a_syntax_error_stops_at_the_first_one():
    text = ("x = y\n"            # a semantic error: never reached
            "PRINT 'abc\n"       # the first syntax error
            "x = (1 + \n"        # a second one
            "END DO\n")
    diags = diagnose(text)
    assert len(diags) == 1
    assert (diags[0].span.line, diags[0].message) == (2, "unterminated string")


@pytest.mark.parametrize("text", [
    # a failed MEDIUM: its use is not "undefined"
    "MEDIUM glass INDEX -1.5\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT lens\n  INTERFACE TRANSMIT air glass\n",
    # a failed MODEL, used twice
    "MODEL m LAMBERTIAN 1.5\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT b\n  SCATTER MODEL m\n"
    "SURFACE\n  PLANE Z 1 RECT 1 1\nOBJECT c\n  SCATTER MODEL m\n",
    # a failed surface: its OBJECT, the object's modifiers and later uses of it are quiet
    "SURFACE\n  PLANE Z 0 RECTT 1 1\nOBJECT b\n  INTERFACE REFLECT\n  SHIFT Z 5\n  DETECTOR PIXELS 10\n"
    "EXPORT b 'x.npy'\n",
    # a failed OBJECT (its name does not evaluate): the block is closed, its modifiers are quiet
    "SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT 'V{k}'\n  SHIFT Z 1\n",
    # a duplicate GROUP still opens a group, so its END GROUP matches
    "GROUP g\nEND GROUP\nGROUP G\nEND GROUP\n",
    # a failed assignment: later uses of the variable are quiet
    "x = y + 1\nz = x * 2\nPRINT '{x}'\nSHIFT Z x\n",
    # a DO whose bounds fail: its variable is not "undefined" afterwards
    "DO i = 1, q\nEND DO\nPRINT i\n",
    # a WAVELENGTHS that fails (no unit): the per-line values after it do not all fail too
    "WAVELENGTHS 450 550 650\nCOATING c REFLECT 0.9 0.8 0.7\nMODEL m LAMBERTIAN 0.1 0.2 0.3\n",
    # a failed SPECTRUM, used by FLUX
    "SPECTRUM sun SOLAR TSI -5 W/m2\nGRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE DIRECTION 0 0 1\nFLUX SPECTRUM sun\n",
    # a failed TRACE CAMERA: it still used up its light (the next TRACE has one source, not two) and its
    # CAMERA_SUN variables are not "undefined"; the next TRACE sets them again
    "UNITS MM\nWAVELENGTHS 550 NM\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT fpa\n  INTERFACE ABSORB\n"
    "  DETECTOR PIXELS 4 4\nSURFACE\n  PLANE Z 10 RECT 5 5\nOBJECT win\n  INTERFACE TRANSMIT AIR AIR\n"
    "EMITTING SPHERE 0 0 1e6 1e3 RAYS 1\nFLUX TOTAL 1 W\nTRACE CAMERA fpa AIM win GUIDE 3\nx = CAMERA_SUN * 2\n"
    "EMITTING SPHERE 0 0 1e6 1e3 RAYS 1\nFLUX TOTAL 1 W\nTRACE CAMERA fpa AIM win\ny = CAMERA_SUN * 2\n",
])
def test_a_failed_definition_does_not_cascade(text):
    diags = diagnose(text)
    assert len(diags) == 1, "\n".join(d.render() for d in diags)


def test_a_use_of_a_failed_definition_in_a_later_pass_says_why():
    """The REPL runs line by line with a fresh report: there the use is explained, not silent."""
    it = Interpreter(check_only=True)
    it.run_text("MEDIUM glass INDEX -1\nx = y\n")
    assert len(it.diags.items) == 2
    got = []
    for text in ("SURFACE\n  PLANE Z 0\nOBJECT a\n  INTERFACE TRANSMIT air glass\n", "z = x\n"):
        it.diags = DiagnosticBag()       # as the REPL does for each entry
        it.run_text(text)
        got += [(d.span.line, d.span.col, d.message) for d in it.diags.items]
    assert got == [(4, 26, "medium 'glass' was not defined because its definition failed (see the earlier error)"),
                   (1, 5, "variable 'x' has no value: its assignment failed (see the earlier error)")]


def test_an_error_inside_a_do_loop_is_reported_once():
    diags = diagnose("DO i = 1, 5\n  x = y + i\n  SHIFT Z 5 deg\nEND DO\n")
    assert [(d.span.line, d.message) for d in diags] == [(2, "undefined variable 'y'"),
                                                          (3, "expected a length, got 5 deg")]


def test_an_error_inside_a_macro_called_many_times_is_reported_once():
    text = "MACRO m a\n  x = q + a\nEND MACRO\nDO i = 1, 4\n  CALL m i\nEND DO\nCALL m 7\n"
    diags = diagnose(text)
    assert [(d.span.line, d.span.col, d.message) for d in diags] == [(2, 7, "undefined variable 'q'")]


def test_an_error_that_depends_on_the_iteration_is_reported_for_each_value():
    # different messages are different errors: the repeat filter must not hide them
    diags = diagnose("DO i = 1, 3\n  x = asin(i + 1)\nEND DO\n")
    assert [d.message for d in diags] == ["asin() needs a value in [-1, 1], got 2",
                                          "asin() needs a value in [-1, 1], got 3",
                                          "asin() needs a value in [-1, 1], got 4"]


# ---------------------------------------------------------------- files: INCLUDE, MESH, MAP, non-text
def test_recursive_include_direct(tmp_path):
    (tmp_path / "self.inr").write_text("x = 1\nINCLUDE 'self.inr'\n")
    (d,) = diagnose_file(tmp_path / "self.inr")
    assert (d.span.line, d.span.col) == (2, 9)
    assert d.message == "recursive INCLUDE: self.inr -> self.inr"


def test_recursive_include_indirect(tmp_path):
    (tmp_path / "main.inr").write_text("INCLUDE 'a.inr'\n")
    (tmp_path / "a.inr").write_text("INCLUDE 'b.inr'\n")
    (tmp_path / "b.inr").write_text("x = 1\nINCLUDE 'a.inr'\n")
    (d,) = diagnose_file(tmp_path / "main.inr")
    assert d.span.file.endswith("b.inr") and (d.span.line, d.span.col) == (2, 9)
    assert d.message == "recursive INCLUDE: main.inr -> a.inr -> b.inr -> a.inr"


def test_missing_include(tmp_path):
    (tmp_path / "main.inr").write_text("x = 1\nINCLUDE 'nope.inr'\n")
    (d,) = diagnose_file(tmp_path / "main.inr")
    assert (d.span.line, d.span.col) == (2, 9)
    assert d.message == f"file not found: 'nope.inr' (looked in {tmp_path}), nor on the INCLUDE search path"


def test_errors_inside_an_included_file_name_that_file(tmp_path):
    (tmp_path / "main.inr").write_text("a = 1\nINCLUDE 'sub/part.inr'\nb = zz\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "part.inr").write_text("!! a part\nw = 2\nSHIFT Z 3 deg\n")
    diags = diagnose_file(tmp_path / "main.inr")
    assert [(d.span.file.replace("\\", "/").endswith("sub/part.inr"), d.span.line, d.span.col, d.message)
            for d in diags] == [(True, 3, 9, "expected a length, got 3 deg"),
                                (False, 3, 5, "undefined variable 'zz'")]
    part = diags[0].render().splitlines()
    assert part[0].endswith("part.inr:3:9: error: expected a length, got 3 deg")
    assert part[1] == "    3 | SHIFT Z 3 deg"


def test_a_syntax_error_inside_an_included_file(tmp_path):
    (tmp_path / "main.inr").write_text("INCLUDE 'part.inr'\nx = y\n")
    (tmp_path / "part.inr").write_text("PRINT 'open\n")
    diags = diagnose_file(tmp_path / "main.inr")
    assert [(d.span.file.endswith("part.inr"), d.span.line, d.message) for d in diags] == [
        (True, 1, "unterminated string"), (False, 2, "undefined variable 'y'")]


def test_include_of_a_file_with_nul_bytes(tmp_path):
    (tmp_path / "main.inr").write_text("x = 1\nINCLUDE 'bin.inr'\n")
    (tmp_path / "bin.inr").write_bytes(b"PRINT 1\n\x00\x01\x02binary")
    (d,) = diagnose_file(tmp_path / "main.inr")   # issue 21: the NUL is reported where it is, line and column
    assert d.span.file.endswith("bin.inr") and (d.span.line, d.span.col) == (2, 1)
    assert d.message.endswith("bin.inr is not a text script") and "binary" not in d.render()


def test_include_of_a_file_that_is_not_utf8(tmp_path):
    (tmp_path / "main.inr").write_text("INCLUDE 'latin1.inr'\n")
    (tmp_path / "latin1.inr").write_bytes(b"x = 1\nPRINT 'caf\xe9'\n")
    (d,) = diagnose_file(tmp_path / "main.inr")
    assert d.span.file.endswith("latin1.inr") and (d.span.line, d.span.col) == (2, 11)
    assert d.message.endswith("latin1.inr is not a UTF-8 text file (byte 0xe9 at offset 16)")


def test_a_script_with_nul_bytes(tmp_path):
    p = tmp_path / "bin.inr"
    p.write_bytes(b"\x00\x00\x00")
    (d,) = diagnose_file(p)
    assert d.render().startswith(f"{p}:1:1: error: a NUL byte (\\0) here: {p} is not a text script")


def test_missing_mesh_file(tmp_path):
    (tmp_path / "m.inr").write_text("SURFACE\n  MESH 'baffle.stl'\nOBJECT baffle\n  INTERFACE ABSORB\n")
    (d,) = diagnose_file(tmp_path / "m.inr")
    assert (d.span.line, d.span.col) == (2, 8)
    assert d.message == f"file not found: 'baffle.stl' (looked in {tmp_path})"


def test_broken_mesh_file(tmp_path):
    (tmp_path / "broken.stl").write_text("solid x\nthis is not an stl file\n")
    (tmp_path / "m.inr").write_text("SURFACE\n  MESH 'broken.stl'\nOBJECT baffle\n")
    (d,) = diagnose_file(tmp_path / "m.inr")
    assert (d.span.line, d.span.col) == (2, 8)
    assert d.message == "mesh 'broken.stl' has no triangles"


@pytest.mark.parametrize("shape, message", [
    ((10, 10), "map 'm.npy' has shape (10, 10): a global LATLON grid has twice as many columns (longitude, 360 deg) "
               "as rows (latitude, 180 deg)"),
    ((2, 4, 8), "map 'm.npy' has shape (2, 4, 8); a LATLON map is 2-D (lat rows, lon columns)"),
])
def test_map_of_the_wrong_shape(tmp_path, shape, message):
    np.save(tmp_path / "m.npy", np.zeros(shape))
    (tmp_path / "s.inr").write_text("MAP cover LATLON 'm.npy'\n")
    (d,) = diagnose_file(tmp_path / "s.inr")
    assert (d.span.line, d.span.col, d.message) == (1, 18, message)


def test_map_that_is_not_an_array(tmp_path):
    (tmp_path / "m.npy").write_bytes(b"not numpy at all")
    (tmp_path / "s.inr").write_text("MAP cover LATLON 'm.npy'\n")
    (d,) = diagnose_file(tmp_path / "s.inr")
    assert (d.span.line, d.span.col) == (1, 18)
    assert d.message.startswith("cannot read map 'm.npy': ")


def test_a_good_map_and_mesh_are_accepted(tmp_path):
    np.save(tmp_path / "m.npy", np.zeros((4, 8), dtype=np.int16))
    (tmp_path / "tri.stl").write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
        "endsolid t\n")
    (tmp_path / "s.inr").write_text("MAP cover LATLON 'm.npy'\nSURFACE\n  MESH 'tri.stl'\nOBJECT t\n")
    assert diagnose_file(tmp_path / "s.inr") == []


# ---------------------------------------------------------------- regressions found while writing these tests
def test_conic_radius_is_not_overwritten_by_a_disk_aperture():
    """CONIC's RADIUS and DISK's radius shared a parameter label: DISK 150 silently became the radius."""
    it = Interpreter(check_only=True)
    it.run_text("SURFACE\n  CONIC Z 0 RADIUS 100 CONIC 0 DISK 50\nOBJECT m\n")
    assert not it.diags
    (surf,) = it.state.objects["M"].surfaces
    assert surf.params["c"] == pytest.approx(1 / 0.1, rel=1e-15)    # 1 / (100 mm)
    assert surf.aperture.params == pytest.approx((0.05,), rel=1e-15)


def test_no_two_parameters_of_a_command_share_a_label():
    """Bound values are stored by label: two parameters with one label overwrite each other."""
    from irtlang.lang.commands import TABLE
    from irtlang.lang.spec import Variants

    def paths(form, params, clauses, out, where):
        params, clauses = list(params), list(clauses) + list(form.clauses)
        for p in form.params:
            if isinstance(p, Variants):
                for kw, sub in p.options.items():
                    paths(sub, params, clauses, out, f"{where} {kw}")
                if p.default is not None:
                    paths(p.default, params, clauses, out, where)
                return
            params.append(p)
        out.append((where, params, clauses))

    clashes = []
    for head, c in TABLE.items():
        if c.form is None:
            continue
        out: list = []
        paths(c.form, [], [], out, head)
        for where, params, clauses in out:
            labels = ([p.label for p in params] + [p.label for cl in clauses for p in cl.params]
                      + [cl.kw.lower() for cl in clauses if not cl.params])
            dup = sorted({x for x in labels if labels.count(x) > 1})
            if dup:
                clashes.append((where, dup))
    assert clashes == []


def test_a_call_with_no_arguments():
    """CALL of a macro without parameters used to fail with 'CALL needs args'."""
    assert diagnose("MACRO hello\n  PRINT 'hi'\nEND MACRO\nCALL hello\n") == []


def test_an_unreadable_script_is_an_input_error(tmp_path):
    from irtlang.lang.parser import read_source

    with pytest.raises(IrtError) as ei:
        read_source(tmp_path, "x.inr")  # a folder: reading it fails with an OSError
    (d,) = ei.value.diagnostics
    assert d.render().startswith("x.inr: error: cannot read x.inr: ")
