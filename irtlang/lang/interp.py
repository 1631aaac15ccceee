"""The interpreter: variables, DO / IF / MACRO / INCLUDE, and the commands that build the scene model.

Semantic errors are collected per statement (one pass reports them all); a statement that fails is skipped
and the names it would have defined are remembered as failed, so later uses do not cascade.

Commands that act on rays (TRACE, SAVE/LOAD RAYS and the analysis commands) become ``Step``s carrying a
snapshot of the scene; the interpreter hands each one to its ``engine`` as soon as it is reached, so output
interleaves with PRINT as written.  With no engine (``irt check``) steps are only collected.
"""
from __future__ import annotations

import hashlib
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable

from . import ast as A
from ..core.diagnostics import Diagnostic, DiagnosticBag, IrtError, Source, Span, did_you_mean, error
from .expr import CONSTANTS, Env, evaluate, format_value
from .parser import parse_source, read_source
from .spec import BindContext, bind, match_keyword
from ..core.units import LENGTH, NONE, UNITS, Quantity, dim_name
from ..limits import Limits, current as current_limits
from ..model import scene as M
from . import commands
from .state import State, StepFailed, StopScript, _SurfaceBlock  # noqa: F401  (re-exported: irtlang.lang.interp.State)

MAX_LOOP_ITERATIONS = 10_000_000
MAX_CALL_DEPTH = 64


NAMESPACES = ("medium", "coating", "spectrum", "model", "map", "object", "group")
# commands whose first argument is the name they define
DEFINES = {"MEDIUM": "medium", "COATING": "coating", "SPECTRUM": "spectrum", "MODEL": "model", "MAP": "map",
           "OBJECT": "object", "GROUP": "group"}


