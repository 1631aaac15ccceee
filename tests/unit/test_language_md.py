"""Conformance with LANGUAGE.md, the language contract (read at test time from shared/ beside the clone, or
from the copy in tests/data/ in a plain clone).

Part 1, mechanical: every fenced code block and every inline code span of LANGUAGE.md that looks like a
command is expanded and checked with the interpreter; each resulting snippet must give no diagnostic.
The documentation notation is expanded mechanically:

* ``[...]`` (optional): each block is checked once with every optional part included and once with every
  optional part left out;
* ``a | b`` (alternatives, on a whole line or inside ``[...]``): each alternative is checked;
* an alternative given in a comment (``!! or CONSIDER ALL``, ``(or: SOURCE FIELD 0.05 0.02 deg)``) is checked
  in place of its line;
* ``...`` (placeholder): dropped; where it stands for statements it becomes a statement separator, and
  ``(...)`` (an elided condition) becomes ``(0)``.

Each snippet runs after a prelude that defines the names the snippets use (media glass/water, coating al,
spectrum sun, models paint/water/forest/grass/desert/snow, map cover, objects earth/fpa/M2/vanes/obj, group
telescope, a traceable source, the variables d, step and i); a prelude entry is left out when the snippet
defines that name itself. Input files (water.csv, grass.csv, landcover.npy, baffle.stl, telescope.inr, run.h5)
are made in a temporary folder, next to the snippet. A one-line snippet gets the context its command needs
(a SURFACE block around a surface, a GRID before a SOURCE).

Section 7 (Sources) is a catalogue of alternative source commands rather than one script (two GRIDs in a row
are an error: each GRID takes its SOURCE), so its lines are checked one by one.

Part 2: specific meanings stated by LANGUAGE.md, asserted on the scene model.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from irtlang.lang.diagnostics import IrtError
from irtlang.lang.interp import Interpreter

# the live contract beside the clone (shared/LANGUAGE.md) where it is, else the copy kept in the repository
# (tests/data/LANGUAGE.md), so that a plain clone runs these tests too
_SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "LANGUAGE.md"
LANGUAGE_MD = _SHARED if _SHARED.is_file() else Path(__file__).resolve().parents[1] / "data" / "LANGUAGE.md"


CATALOGUE_SECTIONS = ("7. Sources",)


# ==================================================================== helpers
def run(text: str, base: Path, name: str = "<snippet>") -> tuple[Interpreter, list]:
    """Check `text` as a script in folder `base` (as `irt check` does); the interpreter and its diagnostics."""
    it = Interpreter(check_only=True)
    it.base_dir = base
    it.include_stack = [base / "snippet.inr"]
    try:
        it.run_text(text, name)
    except IrtError as e:
        return it, list(e.diagnostics)
    return it, list(it.diags.items)


def ok(text: str, base: Path) -> Interpreter:
    it, diags = run(text, base)
    assert not diags, _report(text, diags)
    return it


def errors(text: str, base: Path) -> list:
    _, diags = run(text, base)
    assert diags, "expected an error from:\n" + text
    return diags


def _report(text: str, diags) -> str:
    numbered = "\n".join(f"{n:4d} | {ln}" for n, ln in enumerate(text.splitlines(), 1))
    return "diagnostics:\n" + "\n".join(d.render() for d in diags) + "\n--- script ---\n" + numbered


STL_BOX = """solid box
facet normal 0 0 -1
 outer loop
  vertex 0 0 0
  vertex 1 1 0
  vertex 1 0 0
 endloop
endfacet
facet normal 0 0 -1
 outer loop
  vertex 0 0 0
  vertex 0 1 0
  vertex 1 1 0
 endloop
endfacet
facet normal 0 -1 0
 outer loop
  vertex 0 0 0
  vertex 1 0 0
  vertex 0 0 1
 endloop
endfacet
facet normal -1 0 0
 outer loop
  vertex 0 0 0
  vertex 0 0 1
  vertex 0 1 0
 endloop
endfacet
endsolid box
"""


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("language_md")
    (d / "water.csv").write_text("wavelength_nm,n,k\n200,1.36,0\n3000,1.30,1e-6\n")
    (d / "grass.csv").write_text("wavelength_nm,value\n200,0.05\n700,0.05\n750,0.45\n3000,0.45\n")
    cls = (np.arange(90 * 180).reshape(90, 180) % 5).astype(np.uint8)       # classes 0..4
    np.save(d / "landcover.npy", cls)
    (d / "baffle.stl").write_text(STL_BOX)
    (d / "telescope.inr").write_text("telescope_included = 1\n")
    (d / "run.h5").write_bytes(b"")     # LOAD RAYS only needs the file to exist at check time
    return d


# ==================================================================== reading LANGUAGE.md
def _md() -> str:
    return LANGUAGE_MD.read_text(encoding="utf-8")


def code_blocks() -> list[tuple[str, str]]:
    """(section heading, block text) of every fenced code block."""
    out, section, cur = [], "", None
    for line in _md().splitlines():
        if cur is None:
            if line.startswith("## "):
                section = line[3:].strip()
            elif line.strip().startswith("```"):
                cur = []
        elif line.strip().startswith("```"):
            out.append((section, "\n".join(cur)))
            cur = None
        else:
            cur.append(line)
    return out


def inline_spans() -> list[tuple[str, str]]:
    """(section heading, span) of every `inline` code span outside fenced blocks."""
    out, section, in_block = [], "", False
    for line in _md().splitlines():
        if line.strip().startswith("```"):
            in_block = not in_block
            continue
        if in_block:
            continue
        if line.startswith("## "):
            section = line[3:].strip()
        out.extend((section, m) for m in re.findall(r"`([^`\n]+)`", line))
    return out


# ==================================================================== notation expansion
def split_comment(line: str) -> tuple[str, str]:
    """(code, comment) of a line: the comment starts at a `!!` outside quotes."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif line.startswith("!!", i):
            return line[:i], line[i:]
    return line, ""


