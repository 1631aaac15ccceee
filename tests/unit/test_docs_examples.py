"""Every example in the language reference runs, and the reference covers every command and kind.

* Each fenced ```irt block of docs/language.md (and of README.md, if it has any) is a complete script: it is
  checked with the interpreter (as `irt check` does) and must give no diagnostic.
* Each ```irt-error block must give at least one diagnostic; a comment `!! expect: text` on one of its lines
  names a message that must be among them, reported on that line.
* Examples resolve input files relative to docs/examples/ (they run as if they were a script there).
* The reference names every command of irtlang.lang.commands.TABLE and every plugin KIND, and its generated
  regions match docs/gen_language_tables.py, so it cannot silently go stale.
"""
from __future__ import annotations

import importlib.util
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from irtlang.lang.diagnostics import IrtError
from irtlang.lang.interp import Interpreter

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "language.md"
README = ROOT / "README.md"
EXAMPLES = ROOT / "docs" / "examples"

FENCE = re.compile(r"^```(irt|irt-error)\s*$")
EXPECT = re.compile(r"!!\s*expect:\s*(.+?)\s*$")


@dataclass(frozen=True)
class Block:
    path: Path
    line: int          # line of the opening fence
    kind: str          # irt | irt-error
    text: str

    @property
    def id(self) -> str:
        return f"{self.path.name}:{self.line}"


def extract_blocks(path: Path) -> list[Block]:
    blocks, cur, start, kind = [], None, 0, None
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if cur is None:
            m = FENCE.match(line.strip())
            if m:
                cur, start, kind = [], n, m.group(1)
        elif line.strip() == "```":
            blocks.append(Block(path, start, kind, "\n".join(cur) + "\n"))
            cur = None
        else:
            cur.append(line)
    assert cur is None, f"{path.name}:{start}: unterminated code block"
    return blocks


def check_script(text: str, name: str, base: Path = EXAMPLES) -> tuple[Interpreter, list]:
    """Run `text` as `irt check` would a script in folder `base`; return the interpreter and its diagnostics."""
    it = Interpreter(check_only=True)
    it.base_dir = base
    it.include_stack = [base / "example.inr"]    # input paths resolve next to this (virtual) script
    try:
        it.run_text(text, name)
    except IrtError as e:  # a syntax error stops parsing
        return it, list(e.diagnostics)
    return it, list(it.diags.items)


def _all_blocks() -> list[Block]:
    out = extract_blocks(DOC)
    if README.exists():
        out += extract_blocks(README)
    return out


BLOCKS = _all_blocks()


def test_the_reference_has_examples():
    ok = [b for b in BLOCKS if b.kind == "irt"]
    bad = [b for b in BLOCKS if b.kind == "irt-error"]
    assert len(ok) >= 40 and len(bad) >= 8, (len(ok), len(bad))


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.kind == "irt"], ids=lambda b: b.id)
def test_example_checks_clean(block: Block):
    _, diags = check_script(block.text, block.id)
    assert not diags, f"{block.id}: the example gives diagnostics:\n" + "\n".join(d.render() for d in diags)


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.kind == "irt-error"], ids=lambda b: b.id)
def test_error_example_is_refused(block: Block):
    _, diags = check_script(block.text, block.id)
    assert diags, f"{block.id}: an irt-error example was accepted"
    for n, line in enumerate(block.text.splitlines(), 1):
        m = EXPECT.search(line)
        if m:
            want = m.group(1)
            hits = [d for d in diags if want in d.message]
            assert hits, f"{block.id}: no diagnostic says {want!r}; got:\n" + "\n".join(d.render() for d in diags)
            assert any(d.span.line == n for d in hits), (
                f"{block.id}: {want!r} is reported on line(s) {[d.span.line for d in hits]}, not on line {n}")


# ---------------------------------------------------------------- coverage and freshness
def _doc_text() -> str:
    return DOC.read_text(encoding="utf-8")


def test_every_command_is_documented():
    from irtlang.lang.commands import TABLE

    text = _doc_text()
    missing = [h for h in TABLE if not re.search(rf"`{re.escape(h)}\b", text)]
    assert not missing, f"docs/language.md does not document: {missing}"
    # and every command has at least one example that uses it
    examples = "\n".join(b.text for b in BLOCKS if b.kind == "irt").upper()
    unused = [h for h in TABLE if not re.search(rf"(^|[\s;]){re.escape(h)}\b", examples, re.M)]
    assert not unused, f"no example in docs/language.md uses: {unused}"


