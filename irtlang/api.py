"""The Python API: ``irtlang.run`` and ``irtlang.check`` (docs/python_api.md).

``irt run`` and ``irtlang.run`` share ``execute``: the same script gives the same files, manifest and
``results.nc``.  Input errors raise ``IrtError`` (its ``diagnostics`` are ``Diagnostic`` objects); a run that
stops (a failure, a missing capability) raises ``RunError`` carrying the partial ``RunResult``.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from .core.diagnostics import Diagnostic, IrtError, Source, Span

RESULTS_FILE = "results.nc"


@dataclass
class Script:
    """A script to run: a file, or text (named `name`, INCLUDEs relative to `base`)."""
    path: Path | None
    text: str | None = None
    name: str = "script"
    base: Path | None = None

    @property
    def stem(self) -> str:
        return self.path.stem if self.path is not None else self.name


def as_script(script_or_path) -> Script:
    """A path (str or Path naming an existing file, or a str ending in .inr) or the text of a script."""
    if isinstance(script_or_path, Path):
        return Script(script_or_path)
    s = str(script_or_path)
    if "\n" not in s and (s.lower().endswith(".inr") or os.path.isfile(s)):
        return Script(Path(s))
    return Script(None, s, "script", Path.cwd())


def presets_from(set: Mapping[str, Any] | None) -> list[str]:
    """`set={...}` as `irt run --set` assignments: numbers as numbers, strings as the expression text on the
    right of `=` (so a text value keeps its quotes: {"clouds": "'hg'"}, a length its unit: {"r": "2 MM"})."""
    out = []
    for k, v in (set or {}).items():
        if isinstance(v, bool):
            v = int(v)
        out.append(f"{k}={v!r}" if isinstance(v, (int, float)) else f"{k}={v}")
    return out


def _where(path) -> Span:
    return Span(Source(str(path), ""), 0, 0, 0, 0)   # renders as "PATH: error: ..."


class OutputFolderError(Exception):
    """The run folder cannot be made or used (a path the user gave: reported, not an internal error)."""


def load_check(script: Script, presets=(), *, limits=None, allow_outside: bool = False):
    """Check a script; returns the checking interpreter, or raises IrtError with every diagnostic.
    `limits` (irtlang.limits.Limits; default IRT_LIMITS or the defaults) and `allow_outside` as `irt check`'s
    --limit and --allow-outside (docs/language.md, "Safety and limits")."""
    from .engine import check_trace_memory
    from .lang.interp import Interpreter, check_file
    from .limits import current as current_limits

    limits = limits if limits is not None else current_limits()
    if script.path is not None:
        p = script.path
        if "\0" in str(p):
            raise IrtError(Diagnostic(_where(p), f"no such file: {str(p)!r}"))
        if not p.exists():
            raise IrtError(Diagnostic(_where(p), f"no such file: {p}"))
        if p.is_dir():
            raise IrtError(Diagnostic(_where(p), f"{p} is a folder, not a script"))
        it = check_file(p, presets, limits=limits, allow_outside=allow_outside)
    else:
        it = Interpreter(check_only=True, limits=limits, allow_outside=allow_outside)
        it.base_dir = script.base or Path.cwd()
        it.preset(presets)
        it.run_text(script.text, script.name)
        if it.diags:
            raise IrtError(it.diags.items)
    diags = check_trace_memory(it.steps, limits)   # needs every step of the script: which records are kept
    if diags:
        raise IrtError(diags)
    return it


@dataclass
class Execution:
    """What `execute` did: the folder, the interpreter that ran, how it ended, and the results Dataset."""
    folder: Any
    interp: Any
    status: str
    error: BaseException | None = None
    dataset: Any = None
    manifest_path: Path | None = None


def execute(script: Script, *, presets=(), seed: int | None = None, out: Path | None = None, runner=None,
            progress=None, echo=None, checked=None) -> Execution:
    """Run a checked script into its run folder, write results.nc and the manifest.  Input errors in the
    script raise IrtError before anything is written; errors while running are returned in `.error` (the
    manifest says how the run ended); other exceptions are recorded in the manifest and re-raised."""
    from .engine import Engine, MissingCapability, RuntimeFailure, needs_from_steps
    from .io.manifest import RunFolder
    from .io.results import ResultsCollector
    from .lang.interp import Interpreter

    checked = checked or load_check(script, presets)
    out = Path(out) if out is not None else Path("irt-out") / script.stem
    eff_seed = checked.state.seed if seed is None else int(seed)
    try:   # the manifest says "running" (incomplete) before any output is written
        folder = RunFolder(out, str(script.path) if script.path is not None else f"<{script.name}>",
                           checked.script_hash, eff_seed, allow_outside=bool(getattr(checked, "allow_outside", False)))
    except (OSError, ValueError) as e:
        raise OutputFolderError(f"cannot use {str(out)!r} as the output folder: "
                                f"{getattr(e, 'strerror', None) or e}") from None
    if seed is not None:
        folder.info["seed_from"] = "--seed"   # the script's SEED values were replaced (irt run --seed, seed=)
    records, history = needs_from_steps(checked.steps)
    if progress is not None and hasattr(progress, "frames"):
        progress.frames = sum(1 for s in checked.steps if s.kind == "TRACE")
    engine = Engine(folder, records=records, history=history, runner=runner, progress=progress, out=echo)
    spill = Path(tempfile.mkdtemp(prefix=".irt-results-", dir=folder.root))   # images wait here for results.nc
    engine.collector = ResultsCollector(spill)
    engine.seed = None if seed is None else int(seed)
    it = Interpreter(engine=engine, out=echo, limits=checked.limits, allow_outside=checked.allow_outside)
    status, error = "complete", None
    ahead = _compile_ahead(script, presets, checked)
    try:
        it.preset(presets)
        if script.path is not None:
            it.run_file(script.path)
        else:
            it.base_dir = script.base or Path.cwd()
            it.run_text(script.text, script.name)
        if it.diags:  # run-time diagnostics (a value only known while running)
            raise IrtError(it.diags.items)
    except MissingCapability as e:
        status, error = f"stopped: {e.what} needs {e.capability}", e
    except RuntimeFailure as e:
        status, error = f"failed: {e.message}", e
    except IrtError as e:
        status, error = "failed: input errors", e
    except KeyboardInterrupt as e:
        status, error = "interrupted", e
    except Exception as e:  # keep what was written, then report the internal error
        shutil.rmtree(spill, ignore_errors=True)
        if type(e).__name__ == "ClusterError":   # irtlang.cluster: the cluster failed, not irtlang
            folder.write_manifest(f"failed: {e}")
        else:
            folder.write_manifest(f"internal error: {type(e).__name__}: {e}")
        raise
    finally:
        if ahead is not None:
            from . import tracer

            tracer.COMPILE_AHEAD[:] = [h for h in tracer.COMPILE_AHEAD if h is not ahead]
            ahead.stop()
    try:
        _write_results(folder, engine.collector)
    finally:
        shutil.rmtree(spill, ignore_errors=True)
    man = folder.write_manifest(status)
    return Execution(folder, it, status, error, None, man)


class _Ahead:
    """The hook `execute` leaves in irtlang.tracer.COMPILE_AHEAD: at the run's first compile of a kernel Numba's
    cache lacks, start irtlang.ahead on the script (its later kernels, compiled meanwhile by another process)."""

    def __init__(self, script: Script, presets, allow_outside: bool, limits=()):
        self.args, self.limits, self.proc = (script.path, tuple(presets or ()), allow_outside), tuple(limits), None

    def __call__(self) -> None:
        from .ahead import start

        self.proc = start(*self.args, limits=self.limits)

    def stop(self) -> None:
        """At the run's end: a kernel the run did not reach is not compiled on (nor is a plan that missed)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except Exception:
                pass