def _split_top(code: str, sep: str = "|") -> list[str]:
    """Split at `sep` outside brackets and quotes."""
    parts, depth, quote, cur = [], 0, None, []
    for ch in code:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif ch == sep and depth == 0:
            parts.append("".join(cur))
            cur = []
            continue
        cur.append(ch)
    parts.append("".join(cur))
    return [p.strip() for p in parts]


_OPT = re.compile(r"\[([^\[\]]*)\]")


def expand_code(code: str) -> tuple[str, str, list[str]]:
    """(with every option, without any option, other variants) of one line of code in the notation."""
    code = code.replace("(...)", "(0)")
    code = re.sub(r"(?<![.\w])\.\.\.(?![.\w])", ";", code)
    alts = _split_top(code)
    variants: list[str] = []
    first_max = first_min = None
    for a in alts:
        opts = list(_OPT.finditer(a))
        choices = [_split_top(m.group(1)) for m in opts]
        mx = _OPT.sub(lambda m: _split_top(m.group(1))[0], a)
        mn = _OPT.sub("", a)
        if first_max is None:
            first_max, first_min = mx, mn
        else:
            variants += [mx, mn]
        for k, ch in enumerate(choices):
            for c in ch[1:]:
                i = iter(range(len(opts)))
                variants.append(_OPT.sub(lambda m: c if next(i) == k else _split_top(m.group(1))[0], a))
    tidy = lambda s: re.sub(r"[ \t]+", " ", s).rstrip()
    return tidy(first_max), tidy(first_min), list(dict.fromkeys(tidy(v) for v in variants))


def comment_alternative(comment: str) -> str | None:
    """`!! or CONSIDER ALL` / `(or: SOURCE FIELD 0.05 0.02 deg)`: a command given as an alternative."""
    from irtlang.lang.commands import TABLE

    m = re.search(r"\bor:?\s+(.*)", comment)
    if not m:
        return None
    text = re.split(r"[()]", m.group(1))[0].strip()
    head = text.split()[0] if text.split() else ""
    return text if head.isupper() and head in TABLE else None


def block_variants(block: str) -> list[str]:
    """The scripts a block stands for: all options in, all options out, and each alternative of each line."""
    lines = block.splitlines()
    per_line = []
    for ln in lines:
        code, comment = split_comment(ln)
        mx, mn, alts = expand_code(code)
        alt = comment_alternative(comment)
        if alt:
            alts.append(expand_code(alt)[0])
        per_line.append((mx + " " + comment if comment else mx, mn + " " + comment if comment else mn, alts))
    out = ["\n".join(p[0] for p in per_line), "\n".join(p[1] for p in per_line)]
    for i, (_, _, alts) in enumerate(per_line):
        for a in alts:
            out.append("\n".join(a if j == i else p[0] for j, p in enumerate(per_line)))
    return list(dict.fromkeys(out))


def line_variants(block: str) -> list[str]:
    """For a catalogue block: every variant of every line, each on its own."""
    out = []
    for ln in block.splitlines():
        code, comment = split_comment(ln)
        if not code.strip():
            continue
        mx, mn, alts = expand_code(code)
        alt = comment_alternative(comment)
        out += [mx, mn] + alts + ([expand_code(alt)[0]] if alt else [])
    return list(dict.fromkeys(v for v in out if v.strip()))


# ==================================================================== prelude and context
PRELUDE = [  # (namespace, name, text)
    (None, None, "WAVELENGTHS 450 550 650 NM\nd = 10\nstep = 1\ni = 3"),
    ("medium", "GLASS", "MEDIUM glass INDEX 1.5168"),
    ("medium", "WATER", "MEDIUM water INDEX 1.333"),
    ("coating", "AL", "COATING al REFLECT 0.91"),
    ("spectrum", "SUN", "SPECTRUM sun SOLAR"),
    ("spectrum", "NAME", "SPECTRUM name TABLE 'grass.csv'"),        # `SPECTRUM name`, a per-line value
    ("model", "PAINT", "MODEL paint LAMBERTIAN 0.5"),
    ("model", "WATER", "MODEL water LAMBERTIAN 0.05"),
    ("model", "FOREST", "MODEL forest LAMBERTIAN 0.1"),
    ("model", "GRASS", "MODEL grass LAMBERTIAN 0.2"),
    ("model", "DESERT", "MODEL desert LAMBERTIAN 0.3"),
    ("model", "SNOW", "MODEL snow LAMBERTIAN 0.9"),
    ("map", "COVER", "MAP cover LATLON 'landcover.npy'"),
    ("group", "TELESCOPE", "GROUP telescope\nEND GROUP"),
    ("object", "EARTH", "SURFACE\n  ELLIPSOID 6378.137 km 6378.137 km 6356.752 km AT 0 0 -0.18 AU\nOBJECT earth"),
    ("object", "FPA", "SURFACE\n  PLANE Z 100 RECT 5 5\nOBJECT fpa\n  DETECTOR PIXELS 16"),
    ("object", "M2", "SURFACE\n  PLANE Z 50 DISK 20\nOBJECT M2"),
    ("object", "VANES", "SURFACE\n  TUBE Z 0 30 50 30\nOBJECT vanes"),
    ("object", "OBJ", "SURFACE\n  PLANE Z 80 RECT 5 5\nOBJECT obj\n  DETECTOR PIXELS 8"),   # stays current
    (None, None, "GRID DISK Z -10 10 RAYS 100\nSOURCE DIRECTION 0 0 1"),
]
DEFINING = {"MEDIUM": "medium", "COATING": "coating", "MODEL": "model", "MAP": "map", "GROUP": "group",
            "OBJECT": "object", "SPECTRUM": "spectrum"}


