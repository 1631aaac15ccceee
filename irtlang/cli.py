"""The ``irt`` command: run, check, fmt, repl, analyze.

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
    if "NUMBA_CACHE_DIR" not in os.environ:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        os.environ["NUMBA_CACHE_DIR"] = os.path.join(base, "irtlang", "numba")


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

    f = sub.add_parser("fmt", help="print a script in canonical formatting")
    f.add_argument("file")
    f.add_argument("--debug", action="store_true", default=argparse.SUPPRESS)

    sub.add_parser("repl", help="interactive session")

    a = sub.add_parser("analyze", help="analyses of saved images, spectra and ray files")
    if _wants_analysis(argv):
        from .core.hooks import analysis_provider

        acli = analysis_provider(required=False)  # the analysis package (irtlang/core/hooks.py)
        if acli is not None and hasattr(acli, "build_parser"):
            acli.build_parser(a.add_subparsers(dest="analysis_cmd", metavar="ANALYSIS"))
    return p


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
    from .core.diagnostics import Diagnostic, IrtError, Source, Span
    from .engine import check_trace_memory
    from .lang.interp import check_file

    p = Path(path)
    at = Span(Source(str(path), ""), 0, 0, 0, 0)  # renders as "PATH: error: ..." (not "<input>")
    if "\0" in str(path) or not p.exists():
        raise IrtError(Diagnostic(at, f"no such file: {path!r}" if "\0" in str(path) else f"no such file: {path}"))
    if p.is_dir():
        raise IrtError(Diagnostic(at, f"{path} is a folder, not a script"))
    limits = _limits(args)
    it = check_file(p, presets, limits=limits, allow_outside=bool(getattr(args, "allow_outside", False)))
    diags = check_trace_memory(it.steps, limits)   # needs every step of the script: which records are kept
    if diags:
        raise IrtError(diags)
    return it


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


def cmd_run(args) -> int:
    scheduler, workers = getattr(args, "scheduler", None), getattr(args, "workers", None)
    if not scheduler and workers is None:
        return _run_script(args)
    from .cluster import DEFAULT_TIMEOUT, ClusterError, DaskRunner, connect
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
        client.close()


def _run_script(args, runner=None) -> int:
    from .engine import Engine, MissingCapability, RuntimeFailure
    from .io.manifest import RunFolder
    from .core.diagnostics import Diagnostic, IrtError
    from .lang.interp import Interpreter

    try:
        checked = _load_check(args.file, getattr(args, "set", None) or (), args)
    except IrtError as e:
        _print_diags(e)
        return EXIT_INPUT
    script = Path(args.file)
    out = Path(args.out) if args.out else Path("irt-out") / script.stem
    from .engine import needs_from_steps
    from .tracer import Progress

    try:   # the manifest says "running" (incomplete) before any output is written
        folder = RunFolder(out, str(script), checked.script_hash, checked.state.seed,
                           allow_outside=bool(getattr(args, "allow_outside", False)))
    except (OSError, ValueError) as e:
        raise UsageError(f"cannot use {str(out)!r} as the output folder: {getattr(e, 'strerror', None) or e}") from None
    records, history = needs_from_steps(checked.steps)
    it = Interpreter(engine=Engine(folder, records=records, history=history, runner=runner), limits=checked.limits,
                     allow_outside=checked.allow_outside)
    status = "complete"
    code = EXIT_OK
    try:
        it.preset(getattr(args, "set", None) or ())
        it.run_file(script)
        if it.diags:  # run-time diagnostics (a value only known while running)
            raise IrtError(it.diags.items)
    except MissingCapability as e:
        print(Diagnostic(e.span, f"{e.what} needs {e.capability}, which this version of irtlang "
                                 f"(v{__version__}) does not have yet; the run stops here").render(), file=sys.stderr)
        status, code = f"stopped: {e.what} needs {e.capability}", EXIT_MISSING
    except RuntimeFailure as e:
        print(Diagnostic(e.span, e.message).render(), file=sys.stderr)
        status, code = f"failed: {e.message}", EXIT_RUNTIME
    except IrtError as e:
        _print_diags(e)
        status, code = "failed: input errors", EXIT_INPUT
    except KeyboardInterrupt:
        status, code = "interrupted", EXIT_INTERRUPTED
        print("irt: interrupted; keeping what was written", file=sys.stderr)
    except Exception as e:  # keep what was written, then report the internal error
        if type(e).__name__ == "ClusterError":   # irtlang.cluster: the cluster failed, not irtlang
            folder.write_manifest(f"failed: {e}")
        else:
            folder.write_manifest(f"internal error: {type(e).__name__}: {e}")
        raise
    man = folder.write_manifest(status)
    print(f"irt: outputs in {folder.root}/ ({len(folder.files)} file{'s' if len(folder.files) != 1 else ''}; "
          f"manifest {man})")
    return code


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
