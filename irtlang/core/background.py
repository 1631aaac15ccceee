"""Background Python processes of this irtlang (the compiles ahead: irtlang.ahead, irtlang.kernels.reduce)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


def start_python(module: str, args=(), force: bool = False) -> subprocess.Popen | None:
    """Run ``module.main()`` of this very irtlang (the folder holding this package first on the path) in a
    background process with this process's interpreter and environment, its output discarded and outside this
    terminal's process group (Ctrl-C stops the run, not a compile that ends on its own).  None where no process
    starts, or where ``IRT_COMPILE_AHEAD=0`` (unless `force`)."""
    if not force and os.environ.get("IRT_COMPILE_AHEAD", "1") == "0":
        return None
    root = str(Path(__file__).resolve().parents[2])
    code = f"import sys; sys.path.insert(0, {root!r}); from {module} import main; main()"
    try:
        return subprocess.Popen([sys.executable, "-c", code, *map(str, args)], stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    except OSError:
        return None