def _compile_ahead(script: Script, presets, checked):
    from . import tracer

    if script.path is None:
        return None
    lim = getattr(getattr(checked, "limits", None), "values", {}) or {}
    hook = _Ahead(script, presets, bool(getattr(checked, "allow_outside", False)),
                  [f"{k}={v!r}" for k, v in lim.items()])     # the run's limits, as --limit strings
    tracer.COMPILE_AHEAD.append(hook)
    return hook


def _write_results(folder, collector):
    """results.nc: every image, spectrum and ledger of the run (irtlang/io/results.py)."""
    from .io.results import write_results

    p = write_results(collector, folder.info, folder.root / RESULTS_FILE)
    folder.record(p, "results")


# ---------------------------------------------------------------------------------------------- public
class RunError(Exception):
    """A run that did not complete; `.result` holds what it wrote, `.status` how it ended."""

    def __init__(self, message: str, result: "RunResult", cause: BaseException | None = None):
        super().__init__(message)
        self.result, self.status, self.cause = result, result.status, cause


@dataclass
class RunResult:
    """A finished run: its folder, status, manifest, files, variables and the Dataset of its results."""
    folder: Path
    status: str
    manifest: dict
    variables: dict
    output: str
    _dataset: Any = field(default=None, repr=False)

    @property
    def files(self) -> dict[str, Path]:
        """Every file the run wrote (the manifest's list): relative name -> path."""
        return {f["path"]: self.folder / f["path"] for f in self.manifest.get("files", [])}

    @property
    def dataset(self):
        """The run's xarray Dataset: results.nc, opened lazily (values are read when used; .load() reads all)."""
        if self._dataset is None:
            import xarray as xr

            self._dataset = xr.open_dataset(self.folder / RESULTS_FILE)
        return self._dataset