def defined_names(snippet: str) -> set:
    out = set()
    for ln in snippet.splitlines():
        for stmt in split_comment(ln)[0].split(";"):
            w = stmt.split()
            if len(w) >= 2 and w[0].upper() in DEFINING and not (w[0].upper() == "SPECTRUM" and w[1].upper() == "OF"):
                out.add((DEFINING[w[0].upper()], w[1].strip("'\"").upper()))
    return out


def with_prelude(snippet: str) -> str:
    mine = defined_names(snippet)
    pre = [t for ns, nm, t in PRELUDE if ns is None or (ns, nm) not in mine]
    return "\n".join(pre) + "\n!! ---- snippet ----\n" + snippet + "\n"


def in_context(snippet: str) -> str:
    """What a one-line snippet needs around it to be a complete script."""
    from irtlang.lang.commands import TABLE
    from irtlang.plugins.surfaces import REGISTRY as SURFACES

    w = snippet.split()
    head = w[0].upper()
    if head in SURFACES:
        return f"SURFACE\n  {snippet}\nOBJECT snippet_object"
    if head == "SURFACE":
        return f"{snippet}\n  PLANE Z 0\nOBJECT snippet_object"
    if head == "OBJECT":
        return f"SURFACE\n  PLANE Z 0\n{snippet}"
    if head == "SOURCE":
        return f"GRID DISK Z -10 10 RAYS 100\n{snippet}"
    if head == "GROUP":
        return f"{snippet}\nEND GROUP"
    if head == "SPECTRUM" and len(w) == 2 and w[1].upper() != "OF":
        return f"COATING snippet_coating REFLECT {snippet}"       # `SPECTRUM name` as a per-line value
    assert head in TABLE
    return snippet


def _complete_alone(head: str) -> bool:
    from irtlang.lang.commands import TABLE

    f = TABLE[head].form
    return f is not None and not f.params and not any(c.required for c in f.clauses)


def classify(section: str, span: str) -> str:
    """command | value | name | other, for an inline code span."""
    from irtlang.lang.commands import TABLE

    w = span.split()
    if not w:
        return "other"
    if w[0].upper() in TABLE and re.fullmatch(r"[A-Za-z]+", w[0]):
        return "command" if len(w) > 1 or _complete_alone(w[0].upper()) else "other"
    if re.fullmatch(r"-?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(\s*[A-Za-z/%0-9]+)?", span) and "@" not in span:
        return "value"
    if re.fullmatch(r"'[^']*'|\"[^\"]*\"", span) or (section.startswith("1.") and re.fullmatch(r"[A-Za-z_]\w*", span)):
        return "name"
    return "other"


# ==================================================================== Part 1: mechanical checks
def _snippets() -> list[tuple[str, str]]:
    out = []
    for k, (section, block) in enumerate(code_blocks()):
        if section in CATALOGUE_SECTIONS:
            for v in line_variants(block):
                out.append((f"block{k}[{section}] line: {v.strip()}", with_prelude(in_context(v.strip()))))
        else:
            for j, v in enumerate(block_variants(block)):
                out.append((f"block{k}[{section}] variant {j}", with_prelude(v)))
    for section, span in inline_spans():
        kind = classify(section, span)
        if kind == "command":
            out.append((f"inline `{span}`", with_prelude(in_context(span))))
        elif kind == "value":
            out.append((f"inline `{span}`", with_prelude(f"snippet_value = {span}")))
        elif kind == "name":
            out.append((f"inline `{span}`", with_prelude(f"SURFACE\n  PLANE Z 0\nOBJECT {span}")))
    return list(dict((t, (n, t)) for n, t in out).values())


def _snippets_or_none():
    return _snippets()


def test_contract_sections_are_where_expected():
    heads = {s for s, _ in code_blocks()}
    for s in CATALOGUE_SECTIONS:
        assert s in heads, f"LANGUAGE.md no longer has the section {s!r}: revisit CATALOGUE_SECTIONS"
    assert len(code_blocks()) >= 8


def test_inline_spans_are_classified():
    kinds = {}
    for section, span in inline_spans():
        kinds.setdefault(classify(section, span), set()).add(span)
    for span in ("SPOTS POS", "trace", "SHIFT Z (d/2 + 5 mm)", "PLANE Z 150", "OBJECT name", "SPECTRUM name",
                 "SPECTRUM OF obj 'f.csv'", "EXPORT obj 'f.npy'", "STATS LEDGER 'f.csv'", "SAVE RAYS 'f.h5'"):
        assert span in kinds.get("command", set()), span
    for span in ("550nm", "550 NM", "0.118 deg", "6378.137 km", "0.18 AU", "7 m/s", "1360.5 W/m2", ".5", "1e-3"):
        assert span in kinds.get("value", set()), span
    for span in ("'M1'", "m1", "fpa_2", "'Primary mirror'", '"x"', "'VANE_{i}'"):
        assert span in kinds.get("name", set()), span


def test_notation_expansion():
    assert expand_code("DO i = 1, 4 [, step]")[:2] == ("DO i = 1, 4 , step", "DO i = 1, 4")
    assert expand_code("STATS [LEDGER | POSITION | DIRECTION]") == (
        "STATS LEDGER", "STATS", ["STATS POSITION", "STATS DIRECTION"])
    mx, mn, alts = expand_code("INTERFACE REFLECT | INTERFACE ABSORB | INTERFACE TRANSMIT air glass")
    assert mx == "INTERFACE REFLECT" and "INTERFACE TRANSMIT air glass" in alts
    assert expand_code("IF (d > 1000) THEN ... ELSE IF (...) THEN ... ELSE ... END IF")[0] == \
        "IF (d > 1000) THEN ; ELSE IF (0) THEN ; ELSE ; END IF"
    assert comment_alternative("!! collimated along a direction (or: SOURCE FIELD 0.05 0.02 deg)") == \
        "SOURCE FIELD 0.05 0.02 deg"
    assert comment_alternative("!! or CONSIDER ALL") == "CONSIDER ALL"
    assert comment_alternative("!! disk of radius 150: a regular lattice of about RAYS rays, or random") is None


