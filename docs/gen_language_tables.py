"""Generate the parts of docs/language.md that come straight from the code.

Two regions of docs/language.md are generated, each between its markers:

* ``<!-- BEGIN GENERATED: kinds -->`` ... ``<!-- END GENERATED: kinds -->``: one entry per plugin kind
  (surfaces, scatter models, sources) from the module's docstring (its synopsis line, the description up to
  the parameter table, and the table; what follows the table is for developers and is left out), its
  signature (``FORM``) and its ``EXAMPLE``;
* ``<!-- BEGIN GENERATED: index -->`` ... ``<!-- END GENERATED: index -->``: the command index, one row
  per command of ``irtlang.lang.commands.TABLE`` with its usage lines.

    python docs/gen_language_tables.py            # print both regions
    python docs/gen_language_tables.py --write    # rewrite them in docs/language.md
    python docs/gen_language_tables.py --check    # exit 1 if docs/language.md is stale

tests/unit/test_docs_examples.py runs the equivalent of --check, so a plugin or command that changes
without its documentation fails the tests.
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

DOC = Path(__file__).resolve().parent / "language.md"

# kinds whose module has no EXAMPLE that runs by itself (it needs an input file): the example the docs show.
# Input files are resolved next to the script; docs/examples/ holds the files these examples name.
FALLBACK_EXAMPLES = {
    "TABLE": "MODEL white_table TABLE 'brdf.csv'",
    "MESH": "SURFACE\n  MESH 'baffle.stl' SCALE 1      !! docs/examples/baffle.stl, a 20 x 20 x 40 box\nOBJECT baffle",
}

REGISTRIES = (
    ("Surface kinds", "irtlang.plugins.surfaces", "Each is a command written between `SURFACE` and `OBJECT name`."),
    ("Scatter model kinds", "irtlang.plugins.bsdfs", "Each is written after `MODEL name`."),
    ("Source kinds", "irtlang.plugins.sources",
     "Each is a command: `GRID kind`, `SOURCE kind` or `EMITTING kind`."),
)


def _split_doc(doc: str) -> tuple[str, str, str, str]:
    """(synopsis, description, table, rest) of a plugin docstring."""
    lines = (doc or "").strip("\n").splitlines()
    synopsis = lines[0].strip() if lines else ""
    desc, table, rest = [], [], []
    for ln in lines[1:]:
        if ln.lstrip().startswith("|") and not rest:
            table.append(ln.strip())
        elif table:
            rest.append(ln)
        else:
            desc.append(ln)
    return synopsis, "\n".join(desc).strip(), "\n".join(table), "\n".join(rest).strip()


def _usage(mod, kind: str) -> list[str]:
    return mod.FORM.usages(kind)


def kinds_markdown() -> str:
    import importlib

    out: list[str] = []
    for title, pkg, where in REGISTRIES:
        reg = importlib.import_module(pkg).REGISTRY
        out.append(f"### {title}\n")
        out.append(f"{where} Registered kinds: " + ", ".join(f"`{k}`" for k in reg) + ".\n")
        for kind, mod in reg.items():
            synopsis, desc, table, _notes = _split_doc(mod.__doc__)
            out.append(f"#### {kind}\n")
            out.append(f"`{synopsis}`\n")
            if desc:
                out.append(desc + "\n")
            if table:
                out.append(table + "\n")
            use = _usage(mod, kind)
            out.append("Signature: " + "; ".join(f"`{u}`" for u in use) + "\n")
            ex = getattr(mod, "EXAMPLE", None) or FALLBACK_EXAMPLES.get(kind)
            if ex:
                out.append("```irt\n" + ex.rstrip("\n") + "\n```\n")
    return "\n".join(out).rstrip("\n") + "\n"


def _cell(s: str) -> str:
    return s.replace("|", "\\|")


def index_markdown() -> str:
    from irtlang.lang import commands as C

    out = ["| command | section | usage | what it does |", "|---|---|---|---|"]
    for head, cd in C.TABLE.items():
        use = "<br>".join(f"`{_cell(u)}`" for u in C.usages(head))
        out.append(f"| `{head}` | {cd.section} | {use} | {_cell(cd.summary)} |")
    return "\n".join(out) + "\n"


REGIONS = {"kinds": kinds_markdown, "index": index_markdown}


def _pattern(name: str) -> re.Pattern:
    return re.compile(rf"(<!-- BEGIN GENERATED: {name} -->\n)(.*?)(<!-- END GENERATED: {name} -->)", re.S)


def render(text: str) -> str:
    """text with every generated region replaced by its current content."""
    for name, fn in REGIONS.items():
        pat = _pattern(name)
        if not pat.search(text):
            raise SystemExit(f"{DOC}: missing the markers of the generated region '{name}'")
        body = fn()
        text = pat.sub(lambda m: m.group(1) + body + m.group(3), text)
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--write", action="store_true", help="rewrite the generated regions of docs/language.md")
    g.add_argument("--check", action="store_true", help="exit 1 when docs/language.md is not up to date")
    a = ap.parse_args(argv)
    if not (a.write or a.check):
        for name, fn in REGIONS.items():
            print(f"<!-- {name} -->\n{fn()}")
        return 0
    text = DOC.read_text(encoding="utf-8")
    new = render(text)
    if a.check:
        if new != text:
            print(f"{DOC} is stale: run python docs/gen_language_tables.py --write", file=sys.stderr)
            return 1
        return 0
    if new != text:
        DOC.write_text(new, encoding="utf-8")
        print(f"updated {DOC}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