def _python_value(v):
    from .core.units import Quantity

    if isinstance(v, Quantity):
        return float(v.value)
    if isinstance(v, (list, tuple)):
        return type(v)(_python_value(x) for x in v)
    return v


def run(script_or_path, set: Mapping[str, Any] | None = None, seed: int | None = None, out=None, *,
        echo: bool = False, progress: bool = False) -> RunResult:
    """Run a script (a path, or its text) as `irt run` does and return its RunResult.

    set: variables before the script runs (`irt run --set`); seed: replaces the script's SEED values
    (`irt run --seed`); out: the run folder (default irt-out/<script name>/, or a new temporary folder for a
    script given as text); echo: also print what the run prints; progress: show the progress bar."""
    from .progress import RunProgress

    script = as_script(script_or_path)
    presets = presets_from(set)
    if out is None and script.path is None:
        out = Path(tempfile.mkdtemp(prefix="irt-run-"))
    printed: list[str] = []

    def sink(text: str) -> None:
        printed.append(text)
        if echo:
            print(text, flush=True)

    ex = execute(script, presets=presets, seed=seed, out=out, echo=sink,
                 progress=RunProgress(enabled=bool(progress)))
    manifest = json.loads(ex.manifest_path.read_text())
    variables = {v[0]: _python_value(v[1]) for v in ex.interp.globals.values()}
    res = RunResult(Path(ex.folder.root), ex.status, manifest, variables, "\n".join(printed), ex.dataset)
    if ex.error is not None:
        if isinstance(ex.error, KeyboardInterrupt):
            raise ex.error
        msg = ex.error.render() if isinstance(ex.error, IrtError) else _render(ex.error)
        raise RunError(f"{ex.status}\n{msg}", res, ex.error) from ex.error
    return res


def _render(e) -> str:
    span, message = getattr(e, "span", None), getattr(e, "message", None) or str(e)
    return Diagnostic(span, message).render() if span is not None else message


def check(script_or_path, set: Mapping[str, Any] | None = None) -> list[Diagnostic]:
    """Parse and validate a script (`irt check`); returns its diagnostics (an empty list: the script is
    valid).  Each is a Diagnostic: .message, .hint, .severity, .span (.file, .line, .col), .render()."""
    try:
        load_check(as_script(script_or_path), presets_from(set))
    except IrtError as e:
        return list(e.diagnostics)
    return []