@pytest.mark.parametrize("name,script", _snippets_or_none(), ids=[n for n, _ in _snippets_or_none()])
def test_contract_snippet(name, script, base):
    _, diags = run(script, base, "LANGUAGE.md snippet")
    assert not diags, f"{name}\n" + _report(script, diags)


# ==================================================================== Part 2: meanings
def obj(it, name):
    return it.state.objects[name.upper()]


def cols(R):
    """The columns of a row-major 3x3: the world directions of local x, y, z."""
    return [tuple(R[3 * i + j] for i in range(3)) for j in range(3)]


def test_repeat_is_n_copies(base):
    it = ok("WAVELENGTHS 450 550 650 NM\nCOATING a REFLECT 3@0.9\nCOATING b REFLECT 0.9 0.9 0.9", base)
    assert it.state.coatings["A"].reflect == (0.9, 0.9, 0.9) == it.state.coatings["B"].reflect


def test_units_attached_or_spaced(base):
    it = ok("a = 550nm\nb = 550 NM\nc = 0.118 deg\nd = 6378.137 km\ne1 = 0.18 AU\nf = 7 m/s\ng = 1360.5 W/m2\n"
            "h = 12\nk = -3.5\nl = 1e-3\nm = .5", base)
    v = it.lookup
    assert v("a") == v("b") and v("a").value == pytest.approx(550e-9)
    assert v("c").value == pytest.approx(math.radians(0.118))
    assert v("d").value == pytest.approx(6378137.0)
    assert v("e1").value == pytest.approx(0.18 * 1.495978707e11)
    assert v("f").value == 7.0 and v("f").dim == (1, 0, -1, 0, 0)
    assert v("g").value == 1360.5 and v("g").dim == (-2, 0, 0, 1, 0)
    assert [v(x).value for x in ("h", "k", "l", "m")] == [12.0, -3.5, 1e-3, 0.5]
    # every listed unit is accepted
    for u in "NM UM MM CM M KM AU IN DEG RAD MRAD URAD ARCSEC S MIN H W W/M2 M/S K".split():
        ok(f"x = 2 {u}\ny = 2{u.lower()}", base)


def test_bare_length_takes_units(base):
    it = ok("SURFACE\n  PLANE Z 5\nOBJECT a\nUNITS CM\nSURFACE\n  PLANE Z 5\nOBJECT b\nSURFACE\n  PLANE Z 5 mm\n"
            "OBJECT c", base)
    z = lambda n: obj(it, n).surfaces[0].frame.T[2]
    assert z("a") == pytest.approx(0.005)      # default UNITS MM
    assert z("b") == pytest.approx(0.05)
    assert z("c") == pytest.approx(0.005)


def test_wrong_unit_kind_message(base):
    d = errors("SURFACE\n  PLANE Z 0\nOBJECT a\nSHIFT Z 5 deg", base)
    assert [x.message for x in d] == ["expected a length, got 5 deg"]


def test_angles_in_degrees(base):
    it = ok("s = sin(30)\nc = cos(60)\nt = tan(45)\na = asin(0.5)\nb = acos(0.5)\nn = atan(1)\nm = atan2(1, 1)\n"
            "SURFACE\n  PLANE Z 0\nOBJECT o\nROTATE Z asin(0.5)", base)
    v = lambda n: it.lookup(n).value
    assert v("s") == pytest.approx(0.5) and v("c") == pytest.approx(0.5) and v("t") == pytest.approx(1.0)
    assert it.lookup("a").dim == (0, 1, 0, 0, 0) and v("a") == pytest.approx(math.radians(30))
    assert v("b") == pytest.approx(math.radians(60)) and v("n") == pytest.approx(math.radians(45))
    assert v("m") == pytest.approx(math.radians(45))
    assert it.lookup("a").describe() == "30 deg"
    R = obj(it, "o").transform.R
    assert cols(R)[0] == pytest.approx((math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0))
    # the result of asin compares with a bare number as degrees
    ok("IF (asin(0.5) == 30) THEN\nELSE\n  NO_SUCH_COMMAND\nEND IF", base)


def test_functions_constants_operators(base):
    it = ok("a = sqrt(16) + exp(0) + log(E) + log10(100) + abs(-2) + min(3, 1, 2) + max(1, 5) + floor(2.7) + "
            "ceil(2.2) + round(2.4) + 2^3\nb = (1 < 2) AND (2 <= 2) AND (3 > 2) AND (3 >= 3) AND (1 == 1) AND "
            "(1 != 2) AND NOT (1 > 2) OR 0\nc = PI\nd = 6 / 3 * 2 - 1", base)
    assert it.lookup("a").value == pytest.approx(4 + 1 + 1 + 2 + 2 + 1 + 5 + 2 + 3 + 2 + 8)
    assert it.lookup("b").value == 1.0 and it.lookup("c").value == pytest.approx(math.pi)
    assert it.lookup("d").value == pytest.approx(3.0)


def test_interpolated_names(base):
    it = ok("i = 3\nSURFACE\n  PLANE Z 0\nOBJECT 'VANE_{i}'\nDO k = 1, 2\n  SURFACE\n    PLANE Z (k)\n"
            "  OBJECT 'V_{k}'\nEND DO", base)
    assert {"VANE_3", "V_1", "V_2"} <= set(it.state.objects)
    assert obj(it, "vane_3").name == "VANE_3"


