"""One Numba cache folder however irtlang runs (irtlang/__init__.py, `_setup_numba_cache`).

Numba keeps a module's compiled code beside the module while NUMBA_CACHE_DIR is unset and in NUMBA_CACHE_DIR once
it is set; before the package set it at import, a process that imported irtlang and later ran `irt` in-process
kept two caches of the same kernel and compiled it twice (the README's test command did, 2026-12-04).  These
check where the kernels' compiled code goes, in a fresh interpreter without the variable."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

CHECK = """
import os, sys
{first}
import irtlang
from irtlang.kernels import rng
paths = {{f._cache._cache_path for f in vars(rng).values() if hasattr(f, "_cache")}}
print(os.environ["NUMBA_CACHE_DIR"])
print(sorted(paths)[0])
"""


def _run(tmp_path, first="", **env):
    e = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    e.update(env)
    p = subprocess.run([sys.executable, "-c", CHECK.format(first=first)], capture_output=True, text=True, env=e,
                       cwd=tmp_path, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout.split()


@pytest.mark.parametrize("first", ["", "import numba"])
def test_kernels_cache_under_the_users_cache_folder(tmp_path, first):
    """Unset: $XDG_CACHE_HOME/irtlang/numba, also when numba was imported before irtlang."""
    cache, path = _run(tmp_path, first, XDG_CACHE_HOME=str(tmp_path / "xdg"))
    assert cache == str(tmp_path / "xdg" / "irtlang" / "numba")
    assert Path(path).is_relative_to(cache)


def test_a_set_numba_cache_dir_is_kept(tmp_path):
    cache, path = _run(tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "mine"))
    assert cache == str(tmp_path / "mine") and Path(path).is_relative_to(cache)
