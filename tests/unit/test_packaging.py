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