def test_names_case_insensitive_display_kept(base):
    it = ok("SURFACE\n  PLANE Z 0\nOBJECT 'M1'\nSURFACE\n  PLANE Z 1\nOBJECT 'Primary mirror'\n"
            "SURFACE\n  PLANE Z 2\nOBJECT \"x\"\nSURFACE\n  PLANE Z 3\nOBJECT fpa_2\nspectrum of m1\n"
            "SPECTRUM OF 'primary MIRROR'\nconsider only X FPA_2", base)
    assert obj(it, "m1").name == "M1" and obj(it, "PRIMARY MIRROR").name == "Primary mirror"
    assert [s.params["object"] for s in it.steps[:2]] == ["M1", "PRIMARY MIRROR"]


def test_keyword_abbreviations(base):
    it = ok("SPOTS POS\nSPOTS DIR\nspo position\nSURF\n  PLAN Z 0 RECT 1 1\nOBJ a\nWAV 450 550 NM", base)
    assert [s.params["what"] for s in it.steps] == ["POSITION", "DIRECTION", "POSITION"]
    assert it.state.wavelengths_nm == (450.0, 550.0)
    d = errors("PLA telescope AT 0 0 0", base)
    assert "ambiguous abbreviation 'PLA': it could be PLACE, PLANE" in d[0].message
    d = errors("SURFACE\n  PLANE Z 0\nOBJECT a\nCON ONLY a", base)
    assert "CONIC" in d[0].message and "CONSIDER" in d[0].message
    errors("SP POSITION", base)               # fewer than 3 letters is no keyword


def test_case_insensitive_keywords(base):
    it = ok("surface\n  plane z 0 rect 1 1\nobject a\ngrid disk z -1 1 rays 10\nsource direction 0 0 1\ntrace", base)
    assert it.steps[-1].kind == "TRACE"


def test_lines_semicolons_continuations_comments(base):
    it = ok("d=1200 ; f = 5   !! two statements\nWAVELENGTHS 450 &\n   550 & !! a comment after &\n   650 NM", base)
    assert it.lookup("d").value == 1200 and it.lookup("f").value == 5
    assert it.state.wavelengths_nm == (450.0, 550.0, 650.0)


def test_wavelengths_trailing_unit_and_range(base):
    it = ok("WAVELENGTHS 450 550 650 NM", base)
    assert it.state.wavelengths_nm == (450.0, 550.0, 650.0)
    it = ok("WAVELENGTHS RANGE 300 2500 295 NM", base)
    w = it.state.wavelengths_nm
    assert len(w) == 295 and w[0] == 300.0 and w[-1] == 2500.0
    assert np.allclose(np.diff(w), 2200 / 294)


def test_per_line_values(base):
    it = ok("WAVELENGTHS 450 550 650 NM\nCOATING a REFLECT 0.9\nCOATING b REFLECT 0.7 0.8 0.9\n"
            "SPECTRUM veg TABLE 'grass.csv'\nCOATING c REFLECT SPECTRUM veg", base)
    c = it.state.coatings
    assert c["A"].reflect == (0.9,) * 3 and c["B"].reflect == (0.7, 0.8, 0.9)
    assert c["C"].reflect == pytest.approx(it.state.spectra["VEG"].on_lines)
    # energy-conserving band means: the 650 nm band (600-700 nm) of a flat 0.05 is 0.05
    assert c["C"].reflect[2] == pytest.approx(0.05)
    errors("WAVELENGTHS 450 550 650 NM\nCOATING a REFLECT 0.9 0.8", base)


def test_control_flow(base):
    it = ok("n = 0\nDO i = 1, 4\n  n = n + 1\nEND DO\nm = 0\nDO j = 1, 4, 2\n  m = m + j\nEND DO\n"
            "d = 1200\nIF (d > 1000) THEN\n  r = 1\nELSE IF (d > 10) THEN\n  r = 2\nELSE\n  r = 3\nEND IF\n"
            "IF (d < 0) STOP", base)
    assert it.lookup("n").value == 4 and it.lookup("m").value == 1 + 3 and it.lookup("r").value == 1


def test_macro_and_call(base):
    it = ok("MACRO vane angle width\n  SURFACE\n    PLANE Z 0 RECT (width) 5\n  OBJECT 'VANE_{angle}'\n"
            "  ROTATE Z angle\nEND MACRO\nCALL vane 45 8\nMACRO named nm\n  SURFACE\n    PLANE Z 0\n"
            "  OBJECT '{nm}'\nEND MACRO\nCALL named fpa", base)
    v = obj(it, "VANE_45")
    assert v.surfaces[0].aperture.params[0] == pytest.approx(0.008)
    assert cols(v.transform.R)[0] == pytest.approx((math.sqrt(0.5), math.sqrt(0.5), 0.0))
    assert "FPA" in it.state.objects          # a bare name passes as text


def test_include_relative_to_including_file(tmp_path, monkeypatch):
    (tmp_path / "a" / "sub").mkdir(parents=True)
    (tmp_path / "a" / "main.inr").write_text("INCLUDE 'sub/one.inr'\n")
    (tmp_path / "a" / "sub" / "one.inr").write_text("INCLUDE 'two.inr'\nSPECTRUM t TABLE 't.csv'\n")
    (tmp_path / "a" / "sub" / "two.inr").write_text("v = 2\n")
    (tmp_path / "a" / "sub" / "t.csv").write_text("400,1\n700,1\n")
    (tmp_path / "a" / "two.inr").write_text("v = 99\n")        # a decoy beside main.inr
    (tmp_path / "two.inr").write_text("v = 98\n")              # a decoy in the working directory
    monkeypatch.chdir(tmp_path)
    it = Interpreter(check_only=True)
    it.run_file(tmp_path / "a" / "main.inr")
    assert not it.diags, [d.render() for d in it.diags.items]
    assert it.lookup("v").value == 2 and "T" in it.state.spectra