class Interpreter(BindContext):
    def __init__(self, engine: Any = None, out: Callable[[str], None] | None = None, *, check_only: bool = False,
                 limits: Limits | None = None, allow_outside: bool = False):
        self.engine = engine
        self.limits = limits if limits is not None else current_limits()   # irtlang/limits.py
        self.allow_outside = allow_outside          # irt run --allow-outside: outputs may leave the run folder
        self.steps_run = 0                          # statements and loop iterations run (limit steps)
        self.outputs = set()                        # every output name the script's commands write (normalized)
        self.rays_from = None                       # the step that made the current rays (TRACE, LOAD_RAYS)
        self.saved = {}                             # output name (normalized) -> span of the SAVE RAYS writing it
        self.script_names = set()                  # where a script was read from (INCLUDE resolution)
        self.out = out or (lambda s: print(s, flush=True))
        self.check_only = check_only
        self.state = State()
        self.globals: dict[str, tuple[str, Any]] = {}     # key -> (display name, value)
        self.frames: list[dict] = []                      # macro parameter frames
        self.macros: dict[str, A.Macro] = {}
        self.macro_stack: list[str] = []
        self.include_stack: list[Path] = []
        self.diags = DiagnosticBag()
        self.failed_vars: set[str] = set()                # variables whose assignment failed
        self.wavelengths_failed = False                   # a WAVELENGTHS failed: line counts may not match
        self.steps: list[M.Step] = []
        self.sources: list[Source] = []
        self.base_dir = Path.cwd()
        self.env = Env(self.lookup, lambda: self.state.units, self.variable_names)
        self.env.failed_var = self._failed_var
        self.env.limits = self.limits
        self._cmd_span: Span | None = None
        self._cmd: A.Command | None = None
        self.commands = commands.TABLE

    # ------------------------------------------------------------ entry points
    def run_file(self, path: str | Path) -> None:
        p = Path(path)
        src = read_source(p, max_bytes=self.limits["script"])
        self.base_dir = p.resolve().parent
        self.include_stack = [p.resolve()]
        self.run_source(src)

    def run_source(self, src: Source) -> None:
        self.sources.append(src)
        self.steps_run = 0
        check_source_size(src, self.limits)
        prog = parse_source(src, self.is_macro_head)
        try:
            self.exec_block(prog.stmts)
            self.finish()
        except StopScript:
            pass
        except StepFailed as e:        # a step's run stopped on bad input: report it with what came before
            self.diags.extend(e.error.diagnostics)
            raise IrtError(self.diags.items) from None

    def preset(self, assignments) -> None:
        """Variables given on the command line (`irt run FILE --set name=value`), before the script runs; the
        script's `DEFAULT name value` keeps them.  Each is parsed as the assignment `name = value`."""
        if not assignments:
            return
        text = "\n".join(a.replace("=", " = ", 1) if "=" in a else a for a in assignments) + "\n"
        src = Source("<--set>", text)
        self.sources.append(src)
        prog = parse_source(src, self.is_macro_head)
        self.exec_block(prog.stmts)
        if self.diags:
            raise IrtError(self.diags.items)

    def run_text(self, text: str, name: str = "<input>") -> None:
        self.run_source(Source(name, text))

    def finish(self) -> None:
        """End-of-script checks: open SURFACE block, open GROUP, grid without direction."""
        st = self.state
        if st.block is not None:
            self.diags.add(Diagnostic(st.block.span, "SURFACE block is never closed by OBJECT name"))
            st.block = None
        for g in st.group_stack:
            self.diags.add(Diagnostic(st.groups[g].span, f"GROUP {st.groups[g].name} without END GROUP"))
        st.group_stack.clear()
        self.check_references()

    def check_references(self) -> None:
        """Names that may be defined later than where they are used (TOWARD targets): checked once the whole
        script has run, so a TOWARD naming an object that is never defined is an error without a TRACE too."""
        st = self.state
        names = [o.name for o in st.objects.values()]

        def missing(t):
            return t is not None and t.upper() not in st.objects and ("object", t.upper()) not in st.failed

        for src in st.sources:
            t = src.params.get("toward")
            if missing(t):
                self.diags.add(Diagnostic(src.span, f"TOWARD target '{t}' is not an object", did_you_mean(t, names)))
        for med in st.media.values():
            t = med.params.get("volume", {}).get("toward") if med.params else None
            if missing(t):
                self.diags.add(Diagnostic(med.span, f"MEDIUM {med.name} ... TOWARD '{t}' is not an object",
                                          did_you_mean(t, names)))
        for obj in st.objects.values():
            for sc in obj.scatter:
                if missing(sc.toward):
                    self.diags.add(Diagnostic(sc.span, f"SCATTER ... TOWARD '{sc.toward}' is not an object",
                                              did_you_mean(sc.toward, names)))

    def is_macro_head(self, head: str) -> bool:
        try:
            return match_keyword(head, self.commands, Span(None, 0, 0, 0, 0)) == "MACRO"
        except IrtError:
            return False

    @property
    def script_hash(self) -> str:
        h = hashlib.sha256()
        for s in self.sources:
            h.update(s.text.encode())
        return h.hexdigest()

    # ------------------------------------------------------------ variables
    def lookup(self, name: str):
        k = name.upper()
        for fr in reversed(self.frames):
            if k in fr:
                return fr[k][1]
        v = self.globals.get(k)
        return v[1] if v else None

    def _failed_var(self, name: str, span: Span) -> None:
        if name.upper() in self.failed_vars:
            raise self.follow_on(span, f"variable '{name}' has no value: its assignment failed")

    def is_variable(self, name: str) -> bool:
        k = name.upper()
        return (any(k in fr for fr in self.frames) or k in self.globals or k in CONSTANTS
                or k in self.failed_vars)

    def variable_names(self) -> list[str]:
        names = [v[0] for v in self.globals.values()]
        for fr in self.frames:
            names.extend(v[0] for v in fr.values())
        return names

    def assign(self, name: str, value, span: Span) -> None:
        k = name.upper()
        if k in CONSTANTS:
            raise error(span, f"{name} is a constant and cannot be assigned")
        self.failed_vars.discard(k)      # (a TRACE that failed marked its CAMERA_SUN variables)
        for fr in reversed(self.frames):
            if k in fr:
                fr[k] = (name, value)
                return
        self.globals[k] = (name, value)

    # ------------------------------------------------------------ statements
    def exec_block(self, stmts) -> None:
        for st in stmts:
            self.exec_stmt(st)

    def count_step(self, span: Span) -> None:
        """One statement or loop iteration more; past the limit `steps` the script stops with a diagnostic."""
        self.steps_run += 1
        if self.steps_run > self.limits["steps"]:
            self.diags.add(Diagnostic(span, f"the script stops here: it ran more than the limit "
                                            f"steps={self.limits['steps']:,.0f} statements and loop iterations",
                                      self.limits.hint("steps")))
            raise StopScript()

    def exec_stmt(self, st) -> None:
        self.count_step(st.span)
        try:
            if isinstance(st, A.Assign):
                try:
                    value = evaluate(st.expr, self.env)
                except IrtError:
                    if st.name.upper() not in CONSTANTS:
                        self.failed_vars.add(st.name.upper())
                    raise
                self.assign(st.name, value, st.name_span)
                self.failed_vars.discard(st.name.upper())
            elif isinstance(st, A.Command):
                self.exec_command(st)
            elif isinstance(st, A.Do):
                try:
                    self.exec_do(st)
                except IrtError:  # bad bounds: the loop variable is never set
                    if not self.is_variable(st.var):
                        self.failed_vars.add(st.var.upper())
                    raise
            elif isinstance(st, A.If):
                for br in st.branches:
                    if br.cond is None or self.truth(br.cond):
                        self.exec_block(br.body)
                        break
            elif isinstance(st, A.Macro):
                k = st.name.upper()
                if k in self.macro_stack:
                    raise error(st.span, f"MACRO {st.name} is being redefined inside itself")
                self.macros[k] = st
        except IrtError as e:
            self.diags.extend(e.diagnostics)
        except RecursionError:  # blocks, calls and expressions nested beyond Python's stack
            self.diags.add(Diagnostic(st.span, "too deeply nested (blocks, macro calls or expressions)"))

    def truth(self, expr) -> bool:
        v = evaluate(expr, self.env)
        if isinstance(v, str):
            raise error(expr.span, "a condition must be a number, got a string")
        return v.value != 0.0

    def exec_do(self, st: A.Do) -> None:
        a, b = self.number(st.start), self.number(st.stop)
        step = self.number(st.step) if st.step is not None else Quantity(1.0)
        if step.value == 0:
            raise error(st.step.span, "DO step of 0 would never end")
        if a.dim != b.dim and None not in (a.dim, b.dim):
            raise error(st.span, f"DO bounds of different kinds: {dim_name(a.dim)} and {dim_name(b.dim)}")
        dim = a.dim if a.dim is not None else b.dim if b.dim is not None else step.dim
        fa = self.env.default_factor(dim) if dim not in (None, NONE) else 1.0
        lo = a.value if a.dim is not None else a.value * fa
        hi = b.value if b.dim is not None else b.value * fa
        dv = step.value if step.dim is not None else step.value * fa
        span_n = (hi - lo) / dv + 1e-9
        if not math.isfinite(span_n) or span_n > MAX_LOOP_ITERATIONS:
            raise error(st.span, f"DO loop of more than {MAX_LOOP_ITERATIONS} iterations")
        n = int(span_n) + 1 if (hi - lo) * dv >= 0 else 0
        if n > MAX_LOOP_ITERATIONS:
            raise error(st.span, f"DO loop of {n} iterations (more than {MAX_LOOP_ITERATIONS})")
        for i in range(n):
            self.count_step(st.span)
            v = lo + i * dv
            self.assign(st.var, Quantity(v, None if dim in (None,) else dim) if dim is not None
                        else Quantity(v), st.var_span)
            self.exec_block(st.body)

    def number(self, expr) -> Quantity:
        v = evaluate(expr, self.env)
        if isinstance(v, str):
            raise error(expr.span, f"expected a number, got the string '{v}'")
        return v

    def exec_command(self, st: A.Command) -> None:
        head = st.head.upper()
        if head == "END GROUP":
            key = "END GROUP"
        else:
            key = match_keyword(st.head, self.commands, st.head_span)
        if key is None:
            hint = did_you_mean(st.head, list(self.commands) + list(self.macros))
            short = sorted(c for c in self.commands if c.startswith(head) and " " not in c)
            if len(head) < 3 and short:  # `SP`: too short to abbreviate anything
                hint = "an abbreviation needs at least 3 letters: " + ", ".join(short)
            if st.head.upper() in self.macros:
                hint = f"call a macro with CALL {st.head}"
            raise error(st.head_span, f"unknown command '{st.head}'", hint)
        cmd = self.commands[key]
        self._cmd_span = st.span
        self._cmd = st
        try:
            b = bind(key, cmd.form, st, self) if cmd.form is not None else None
            cmd.handler(self, b, st)
        except IrtError:
            self._failed(key, st)
            raise

    def _failed(self, key: str, st: A.Command) -> None:
        """A command failed: remember what it would have defined, so later uses do not cascade."""
        from ..plugins.surfaces import REGISTRY as SURFACE_KINDS

        s = self.state
        if key == "WAVELENGTHS":
            self.wavelengths_failed = True
        if key in ("GRID", "SOURCE", "EMITTING", "FLUX"):
            s.source_failed = True
        if key == "TRACE":
            # it would have traced (and so used up) the sources defined before it and, camera-side, set the light's
            # band irradiance CAMERA_SUN[_filter] of its camera: a later TRACE and those variables' uses are quiet
            s.sources.clear()
            s.source_failed = False
            s.traces += 1
            self.failed_vars.add("CAMERA_SUN")
            for obj in s.objects.values():
                for fname, _ in ((obj.detector.filters or ()) if obj.detector is not None else ()):
                    self.failed_vars.add(f"CAMERA_SUN_{fname}".upper())
        if key in SURFACE_KINDS and s.block is not None:
            s.block.failed = True
            return
        if key == "OBJECT":  # it closes the block even so; "\0" is no object's key: its modifiers are skipped
            s.block, s.current = None, "\0"
        ns = DEFINES.get(key)
        first = st.args[0] if st.args else None
        if ns is None or not isinstance(first, (A.Word, A.Str)):
            return
        try:
            name = first.name if isinstance(first, A.Word) else self.string(first)
        except IrtError:
            return
        k = name.upper()
        if key == "GROUP" and k in s.groups and s.block is None and k not in s.group_stack:
            s.group_stack.append(k)  # a duplicate GROUP still opens, so its END GROUP matches
            s.current = None
        self.fail(ns, name)

    # ------------------------------------------------------------ BindContext
    def eval(self, expr):
        return evaluate(expr, self.env)

    def string(self, item) -> str:
        v = evaluate(item, self.env)
        return v if isinstance(v, str) else format_value(v, self.env)

    def to_dim(self, v, dim, span: Span):
        if dim is None:
            return v
        if isinstance(v, str):
            raise error(span, f"expected {dim_name(dim)}, got the string '{v}'")
        if v.dim is None or v.dim == NONE:
            if dim == NONE:
                return v.value
            return v.value * self.env.default_factor(dim)
        if v.dim == dim:
            return v.value
        raise error(span, f"expected {dim_name(dim)}, got {v.describe(self.state.units)}")

    def resolve(self, ns: str, name: str, span: Span) -> str:
        """The key of a defined `name` in namespace `ns`, or a diagnostic naming what it is instead."""
        k = name.upper()
        table = self._table(ns)
        if k in table:
            return k
        if ns == "object" and k in getattr(self, "loaded_objects", ()):   # named by a LOAD RAYS file
            return k
        if (ns, k) in self.state.failed:
            raise self.follow_on(span, f"{ns} '{name}' was not defined because its definition failed")
        elsewhere = [n for n in NAMESPACES if n != ns and k in self._table(n)]
        hint = did_you_mean(name, [v.name for v in table.values()])
        if elsewhere:
            an = {n: ("an " if n[0] in "aeiou" else "a ") + n for n in (elsewhere[0], ns)}
            raise error(span, f"'{name}' is {an[elsewhere[0]]}, not {an[ns]}", hint)
        raise error(span, f"undefined {ns} '{name}'", hint)

    def follow_on(self, span: Span, message: str) -> IrtError:
        """The error for a use of something whose definition failed: nothing more while that failure is in
        this report (no cascade), else (a later REPL line) a message that says why."""
        if self.diags:
            return IrtError([])
        return error(span, message + " (see the earlier error)")

    def _table(self, ns: str) -> dict:
        st = self.state
        return {"medium": st.media, "coating": st.coatings, "spectrum": st.spectra, "model": st.models,
                "map": st.maps, "object": st.objects, "group": st.groups}[ns]

    def n_lines(self) -> int:
        if self.state.first_per_line is None:
            self.state.first_per_line = self._cmd_span
        return len(self.state.wavelengths_nm)

    def spectrum_on_lines(self, name: str, span: Span) -> tuple:
        return self.state.spectra[name].on_lines

    def length_factor(self) -> float:
        return UNITS[self.state.units.lower()][0]

    def input_path(self, rel: str, span: Span, limit: str = "input") -> Path:
        """An input file (INCLUDE, TABLE, MAP, LOAD RAYS, ...): a relative path is looked up in the folder of the
        script that names it, then in each folder of IRT_PATH; the file must be a regular file no larger than the
        limit `limit` (irtlang/limits.py)."""
        base = self.include_stack[-1].parent if self.include_stack else self.base_dir
        p = find_input(rel, base)
        if p is None:
            where = [str(base)] + [d for d in search_path() if d]
            raise error(span, f"file not found: '{rel}' (looked in {', '.join(where)})",
                        "a relative path is relative to the script's folder, then to the folders of IRT_PATH")
        if p.is_dir():
            raise error(span, f"'{rel}' is a folder, not a file")
        if not p.is_file():
            raise error(span, f"'{rel}' is not a regular file")
        size = p.stat().st_size
        over = self.limits.exceeded(limit, size)
        if over:
            raise error(span, f"'{rel}' is too large: {over}", self.limits.hint(limit))
        return p

    def saved_output(self, rel: str) -> str | None:
        """The name of an output an earlier SAVE RAYS of this script writes, if `rel` names it."""
        k = _normal(rel)
        return k if k in self.saved else None

    def output_name(self, rel: str, span: Span) -> str:
        """An output file named in the script: it must stay inside the run folder (no absolute path, no '..'
        that climbs out of it) unless the run allows it (irt run --allow-outside).  Returns the name."""
        problem = output_problem(rel, self.allow_outside)
        if problem:
            raise error(span, problem, "outputs go inside the run folder (irt run --out DIR); to write elsewhere "
                        "on purpose, run with `irt run --allow-outside`" if "run folder" in problem else None)
        return rel

    # ------------------------------------------------------------ helpers for commands
    def define(self, ns: str, key: str, value, span: Span, *, unique: bool = False) -> None:
        table = self._table(ns)
        if unique and key in table:
            prev = table[key].span
            raise error(span, f"duplicate {ns} name '{value.name}'", f"names are case-insensitive; "
                        f"{value.name} was defined at line {prev.line}" if prev.line else None,
                        notes=[(prev, "first defined here")] if prev.source else [])
        table[key] = value
        self.state.failed.discard((ns, key))

    def fail(self, ns: str, name: str) -> None:
        self.state.failed.add((ns, name.upper()))

    def step(self, kind: str, params: dict, span: Span, with_scene: bool = True) -> None:
        self.check_step(kind, params, span)
        s = M.Step(kind, M.frozen_params(params), self.state.scene() if with_scene else None, span)
        self.steps.append(s)
        if self.engine is not None:
            try:
                self.engine.run_step(s, self)
            except IrtError as e:
                raise StepFailed(e) from None

    # ------------------------------------------------------------ containment and limits of steps
    def _arg_span(self, text: str, default: Span) -> Span:
        """The span of the current command's quoted argument whose value is `text` (else `default`)."""
        st = self._cmd
        for a in (st.args if st is not None else ()):
            if isinstance(a, A.Str):
                try:
                    if self.string(a) == text:
                        return a.span
                except IrtError:
                    pass
        return default

    def check_step(self, kind: str, params: dict, span: Span) -> None:
        """What a step asks for, checked before it runs (and by irt check): every output it names stays inside
        the run folder; images and traces within the limits (irtlang/limits.py)."""
        lim = self.limits
        f = params.get("file")
        if isinstance(f, str) and kind != "LOAD_RAYS":
            self.output_name(f, self._arg_span(f, span))
            self.outputs.add(_normal(f))
            if kind == "SAVE_RAYS":
                self.saved[_normal(f)] = span
        if kind == "ANALYZE":
            from .commands import ANALYSIS_OUTPUT_OPTIONS

            argv = params.get("argv", ())
            for prev, a in zip(argv, argv[1:]):
                if prev in ANALYSIS_OUTPUT_OPTIONS and isinstance(a, str) and a.startswith("\0path:"):
                    name = a[len("\0path:"):]
                    self.output_name(name, self._arg_span(name, span))
                    self.outputs.add(_normal(name))
            self.check_analyze_inputs(argv, params.get("base"), span)
        pix = None
        if kind == "PIXELS":
            pix = params["nx"] * params["ny"]
        elif kind == "PSF" and params.get("size"):
            pix = params["size"] ** 2
        if pix is not None:
            over = lim.exceeded("pixels", pix)
            if over:
                raise error(span, f"an image of {over}", lim.hint("pixels"))
        if kind == "TRACE":
            self.check_trace(span)
        if kind in ("TRACE", "LOAD_RAYS", "RESET"):   # a file this script saved keeps its TRACE's ledger
            self.rays_from = "LOADED" if kind == "LOAD_RAYS" and not params.get("in_run_folder") else kind
        # (a ray file carries its TRACE's ledger; one that does not is reported when the run reads it)

    def check_analyze_inputs(self, argv, base, span: Span) -> None:
        """The input files of an ANALYZE (its positional arguments) must be written earlier by this script (in
        the run folder) or found as inputs are (the script's folder, then IRT_PATH)."""
        from .commands import analysis_parser

        plain = [a.replace("\0path:", "") for a in argv]
        try:
            p = analysis_parser()
            ns = p.parse_args(plain)
            sub = p._subparsers._group_actions[0].choices[plain[0]]
        except (ValueError, KeyError, AttributeError, IndexError):   # reported by ANALYZE itself
            return
        names = []
        for act in sub._actions:
            if not act.option_strings and act.dest not in ("help",):
                v = getattr(ns, act.dest, None)
                names.extend(v if isinstance(v, list) else [v] if isinstance(v, str) else [])
        for name in names:
            if self._produced(name) or find_input(name, Path(base) if base else self.base_dir) is not None:
                continue
            head = name.split(":", 1)[0]     # FILE.h5:DETECTOR[:LINE]
            if head != name and (self._produced(head) or find_input(head, Path(base) if base else self.base_dir)):
                continue
            raise error(self._arg_span(name, span), f"ANALYZE input '{name}' is not written earlier by this "
                        "script and not found", "name a file an earlier command writes (EXPORT, SPECTRUM OF, "
                        "SAVE RAYS ...) or one next to the script (or in IRT_PATH)")

    def _produced(self, name: str) -> bool:
        """Whether an earlier command of this script writes `name` (a file, or a folder holding some)."""
        k = _normal(name)
        return k in self.outputs or any(o.startswith(k.rstrip("/") + "/") for o in self.outputs)

    def check_trace(self, span: Span) -> None:
        """Rays of one TRACE and each detector's pixels against the limits `rays` and `pixels`."""
        lim, st = self.limits, self.state
        for obj in st.objects.values():
            det = obj.detector
            if det is not None:
                planes = len(det.filters) if det.filters else len(st.wavelengths_nm)
                over = lim.exceeded("pixels", det.nx * det.ny)
                if over:
                    raise error(det.span, f"DETECTOR of object {obj.name}: {over}", lim.hint("pixels"))
                over = lim.exceeded("pixels", det.nx * det.ny * planes)
                if over:
                    raise error(det.span, f"DETECTOR of object {obj.name}: its {planes} images (one per "
                                f"{'filter' if det.filters else 'line'}) hold {over}", lim.hint("pixels"))
        total, biggest = 0, None
        for src in st.sources:
            n = source_rays(src)
            total += n
            if biggest is None or n > biggest[0]:
                biggest = (n, src)
        total *= len(st.wavelengths_nm)
        over = lim.exceeded("rays", total)
        if over:
            notes = [(biggest[1].span, f"this source sends {biggest[0]:,} rays per line")] if biggest else []
            raise error(span, f"this TRACE would trace {over} (sources x {len(st.wavelengths_nm)} wavelength "
                        "lines)", lim.hint("rays"), notes=notes)

    def current_group(self) -> str | None:
        return self.state.group_stack[-1] if self.state.group_stack else None

    def print(self, text: str) -> None:
        if not self.check_only:
            self.out(text)

    # ------------------------------------------------------------ INCLUDE and CALL
    def include(self, rel: str, span: Span) -> None:
        if Path(rel).suffix.lower() not in SCRIPT_SUFFIXES:
            raise error(span, f"INCLUDE reads irtlang scripts (*.inr); '{rel}' is not one",
                        "a data file is read by the command that uses it (MEDIUM ... TABLE, MAP, LOAD RAYS, ...)")
        try:
            p = self.input_path(rel, span, limit="script").resolve()
        except IrtError as e:   # not next to the including script: the search path ($IRT_PATH, installed examples)
            from ..library import find_include

            found = find_include(rel)
            if found is None:
                if not e.diagnostics[0].message.startswith("file not found"):
                    raise
                raise error(span, f"{e.diagnostics[0].message}, nor on the INCLUDE search path",
                            "the search path is $IRT_PATH, then the installed examples (irt examples)") from None
            p = found.resolve()
        if p in self.include_stack:
            chain = " -> ".join(x.name for x in self.include_stack + [p])
            raise error(span, f"recursive INCLUDE: {chain}")
        if len(self.include_stack) > MAX_CALL_DEPTH:
            raise error(span, "INCLUDE nested too deeply")
        try:
            src = read_source(p, display_name=_display(p), max_bytes=self.limits["script"])
        except IrtError as e:  # a file-level problem (not text, unreadable) is reported at the INCLUDE
            raise IrtError([replace(d, span=span) if d.span.line <= 0 else d for d in e.diagnostics]) from None
        self.sources.append(src)
        check_source_size(src, self.limits)
        prog = parse_source(src, self.is_macro_head)
        self.include_stack.append(p)
        try:
            self.exec_block(prog.stmts)
        finally:
            self.include_stack.pop()

    def call(self, name: str, args: tuple, span: Span, name_span: Span) -> None:
        k = name.upper()
        m = self.macros.get(k)
        if m is None:
            raise error(name_span, f"undefined macro '{name}'", did_you_mean(name, [x.name for x in self.macros.values()]))
        if len(self.macro_stack) >= MAX_CALL_DEPTH:
            raise error(span, f"MACRO calls nested more than {MAX_CALL_DEPTH} deep")
        if k in self.macro_stack:
            raise error(span, "recursive MACRO: " + " -> ".join(self.macros[x].name for x in self.macro_stack + [k]))
        if len(args) != len(m.params):
            raise error(span, f"wrong number of arguments: macro {m.name} takes {len(m.params)}"
                        + (f" ({' '.join(m.params)})" if m.params else "") + f", got {len(args)}",
                        notes=[(m.span, "defined here")])
        frame = {}
        for p, a in zip(m.params, args):
            if isinstance(a, A.Word) and not self.is_variable(a.name):
                frame[p.upper()] = (p, a.name)          # a bare name passes as text (an object name, say)
            else:
                frame[p.upper()] = (p, evaluate(a, self.env))
        self.frames.append(frame)
        self.macro_stack.append(k)
        try:
            self.exec_block(m.body)
        finally:
            self.frames.pop()
            self.macro_stack.pop()


