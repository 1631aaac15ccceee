"""The wheel carries every package, the grammar (irtlang.grammar, from the top-level grammar/ folder) and the data."""
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_every_package_is_listed_for_the_wheel():
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(cfg["packages"])
    found = {".".join(p.parent.relative_to(ROOT).parts) for top in ("irtlang", "analysis")
             for p in (ROOT / top).rglob("__init__.py")}
    assert found - listed == set(), f"add to [tool.setuptools] packages in pyproject.toml: {sorted(found - listed)}"
    assert "irtlang.grammar" in listed and cfg["package-dir"]["irtlang.grammar"] == "grammar"
    assert (ROOT / "grammar" / "irt.lark").exists()


def test_the_examples_travel_in_the_wheel():
    """examples_scripts/ is the package irtlang.examples, and its package data covers every file in it (the
    earth/ includes and the data/ tables too): `irt examples` and the INCLUDE search path need them installed."""
    import fnmatch

    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "irtlang.examples" in cfg["packages"] and cfg["package-dir"]["irtlang.examples"] == "examples_scripts"
    patterns = cfg["package-data"]["irtlang.examples"]
    src = ROOT / "examples_scripts"
    for p in src.rglob("*"):
        rel = p.relative_to(src).as_posix()
        if p.is_dir() or "__pycache__" in rel or rel == "__init__.py":
            continue
        assert any(fnmatch.fnmatch(rel, pat) and rel.count("/") == pat.count("/") for pat in patterns), \
            f"examples_scripts/{rel} is not in the wheel: add a pattern to package-data irtlang.examples"