def test_stop_ends_the_script(base):
    it = ok("x = 1\nSTOP\nx = 2\nNO_SUCH_COMMAND 1", base)
    assert it.lookup("x").value == 1
    it = ok("DO i = 1, 10\n  IF (i == 3) STOP\n  last = i\nEND DO\nNO_SUCH_COMMAND", base)
    assert it.lookup("last").value == 2


def test_system_new_and_reset(base):
    it = ok("UNITS CM\nSURFACE\n  PLANE Z 0\nOBJECT a\nSYSTEM NEW\nSURFACE\n  PLANE Z 1\nOBJECT a", base)
    assert it.state.units == "MM" and obj(it, "a").surfaces[0].frame.T[2] == pytest.approx(0.001)
    it = ok("SURFACE\n  PLANE Z 0\nOBJECT a\nGRID DISK Z 0 1 RAYS 10\nSOURCE DIRECTION 0 0 1\nRESET", base)
    assert "A" in it.state.objects and not it.state.sources


def test_materials(base):
    it = ok("WAVELENGTHS 587.6 NM\nMEDIUM glass INDEX 1.5168 ABSORB 0.001\n"
            "MEDIUM bk7 SELLMEIER 1.0396 0.2318 1.0105 0.0060007 0.020018 103.56\nMEDIUM water TABLE 'water.csv'\n"
            "COATING al REFLECT 0.91\nCOATING bare FRESNEL\nSPECTRUM sun SOLAR TSI 1360.5 W/m2", base)
    m = it.state.media
    assert m["GLASS"].absorb[0] == pytest.approx(1.0)         # 0.001 per mm = 1 per m
    assert m["BK7"].index[0] == pytest.approx(1.5168, abs=2e-4)
    assert 1.3 < m["WATER"].index[0] < 1.36
    al = it.state.coatings["AL"]
    assert al.reflect == (0.91,) and al.transmit == (0.0,)      # A = 1 - R - T = 0.09
    assert it.state.coatings["BARE"].kind == "fresnel"


def test_coating_r_plus_t_above_one(base):
    d = errors("COATING al REFLECT 0.6 TRANSMIT 0.5", base)
    assert "R + T" in d[0].message and "> 1" in d[0].message
    errors("WAVELENGTHS 450 550 NM\nCOATING al REFLECT 0.5 0.6 TRANSMIT 0.5", base)
    errors("MODEL paint LAMBERTIAN 0.6 TRANSMIT 0.5", base)


def test_rect_half_widths_cyclic(base):
    it = ok("SURFACE\n  PLANE Z 7 RECT 10 5\nOBJECT pz\nSURFACE\n  PLANE X 7 RECT 10 5\nOBJECT px\n"
            "SURFACE\n  PLANE Y 7 RECT 10 5\nOBJECT py", base)
    expect = {"PZ": ("x", "y", "z"), "PX": ("y", "z", "x"), "PY": ("z", "x", "y")}
    unit = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
    for n, (a, b, normal) in expect.items():
        s = obj(it, n).surfaces[0]
        cx, cy, cz = cols(s.frame.R)
        assert cx == unit[a] and cy == unit[b] and cz == unit[normal], n   # half-widths along a then b
        assert s.aperture.kind == "RECT" and s.aperture.params == pytest.approx((0.010, 0.005))
        assert s.frame.T == pytest.approx(tuple(0.007 * c for c in unit[normal]))
        assert np.linalg.det(np.array(s.frame.R).reshape(3, 3)) == pytest.approx(1.0)


def test_conic_radius_sign(base):
    it = ok("SURFACE\n  CONIC Z 0 RADIUS 800 DISK 20\nOBJECT p\nSURFACE\n  CONIC Z 0 RADIUS -4200 CONIC -1 "
            "ANNULUS 45 150\nOBJECT n", base)
    cp, cn = obj(it, "p").surfaces[0].params, obj(it, "n").surfaces[0].params
    assert cp["c"] == pytest.approx(1 / 0.8) and cn["c"] == pytest.approx(-1 / 4.2) and cn["k"] == -1
    # R > 0: the surface bends toward +z, toward its centre of curvature at z = +R
    r, c = 0.01, cp["c"]
    assert c * r * r / (1 + math.sqrt(1 - c * c * r * r)) > 0
    assert cols(obj(it, "p").surfaces[0].frame.R)[2] == (0.0, 0.0, 1.0)     # normal along +axis


def test_rotate_right_handed(base):
    it = ok("SURFACE\n  PLANE Z 0\nOBJECT rz\nROTATE Z 90\nSURFACE\n  PLANE Z 0\nOBJECT rx\nROTATE X 90\n"
            "SURFACE\n  PLANE Z 0\nOBJECT ry\nROTATE Y 90\nSURFACE\n  PLANE Z 0\nOBJECT ra\nROTATE Z 90 ABOUT 1 0 0\n"
            "SURFACE\n  PLANE Z 0\nOBJECT rr\nROTATE Z 1.5707963267948966 rad", base)
    ap = lambda n, p: obj(it, n).transform.apply(p)
    assert ap("rz", (1, 0, 0)) == pytest.approx((0, 1, 0))    # x -> y about z
    assert ap("rx", (0, 1, 0)) == pytest.approx((0, 0, 1))    # y -> z about x
    assert ap("ry", (0, 0, 1)) == pytest.approx((1, 0, 0))    # z -> x about y
    assert ap("ra", (0.002, 0, 0)) == pytest.approx((0.001, 0.001, 0))
    assert ap("rr", (1, 0, 0)) == pytest.approx((0, 1, 0))