def test_every_plugin_kind_is_documented():
    from irtlang.plugins.bsdfs import REGISTRY as BSDFS
    from irtlang.plugins.sources import REGISTRY as SOURCES
    from irtlang.plugins.surfaces import REGISTRY as SURFACES

    text = _doc_text()
    kinds = list(SURFACES) + list(BSDFS) + list(SOURCES)
    missing = [k for k in kinds if f"#### {k}\n" not in text]
    assert not missing, f"docs/language.md has no entry for the kinds: {missing}"
    examples = "\n".join(b.text for b in BLOCKS if b.kind == "irt").upper()
    unused = [k for k in kinds if not re.search(rf"\b{re.escape(k)}\b", examples)]
    assert not unused, f"no example in docs/language.md uses the kinds: {unused}"


def test_generated_regions_are_up_to_date():
    spec = importlib.util.spec_from_file_location("gen_language_tables", ROOT / "docs" / "gen_language_tables.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    text = _doc_text()
    assert gen.render(text) == text, "docs/language.md is stale: run python docs/gen_language_tables.py --write"


def test_fixture_files_exist():
    """The input files the examples name (remade by docs/examples/make_fixtures.py)."""
    for name in ("water.csv", "grass.csv", "landcover.npy", "clouds.npy", "baffle.stl", "run.h5", "telescope.inr"):
        assert (EXAMPLES / name).is_file(), name
    assert (EXAMPLES / "baffle.stl").read_text().startswith("solid"), "baffle.stl is committed as ASCII STL"


# ---------------------------------------------------------------- behaviour the reference states
def _ok(text: str) -> Interpreter:
    it, diags = check_script(text, "<doc claim>")
    assert not diags, "\n".join(d.render() for d in diags)
    return it


def test_display_unit_rounding_and_round_half_away():
    it = _ok("a = floor(2.5 mm)\nUNITS CM\nb = floor(25 mm)\nc = round(2.5)\nd = round(-2.5)\ne1 = round(2.4)")
    v = lambda n: it.lookup(n).value
    assert v("a") == pytest.approx(0.002) and v("b") == pytest.approx(0.02)
    assert (v("c"), v("d"), v("e1")) == (3.0, -3.0, 2.0)


def test_trailing_unit_within_one_list_only():
    it = _ok("SURFACE\n  SPHERE 1 2 3 6371 km\nOBJECT s\n  SHIFT 1 2 3 cm\nGRID DISK Z 0 1 RAYS 10\n"
             "SOURCE FIELD 0.05 0.02 mrad")
    s = it.state.objects["S"]
    assert s.surfaces[0].frame.T == pytest.approx((0.001, 0.002, 0.003))   # the centre stays in mm
    assert s.surfaces[0].params["radius"] == pytest.approx(6.371e6)
    assert s.transform.T == pytest.approx((0.01, 0.02, 0.03))
    d = it.state.sources[0].params["direction"]
    assert (d["angle_x"], d["angle_y"]) == pytest.approx((5e-5, 2e-5))        # the pair shares its unit


def test_system_new_keeps_variables_and_macros():
    it = _ok("x = 5\nMACRO m\n  y = x + 1\nEND MACRO\nUNITS CM\nSURFACE\n  PLANE Z 0\nOBJECT a\nSYSTEM NEW\n"
             "CALL m\nSURFACE\n  PLANE Z 0\nOBJECT a")
    assert it.lookup("y").value == 6 and it.state.units == "MM"


def test_wavelengths_rules():
    _ok("UNITS UM\nWAVELENGTHS 0.45 0.55 0.65")
    it = _ok("WAVELENGTHS RANGE 400nm 700nm 4")
    assert it.state.wavelengths_nm == (400.0, 500.0, 600.0, 700.0)
    _, d = check_script("WAVELENGTHS 450 550 650 NM\nSPECTRUM sun SOLAR\nWAVELENGTHS 400 500 600 NM", "x")
    assert d and "after wavelength-dependent values" in d[0].message


def test_print_output_and_formats():
    lines: list[str] = []
    it = Interpreter(out=lines.append)
    it.run_text("i = 3\nPRINT 'angle' asin(0.5) 'length' (2 * 5 mm)\nPRINT 'baffle_{i:02d} {{i}} {PI:.3f}'\n"
                "MACRO hello\n  PRINT 'hello'\nEND MACRO\nCALL hello\nPRINT", "<print>")
    assert not it.diags
    assert lines == ["angle 30 deg length 10 mm", "baffle_03 {i} 3.142", "hello", ""]
