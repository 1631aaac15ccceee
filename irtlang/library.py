"""The example scripts installed with irtlang (package irtlang.examples, from examples_scripts/) and the
INCLUDE search path.

An INCLUDE (or any input file) is looked up relative to the including script's folder; when it is not there,
a relative INCLUDE is looked up in each folder of $IRT_PATH (separated by os.pathsep), then in the installed
examples, so ``INCLUDE 'cassegrain.inr'`` works from a user's own folder.  ``irt examples`` lists them and
``irt examples --copy DIR`` copies them with their includes (earth/) and data (data/).
"""
from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

SKIP = {"__init__.py", "__pycache__"}


def examples_dir() -> Path:
    """The installed examples (irtlang.examples), or examples_scripts/ of a source checkout."""
    try:
        from importlib import resources

        p = Path(str(resources.files("irtlang.examples")))
        if (p / "telescope_spots.inr").is_file():
            return p
    except (ImportError, TypeError, ValueError):
        pass
    return Path(__file__).resolve().parents[1] / "examples_scripts"


def search_path() -> list[Path]:
    """The folders a relative INCLUDE is looked up in after the including script's own folder."""
    dirs = [Path(d) for d in os.environ.get("IRT_PATH", "").split(os.pathsep) if d]
    return dirs + [examples_dir()]


def find_include(rel: str) -> Path | None:
    """The first file named rel on the search path, or None."""
    if Path(rel).is_absolute():
        return None
    for d in search_path():
        p = d / rel
        if p.is_file():
            return p
    return None


def _about(p: Path) -> str:
    """The first comment line of a script."""
    try:
        for line in p.read_text(encoding="utf-8").splitlines():
            t = line.strip()
            if t.startswith("!!"):
                return t.lstrip("!").strip()
            if t:
                break
    except OSError:
        pass
    return ""


def list_examples() -> list[tuple[str, str]]:
    """(file name, first comment line) of each top-level example script."""
    d = examples_dir()
    return [(p.name, _about(p)) for p in sorted(d.glob("*.inr"))]


def _tree(d: Path) -> list[Path]:
    return sorted(p for p in d.rglob("*") if p.is_file() and not SKIP & set(p.relative_to(d).parts)
                  and p.suffix != ".pyc")


def copy_examples(dest: Path, names=None, *, force: bool = False) -> list[Path]:
    """Copy the examples into dest: all of them, or the named scripts with the scripts beside them that they
    INCLUDE; the includes (earth/) and data (data/) always come along, since the scripts refer to them.  Existing
    files stay unless force."""
    src = examples_dir()
    files = _tree(src)
    if names:
        known = {p.name for p in src.glob("*.inr")}
        want = set()
        for n in names:
            n = n if n.endswith(".inr") else n + ".inr"
            if n not in known:
                raise KeyError(f"no example named {n!r}; `irt examples` lists them")
            want.add(n)
        # and the scripts beside them that they INCLUDE (earth_defocus.inr: earth_scene.inr, cassegrain.inr ...)
        todo = list(want)
        while todo:
            text = (src / todo.pop()).read_text(encoding="utf-8", errors="replace")
            for inc in re.findall(r"^\s*INCLUDE\s+'([^'/\\]+\.inr)'", text, re.M | re.I):
                if inc in known and inc not in want:
                    want.add(inc)
                    todo.append(inc)
        files = [p for p in files if p.parent != src or p.name in want]
    targets = [(p, dest / p.relative_to(src)) for p in files]
    clash = [t for _, t in targets if t.exists()]
    if clash and not force:
        raise FileExistsError(f"{clash[0]} exists (and {len(clash) - 1} more); give --force to overwrite"
                              if len(clash) > 1 else f"{clash[0]} exists; give --force to overwrite")
    for p, t in targets:
        t.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(p, t)
    return [t for _, t in targets]