def test_shift(base):
    it = ok("d = 10\nSURFACE\n  PLANE Z 0\nOBJECT a\nSHIFT 0 0 -5\nSHIFT Z (d/2 + 5 mm)\nSHIFT 1 2 3 cm", base)
    assert obj(it, "a").transform.T == pytest.approx((0.01, 0.02, 0.035))


def test_place_aim_up(base):
    it = ok("GROUP telescope\n  SURFACE\n    PLANE Z 10\n  OBJECT fpa\n  GRID DISK Z 0 1 RAYS 10\n"
            "  SOURCE DIRECTION 0 0 1\nEND GROUP\nPLACE telescope AT 0 0 100 AIM 0 0 0 UP 0 1 0\n"
            "GROUP g2\nEND GROUP\nPLACE g2 AT 0 0 0.18 AU\nGROUP g3\nEND GROUP\nPLACE g3 AT 0 0 0 AIM 1 0 0 UP 0 0 1",
            base)
    g = it.state.groups["TELESCOPE"]
    x, y, z = cols(g.placement.R)
    assert z == pytest.approx((0, 0, -1)) and y == pytest.approx((0, 1, 0))     # +Z at AIM, +Y toward UP
    assert np.cross(x, y) == pytest.approx(z)                                    # right-handed
    sc = it.state.scene()
    f = sc.objects["FPA"]
    assert f.group == "TELESCOPE"
    assert sc.world_transform(f).apply(f.surfaces[0].frame.T) == pytest.approx((0, 0, 0.09))
    assert it.state.sources[0].group == "TELESCOPE"             # a source inside a GROUP is in its frame
    g2 = it.state.groups["G2"]
    assert g2.placement.R == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)   # without AIM: the world's axes
    assert g2.placement.T[2] == pytest.approx(0.18 * 1.495978707e11)
    x3, y3, z3 = cols(it.state.groups["G3"].placement.R)
    assert z3 == pytest.approx((1, 0, 0)) and y3 == pytest.approx((0, 0, 1))


def test_interface_media_order(base):
    it = ok("MEDIUM glass INDEX 1.5\nCOATING al REFLECT 0.9\nSURFACE\n  PLANE Z 0\nOBJECT w\n"
            "INTERFACE TRANSMIT air glass\nSURFACE\n  PLANE Z 1\nOBJECT m\nINTERFACE COATING al AIR glass\n"
            "SURFACE\n  PLANE Z 2\nOBJECT r\nINTERFACE REFLECT", base)
    w, m = obj(it, "w"), obj(it, "m")
    # the normal of PLANE Z points to +z: back (below) is the first medium, front (above) the second
    assert cols(w.surfaces[0].frame.R)[2] == (0.0, 0.0, 1.0)
    assert (w.interface.kind, w.interface.back, w.interface.front) == ("transmit", "AIR", "GLASS")
    assert (m.interface.coating, m.interface.back, m.interface.front) == ("AL", "AIR", "GLASS")
    assert obj(it, "r").interface.kind == "reflect"


def test_scatter_detector_and_current_object(base):
    it = ok("MODEL paint LAMBERTIAN 0.5\nMAP cover LATLON 'landcover.npy'\n"
            "MODEL w LAMBERTIAN 0.1\nMODEL f LAMBERTIAN 0.1\nMODEL g LAMBERTIAN 0.1\nMODEL d LAMBERTIAN 0.1\n"
            "MODEL s LAMBERTIAN 0.1\nSURFACE\n  PLANE Z 10 RECT 1 1\nOBJECT fpa\nSURFACE\n  PLANE Z 0 RECT 10 5\n"
            "OBJECT 'M1'\n  SCATTER MODEL paint RAYS 4 TOWARD fpa\n  SCATTER MAP cover MODELS w f g d s\n"
            "  DETECTOR PIXELS 1024 512", base)
    m1 = obj(it, "M1")
    assert m1.scatter[0].model == "PAINT" and m1.scatter[0].rays == 4 and m1.scatter[0].toward == "FPA"
    assert m1.scatter[1].map == "COVER" and m1.scatter[1].models == ("W", "F", "G", "D", "S")
    assert (m1.detector.nx, m1.detector.ny) == (1024, 512)
    for ender in ("SURFACE\n  PLANE Z 0\n", "GROUP g\n", "GROUP g\nEND GROUP\n"):
        d = errors(f"SURFACE\n  PLANE Z 0\nOBJECT a\n{ender}SHIFT 0 0 1", base)
        assert any("no current object" in x.message for x in d), ender


def test_detector_on_a_named_object(base):
    """DETECTOR ... ON obj (an extension) replaces the named object's detector, after its block has closed and
    between traces: the TRACE before the change keeps the old grid, the one after has the new one."""
    src = "GRID RECT Z 50 -1 1 -1 1 10 1 RANDOM\nSOURCE DIRECTION 0 0 -1\n"
    it = ok("SURFACE\n  PLANE Z 0 RECT 5 5\nOBJECT det\n  DETECTOR PIXELS 8\nSURFACE\n  PLANE Z 10 RECT 1 1\n"
            f"OBJECT other\n{src}TRACE\nDETECTOR PIXELS 2 3 ON det\n{src}TRACE", base)
    traces = [s for s in it.steps if s.kind == "TRACE"]
    assert [(t.scene.objects["DET"].detector.nx, t.scene.objects["DET"].detector.ny) for t in traces] == [(8, 8), (2, 3)]
    assert obj(it, "other").detector is None
    d = errors("SURFACE\n  PLANE Z 0 RECT 5 5\nOBJECT det\nDETECTOR PIXELS 2 ON nothing", base)
    assert any("undefined object 'nothing'" in x.message for x in d)