SCRIPT_SUFFIXES = (".inr",)
PATH_ENV = "IRT_PATH"


def search_path() -> list[str]:
    """The folders of IRT_PATH (os.pathsep separated), searched after the script's own folder."""
    import os

    return [d for d in os.environ.get(PATH_ENV, "").split(os.pathsep) if d]


def find_input(rel: str, base: Path) -> Path | None:
    """An input's path: absolute as given; relative: in `base` (the naming script's folder), then in IRT_PATH."""
    if "\0" in rel:
        return None
    p = Path(rel)
    try:
        if p.is_absolute():
            return p if p.exists() else None
        for d in [base] + [Path(x) for x in search_path()]:
            q = d / p
            if q.exists():
                return q
    except OSError:     # a name too long for the file system
        return None
    return None


def output_problem(rel: str, allow_outside: bool = False) -> str | None:
    """Why an output name cannot be used (None when it can): empty, control characters, too long, or (unless
    allowed) an absolute path or a '..' that leaves the run folder."""
    import os
    import posixpath

    if not rel.strip():
        return "an output file needs a name"
    if any(ord(c) < 32 or ord(c) == 127 for c in rel):
        return "an output file name cannot contain control characters"
    if len(rel) > 1024 or any(len(part) > 255 for part in rel.replace("\\", "/").split("/")):
        return "an output file name is too long (at most 255 characters a part, 1024 in all)"
    if rel.endswith(("/", "\\")) or posixpath.basename(rel) in (".", ".."):
        return f"output '{rel}' names a folder, not a file"
    if allow_outside:
        return None
    drive = len(rel) > 1 and rel[0].isalpha() and rel[1] == ":" and rel[2:3] in ("", "/", "\\")   # C:\x
    if os.path.isabs(rel) or rel.startswith(("/", "\\")) or drive:
        return f"output '{rel}' is an absolute path: outputs stay inside the run folder"
    depth = 0
    for part in rel.replace("\\", "/").split("/"):
        if part == "..":
            depth -= 1
            if depth < 0:
                return f"output '{rel}' leaves the run folder ('..')"
        elif part not in ("", "."):
            depth += 1
    return None


