"""The ``irt`` command: run, check, warmup, fmt, repl, analyze.

Exit codes: 0 success; 2 the input has errors (diagnostics printed) or bad usage; 3 the script needs a
capability this build does not have; 1 a run-time failure; 70 an internal error (a bug: please report);
130 interrupted.
"""
from __future__ import annotations

import argparse
import os
import sys
import traceback
from pathlib import Path

from ._version import __version__

EXIT_OK, EXIT_RUNTIME, EXIT_INPUT, EXIT_MISSING, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 70, 130
BUG_URL = "https://github.com/irtlang/irtlang/issues"


def _setup_numba_cache() -> None:
    """The package's rule (irtlang/__init__.py), again: a test may have removed the variable since the import."""
    from . import _setup_numba_cache as setup

    setup()


def _wants_analysis(argv) -> bool:
    """Only `irt analyze ...` and a bare `irt` / `irt --help` need the analysis package's subcommands: importing
    it (scipy, matplotlib) would cost every `irt run` about a second of start-up (benchmarks/bench_startup.py)."""
    words = [a for a in (sys.argv[1:] if argv is None else argv) if not a.startswith("-")]
    return not words or words[0] == "analyze"


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="irt", description="irtlang: end-to-end optical simulation of space instruments")
    p.add_argument("--version", action="version", version=f"irt (irtlang) {__version__}")
    p.add_argument("--debug", action="store_true", help="show Python tracebacks")
    sub = p.add_subparsers(dest="cmd", metavar="COMMAND")

    r = sub.add_parser("run", help="run a script")
    r.add_argument("file")
    r.add_argument("--out", help="output folder (default irt-out/<script name>/)")
    r.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="set a variable before the script runs (the script's DEFAULT NAME VALUE keeps it); repeatable")
    r.add_argument("--seed", type=_seed, metavar="N",
                   help="random seed of the first TRACE, in place of the script's SEED; later ones keep their "
                        "SEED's offset from it (recorded in the manifest)")
    pq = r.add_mutually_exclusive_group()
    pq.add_argument("--quiet", action="store_true", help="no progress display")
    pq.add_argument("--progress", action="store_true",
                    help="show the progress display even when the output is not a terminal")
    g = r.add_mutually_exclusive_group()   # docs/cluster.md
    g.add_argument("--scheduler", metavar="ADDRESS", help="trace on the Dask cluster of this scheduler (tcp://host:8786)")
    g.add_argument("--workers", type=int, metavar="N", help="trace on a local Dask cluster of N worker processes")
    r.add_argument("--connect-timeout", type=float, default=5.0, metavar="S",
                   help="seconds to wait for the Dask scheduler and a worker (default 5)")
    r.add_argument("--debug", action="store_true", default=argparse.SUPPRESS)
    _safety_options(r)

    c = sub.add_parser("check", help="parse and validate scripts only")
    c.add_argument("files", nargs="+")
    c.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="set a variable before the script runs (as irt run --set)")
    _safety_options(c)
    c.add_argument("--debug", action="store_true", default=argparse.SUPPRESS)

    w = sub.add_parser("warmup", help="compile the kernels a script's run will use, without running it")
    w.add_argument("file")
    w.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="set a variable before the script runs (as irt run --set)")
    w.add_argument("--jobs", type=int, default=os.cpu_count() or 1, metavar="N",
                   help="compile in N processes at once (default: the number of cores)")
    _safety_options(w)
    w.add_argument("--debug", action="store_true", default=argparse.SUPPRESS)

    f = sub.add_parser("fmt", help="print a script in canonical formatting")
    f.add_argument("file")
    f.add_argument("--debug", action="store_true", default=argparse.SUPPRESS)

    sub.add_parser("repl", help="interactive session")

    e = sub.add_parser("examples", help="list the example scripts installed with irtlang, or copy them")
    e.add_argument("names", nargs="*", help="examples to copy (default: all of them, with their includes and data)")
    e.add_argument("--copy", metavar="DIR", help="copy the examples into DIR (created if needed)")
    e.add_argument("--force", action="store_true", help="overwrite files that already exist in DIR")

    a = sub.add_parser("analyze", help="analyses of saved images, spectra and ray files")
    if _wants_analysis(argv):
        from .core.hooks import analysis_provider

        acli = analysis_provider(required=False)  # the analysis package (irtlang/core/hooks.py)
        if acli is not None and hasattr(acli, "build_parser"):
            acli.build_parser(a.add_subparsers(dest="analysis_cmd", metavar="ANALYSIS"))
    return p