def test_sources_and_flux(base):
    it = ok("SPECTRUM sun SOLAR\nSURFACE\n  SPHERE 0 0 1 AU 6371 km\nOBJECT earth\n"
            "GRID RECT Z -100 -10 10 -10 10 101 101\nSOURCE DIRECTION 0 0 1\n"
            "GRID DISK Z -100 150 RAYS 100000 RANDOM\nSOURCE FIELD 0.05 0.02 deg\nFLUX TOTAL 2 W\n"
            "GRID DISK Z -100 150 RAYS 100\nSOURCE POSITION 0 0 500\n"
            "EMITTING SPHERE 0 0 0 6.957e5 km RAYS 1e6 TOWARD earth\nFLUX SPECTRUM sun\n"
            "EMITTING DISK Z 0 5 RAYS 1e5 CONE 10", base)
    s = it.state.sources
    assert len(s) == 5
    assert s[0].flux.kind == "total" and s[0].flux.value == 1.0          # 1 W by default
    assert s[1].flux.value == 2.0 and s[3].flux.spectrum == "SUN"
    assert s[1].params["direction"]["angle_x"] == pytest.approx(math.radians(0.05))
    assert s[0].params["grid"]["nx"] == 101 and s[1].params["grid"]["random"] is True
    assert s[4].params["cone"] == pytest.approx(math.radians(10))
    it = ok("GRID DISK Z 0 1 RAYS 10\nSOURCE DIRECTION 0 0 1\nEMITTING DISK Z 0 5 RAYS 100\nTRACE", base)
    assert it.steps[-1].kind == "TRACE" and not it.state.sources        # TRACE traces every source


def test_select_predicates(base):
    it = ok("SURFACE\n  PLANE Z 0\nOBJECT o\nSURFACE\n  PLANE Z 1\nOBJECT a\nSURFACE\n  PLANE Z 2\nOBJECT b\n"
            "SURFACE\n  PLANE Z 3\nOBJECT c\nlo = 400 nm\nhi = 700 nm\nSELECT HIT(o)\nSELECT LAST(o)\n"
            "SELECT SCATTERED(o)\nSELECT PATH(a, b, c)\nSELECT WAVELENGTH(lo, hi)\n"
            "SELECT HIT(a) AND NOT SCATTERED(b)\nSELECT ALL", base)
    p = [s.params["predicate"] for s in it.steps]
    assert p[:4] == [("HIT", ("O",)), ("LAST", ("O",)), ("SCATTERED", ("O",)), ("PATH", ("A", "B", "C"))]
    assert p[4] == ("WAVELENGTH", pytest.approx((400.0, 700.0)))
    assert p[5] == ("and", ("HIT", ("A",)), ("not", ("SCATTERED", ("B",))))
    assert p[6] is None


def test_trace_until_and_analysis_steps(base):
    it = ok("SURFACE\n  PLANE Z 10 RECT 1 1\nOBJECT fpa\nGRID DISK Z 0 1 RAYS 10\nSOURCE DIRECTION 0 0 1\n"
            "LEVEL 100\nHALT 1e-6\nTRACE UNTIL ERROR 1% ON fpa\nSAVE RAYS 'run.h5' AT fpa\nLOAD RAYS 'run.h5'\n"
            "STATS LEDGER 'ledger.csv'\nWINDOW X -0.2 0.2 Y -0.2 0.2 ; PIXELS 101\nSPOTS POSITION 'spot.png'\n"
            "FOCUS\nSPECTRUM OF fpa 'spectrum.csv'\nEXPORT fpa 'image.fits'", base)
    st = {s.kind: s.params for s in it.steps}
    assert st["TRACE"]["until_error"] == pytest.approx(0.01) and st["TRACE"]["until_target"] == "FPA"
    assert st["TRACE"]["level"] == 100 and st["TRACE"]["halt"] == 1e-6
    assert st["PIXELS"] == {"nx": 101, "ny": 101}
    assert st["STATS"]["what"] == "LEDGER" and st["EXPORT"]["file"] == "image.fits"


def test_maps(base):
    it = ok("MAP cover LATLON 'landcover.npy'\nMAP clouds LATLON DEFAULT CLOUD_FRACTION", base)
    assert it.state.maps["COVER"].path.endswith("landcover.npy")
    assert it.state.maps["CLOUDS"].dataset == "CLOUD_FRACTION"


def test_apertures(base):
    """`PLANE Z 0 RECT 10 5 !! half-widths; also DISK r, ANNULUS r_in r_out, ELLIPSE a b`"""
    it = ok("SURFACE\n  PLANE Z 0 RECT 10 5\nOBJECT a\nSURFACE\n  PLANE Z 0 DISK 4\nOBJECT b\n"
            "SURFACE\n  PLANE Z 0 ANNULUS 1 4\nOBJECT c\nSURFACE\n  PLANE Z 0 ELLIPSE 3 2\nOBJECT d", base)
    ap = {n: obj(it, n).surfaces[0].aperture for n in "abcd"}
    assert [(a.kind, a.params) for a in ap.values()] == [
        ("RECT", pytest.approx((0.010, 0.005))), ("DISK", pytest.approx((0.004,))),
        ("ANNULUS", pytest.approx((0.001, 0.004))), ("ELLIPSE", pytest.approx((0.003, 0.002)))]


def test_comparisons_survive_unit_conversion(base):
    """`asin(0.5)` is 30 degrees: comparing it with a bare 30 (read as degrees) is exact enough to be equal."""
    it = ok("a = (asin(0.5) == 30)\nb = (asin(0.5) <= 30) AND (asin(0.5) >= 30)\nc = (acos(0.5) != 60)\n"
            "dd = (25.4 mm == 1 in)", base)
    assert [it.lookup(x).value for x in ("a", "b", "c", "dd")] == [1.0, 1.0, 0.0, 1.0]