def _normal(name: str) -> str:
    """An output name as the run folder stores it ('./a//b.h5' and 'a/b.h5' are one file)."""
    import posixpath

    return posixpath.normpath(name.replace("\\", "/"))


def source_rays(src) -> int:
    """Rays a source sends per wavelength line (as irtlang.compile.pack counts them; a regular GRID DISK's
    lattice may hold a few more or fewer)."""
    p = src.params
    if src.kind.startswith("GRID"):
        g = p["grid"]
        if src.kind.startswith("GRID RECT"):
            return int(g["nx"]) * int(g["ny"])
        return int(g["rays"])
    return int(p.get("rays", 1))


def check_source_size(src: Source, limits: Limits) -> None:
    """A script's size and its longest line against the limits `script` and `statement`."""
    over = limits.exceeded("script", len(src.text.encode("utf-8", "surrogatepass")))
    if over:
        raise error(Span(src, 0, 0, 0, 0), f"{src.name} is too large: {over}", limits.hint("script"))
    lim = limits["statement"]
    if len(src.text) > lim:
        for n, line in enumerate(src.text.split("\n"), 1):
            if len(line) > lim:
                raise error(Span(src, n, 1, n, 2), f"line {n} is too long: "
                            f"{limits.exceeded('statement', len(line))}", limits.hint("statement"))


def _display(p: Path) -> str:
    try:
        return str(p.relative_to(Path.cwd()))
    except ValueError:
        return str(p)


def check_file(path: str | Path, presets=(), *, limits: Limits | None = None, allow_outside: bool = False) -> Interpreter:
    """Parse and validate a script; raise IrtError with every diagnostic if it has any."""
    it = Interpreter(check_only=True, limits=limits, allow_outside=allow_outside)
    it.preset(presets)
    it.run_file(path)
    if it.diags:
        raise IrtError(it.diags.items)
    return it