def _seed(text: str) -> int:
    """--seed N: an integer in [0, 2^63), as SEED (the counter-based generator's key)."""
    try:
        n = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not 0 <= n < 2 ** 63:
        raise argparse.ArgumentTypeError(f"must be in [0, 2^63), got {text}")
    return n


def _safety_options(p) -> None:
    """--limit and --allow-outside (docs/language.md, "Safety and limits"; irtlang/limits.py)."""
    p.add_argument("--limit", action="append", default=[], metavar="NAME=VALUE",
                   help="change a resource limit (rays, pixels, memory, steps, string, statement, script, input, "
                        "format), e.g. --limit rays=1e11 --limit memory=200G; repeatable (also IRT_LIMITS)")
    p.add_argument("--allow-outside", action="store_true",
                   help="let the script's outputs name absolute paths and '..' paths outside the run folder")


def _limits(args):
    """The run's limits (IRT_LIMITS, then --limit); a bad entry raises LimitError."""
    from .limits import Limits

    return Limits.from_env(getattr(args, "limit", None) or ())


def main(argv: list[str] | None = None) -> int:
    _setup_numba_cache()
    args = build_parser(argv).parse_args(argv)
    debug = getattr(args, "debug", False)
    try:
        if args.cmd == "run":
            return cmd_run(args)
        if args.cmd == "check":
            return cmd_check(args)
        if args.cmd == "fmt":
            return cmd_fmt(args)
        if args.cmd == "warmup":
            return cmd_warmup(args)
        if args.cmd == "examples":
            return cmd_examples(args)
        if args.cmd == "repl":
            from .repl import main as repl_main

            return repl_main()
        if args.cmd == "analyze":
            from .core.hooks import analysis_provider

            return analysis_provider().run(args)
        build_parser().print_help()
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("irt: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except _usage_errors() as e:   # a bad --limit, an output folder that cannot be made: the user's to fix
        print(f"irt: {e}", file=sys.stderr)
        return EXIT_INPUT
    except Exception:  # the last line of defence: never a bare traceback unless --debug
        if debug:
            traceback.print_exc()
        else:
            etype, evalue, _ = sys.exc_info()
            print(f"irt: internal error: {etype.__name__}: {evalue}\n"
                  f"This is a bug in irtlang {__version__}. Please report it at {BUG_URL} with your script "
                  f"and the output of `irt --debug {' '.join(argv or sys.argv[1:])}`.", file=sys.stderr)
        return EXIT_INTERNAL


class UsageError(Exception):
    """A command-line problem the user can fix (reported as `irt: message`, exit 2)."""


def _usage_errors():
    from .limits import LimitError

    return (UsageError, LimitError)


def _print_diags(e) -> None:
    print(e.render(), file=sys.stderr)
    n = len(e.diagnostics)
    print(f"{n} error{'s' if n != 1 else ''}", file=sys.stderr)


def _load_check(path: str, presets=(), args=None):
    """Check a script; returns the interpreter, or raises IrtError with every diagnostic."""
    from .api import Script, load_check

    return load_check(Script(Path(path)), presets, limits=_limits(args),
                      allow_outside=bool(getattr(args, "allow_outside", False)))


def _checked(args):
    """(the --set values, the checking interpreter of args.file), or (..., None) after printing its diagnostics."""
    from .core.diagnostics import IrtError

    presets = getattr(args, "set", None) or ()
    try:
        return presets, _load_check(args.file, presets, args)
    except IrtError as e:
        _print_diags(e)
        return presets, None


def cmd_check(args) -> int:
    from .core.diagnostics import IrtError

    status = EXIT_OK
    for f in args.files:
        try:
            _load_check(f, getattr(args, "set", None) or (), args)
            print(f"{f}: ok")
        except IrtError as e:
            _print_diags(e)
            status = EXIT_INPUT
    return status


def cmd_warmup(args) -> int:
    """irt warmup FILE: compile (into Numba's cache) every trace kernel a run of FILE will use, in --jobs
    processes at once (irtlang/ahead.py), so that the run itself starts warm: before a cluster run, on a new
    machine or in a container image.  Retraces by PST and SPOTS DIAGRAM are not planned."""
    import time

    from .ahead import warmup

    if args.jobs < 1:
        print("irt: --jobs needs at least 1", file=sys.stderr)
        return EXIT_INPUT
    presets, checked = _checked(args)
    if checked is None:
        return EXIT_INPUT
    t0 = time.perf_counter()

    def on_plan(n, missing, at_once):
        if missing:
            print(f"irt warmup: compiling {missing} of {n} trace kernels for {args.file}, {at_once} at once "
                  "(a minute or more each)...", flush=True)

    r = warmup(checked, Path(args.file), presets, bool(args.allow_outside), jobs=args.jobs, on_plan=on_plan,
               limits=getattr(args, "limit", None) or ())
    n, before, now = len(r["planned"]), len(r["cached_before"]), len(r["cached"])
    print(f"irt warmup: {n} trace kernel{'s' if n != 1 else ''} for {args.file}: {before} already compiled, "
          f"{now - before} compiled now ({min(args.jobs, max(n - before, 1))} at once), "
          f"{time.perf_counter() - t0:.1f} s")
    for k in r["planned"]:
        print(f"  {k}: {'cached' if k in r['cached'] else 'NOT compiled'}")
    return EXIT_OK if now == n else EXIT_RUNTIME


def cmd_run(args) -> int:
    scheduler, workers = getattr(args, "scheduler", None), getattr(args, "workers", None)
    if not scheduler and workers is None:
        return _run_script(args)
    from .cluster import DEFAULT_TIMEOUT, ClusterError, DaskRunner, close_client, connect
    from .core.diagnostics import IrtError

    if workers is not None and workers < 1:
        print("irt: --workers needs at least 1 worker", file=sys.stderr)
        return EXIT_INPUT
    try:
        _load_check(args.file, getattr(args, "set", None) or (), args)   # input errors before reaching a cluster
    except IrtError:
        return _run_script(args)
    try:
        client = connect(scheduler, workers, timeout=getattr(args, "connect_timeout", DEFAULT_TIMEOUT))
    except ClusterError as e:
        print(f"irt: {e}", file=sys.stderr)
        return EXIT_RUNTIME
    try:
        return _run_script(args, DaskRunner(client))
    except ClusterError as e:
        print(f"irt: {e}", file=sys.stderr)
        return EXIT_RUNTIME
    finally:
        close_client(client)


def _run_script(args, runner=None) -> int:
    from .api import Script, execute
    from .engine import MissingCapability, RuntimeFailure
    from .api import OutputFolderError
    from .core.diagnostics import Diagnostic, IrtError
    from .progress import RunProgress

    script = Script(Path(args.file))
    presets, checked = _checked(args)
    if checked is None:
        return EXIT_INPUT
    enabled = False if getattr(args, "quiet", False) else True if getattr(args, "progress", False) else None
    try:
        ex = execute(script, presets=presets, seed=getattr(args, "seed", None),
                     out=Path(args.out) if args.out else None, runner=runner, progress=RunProgress(enabled=enabled),
                     checked=checked)
    except OutputFolderError as e:
        raise UsageError(str(e)) from None
    e, code = ex.error, EXIT_OK
    if isinstance(e, MissingCapability):
        print(Diagnostic(e.span, f"{e.what} needs {e.capability}, which this version of irtlang "
                                 f"(v{__version__}) does not have yet; the run stops here").render(), file=sys.stderr)
        code = EXIT_MISSING
    elif isinstance(e, RuntimeFailure):
        print(Diagnostic(e.span, e.message).render(), file=sys.stderr)
        code = EXIT_RUNTIME
    elif isinstance(e, IrtError):
        _print_diags(e)
        code = EXIT_INPUT
    elif isinstance(e, KeyboardInterrupt):
        print("irt: interrupted; keeping what was written", file=sys.stderr)
        code = EXIT_INTERRUPTED
    folder, man = ex.folder, ex.manifest_path
    print(f"irt: outputs in {folder.root}/ ({len(folder.files)} file{'s' if len(folder.files) != 1 else ''}; "
          f"manifest {man})")
    return code


def cmd_examples(args) -> int:
    from .library import copy_examples, list_examples

    if not args.copy:
        if args.names:
            print("irt: give --copy DIR to copy examples", file=sys.stderr)
            return EXIT_INPUT
        for name, about in list_examples():
            print(f"{name:<24} {about}")
        print("\nirt examples --copy DIR   copies them (with their includes and data) into DIR; an INCLUDE of one "
              "of them (INCLUDE 'cassegrain.inr') finds the installed copy from any folder")
        return EXIT_OK
    try:
        written = copy_examples(Path(args.copy), args.names or None, force=args.force)
    except (FileExistsError, KeyError) as e:
        print(f"irt: {e.args[0]}", file=sys.stderr)
        return EXIT_INPUT
    print(f"irt: copied {len(written)} file{'s' if len(written) != 1 else ''} into {args.copy}/")
    return EXIT_OK


def cmd_fmt(args) -> int:
    from .core.diagnostics import IrtError
    from .lang.fmt import format_file

    try:
        sys.stdout.write(format_file(args.file))
    except IrtError as e:
        _print_diags(e)
        return EXIT_INPUT
    return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
