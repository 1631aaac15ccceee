"""A long-lived `irt run` worker for the stress tests (tests/stress/_stress_util.py starts it).

Reads one JSON request per line on stdin, {"script": path, "out": folder}, runs
``irtlang.cli.main(["run", script, "--out", out])`` with its stdout and stderr captured, and answers one JSON
line {"code", "stdout", "stderr", "seconds"} on its own stdout.  One process serves many scripts, so the traced
kernel is loaded (or compiled) once; the parent guards every request with a wall-clock limit and kills the
worker when a script hangs.
"""
import contextlib
import io
import json
import os
import sys
import time
import traceback
import warnings


def main() -> None:
    warnings.simplefilter("always")   # every numerical warning shows, not only the first of each place
    proto = os.fdopen(os.dup(sys.stdout.fileno()), "w", buffering=1)
    from irtlang.cli import main as irt_main

    for line in sys.stdin:
        req = json.loads(line)
        out, err = io.StringIO(), io.StringIO()
        t0 = time.perf_counter()
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                code = irt_main(["run", req["script"], "--out", req["out"]])
        except BaseException:   # a SystemExit or anything cli.main let through is a failure to report
            code = -1
            err.write(traceback.format_exc())
        proto.write(json.dumps({"code": code, "stdout": out.getvalue(), "stderr": err.getvalue(),
                                "seconds": time.perf_counter() - t0}) + "\n")


if __name__ == "__main__":
    main()
