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
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

from . import ast as A
from .diagnostics import Diagnostic, DiagnosticBag, IrtError, Source, Span, did_you_mean, error
from .expr import CONSTANTS, Env, evaluate, format_value
from .parser import parse_source, read_source
from .spec import BindContext, bind, match_keyword
from .units import LENGTH, NONE, UNITS, Quantity, dim_name
from ..model import scene as M

MAX_LOOP_ITERATIONS = 10_000_000
MAX_CALL_DEPTH = 64


class StopScript(Exception):
    """STOP: ends the script here."""


@dataclass
class _SurfaceBlock:
    span: Span
    surfaces: list = field(default_factory=list)
    failed: bool = False                       # a surface in it failed: its OBJECT fails quietly


@dataclass
class State:
    """Everything a script has defined so far (mutable while interpreting; steps get frozen snapshots)."""

    units: str = "MM"
    wavelengths_nm: tuple = (550.0,)
    wavelengths_span: Span | None = None
    seed: int = 0
    media: dict = field(default_factory=lambda: {"AIR": M.AIR, "VACUUM": M.VACUUM})
    coatings: dict = field(default_factory=dict)
    spectra: dict = field(default_factory=dict)
    models: dict = field(default_factory=dict)
    maps: dict = field(default_factory=dict)
    objects: dict = field(default_factory=dict)
    groups: dict = field(default_factory=dict)
    sources: list = field(default_factory=list)
    pending_grid: tuple | None = None          # (module, params, span, group)
    block: _SurfaceBlock | None = None
    current: str | None = None                 # key of the current object
    group_stack: list = field(default_factory=list)
    level: int = 1000
    halt: float = 1e-6
    importance_cut: float = 0.0
    traces: int = 0                            # TRACE commands so far (a group may move between them)
    placed_trace: dict = field(default_factory=dict)   # group key -> the value of traces when it was placed
    first_per_line: Span | None = None         # first wavelength-dependent definition
    failed: set = field(default_factory=set)   # (namespace, key) of definitions that failed

    def scene(self) -> M.Scene:
        fp = M.frozen_params
        return M.Scene(self.units, self.wavelengths_nm, self.seed, fp(self.media), fp(self.coatings),
                       fp(self.spectra), fp(self.models), fp(self.maps), fp(self.objects), fp(self.groups),
                       tuple(self.sources), self.importance_cut)


NAMESPACES = ("medium", "coating", "spectrum", "model", "map", "object", "group")
# commands whose first argument is the name they define
DEFINES = {"MEDIUM": "medium", "COATING": "coating", "SPECTRUM": "spectrum", "MODEL": "model", "MAP": "map",
           "OBJECT": "object", "GROUP": "group"}


class Interpreter(BindContext):
    def __init__(self, engine: Any = None, out: Callable[[str], None] | None = None, *, check_only: bool = False):
        self.engine = engine
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
        self._cmd_span: Span | None = None
        from . import commands

        self.commands = commands.TABLE

    # ------------------------------------------------------------ entry points
    def run_file(self, path: str | Path) -> None:
        p = Path(path)
        src = read_source(p)
        self.base_dir = p.resolve().parent
        self.include_stack = [p.resolve()]
        self.run_source(src)

    def run_source(self, src: Source) -> None:
        self.sources.append(src)
        prog = parse_source(src, self.is_macro_head)
        try:
            self.exec_block(prog.stmts)
            self.finish()
        except StopScript:
            pass

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
        for fr in reversed(self.frames):
            if k in fr:
                fr[k] = (name, value)
                return
        self.globals[k] = (name, value)

    # ------------------------------------------------------------ statements
    def exec_block(self, stmts) -> None:
        for st in stmts:
            self.exec_stmt(st)

    def exec_stmt(self, st) -> None:
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

    def input_path(self, rel: str, span: Span) -> Path:
        """An input file: relative paths are relative to the including script's folder."""
        base = self.include_stack[-1].parent if self.include_stack else self.base_dir
        p = (base / rel) if not Path(rel).is_absolute() else Path(rel)
        if not p.exists():
            raise error(span, f"file not found: '{rel}' (looked in {p.parent})")
        if p.is_dir():
            raise error(span, f"'{rel}' is a folder, not a file")
        return p

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
        s = M.Step(kind, M.frozen_params(params), self.state.scene() if with_scene else None, span)
        self.steps.append(s)
        if self.engine is not None:
            self.engine.run_step(s, self)

    def current_group(self) -> str | None:
        return self.state.group_stack[-1] if self.state.group_stack else None

    def print(self, text: str) -> None:
        if not self.check_only:
            self.out(text)

    # ------------------------------------------------------------ INCLUDE and CALL
    def include(self, rel: str, span: Span) -> None:
        p = self.input_path(rel, span).resolve()
        if p in self.include_stack:
            chain = " -> ".join(x.name for x in self.include_stack + [p])
            raise error(span, f"recursive INCLUDE: {chain}")
        if len(self.include_stack) > MAX_CALL_DEPTH:
            raise error(span, "INCLUDE nested too deeply")
        try:
            src = read_source(p, display_name=_display(p))
        except IrtError as e:  # a file-level problem (not text, unreadable) is reported at the INCLUDE
            raise IrtError([replace(d, span=span) if d.span.line <= 0 else d for d in e.diagnostics]) from None
        self.sources.append(src)
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


def _display(p: Path) -> str:
    try:
        return str(p.relative_to(Path.cwd()))
    except ValueError:
        return str(p)


def check_file(path: str | Path, presets=()) -> Interpreter:
    """Parse and validate a script; raise IrtError with every diagnostic if it has any."""
    it = Interpreter(check_only=True)
    it.preset(presets)
    it.run_file(path)
    if it.diags:
        raise IrtError(it.diags.items)
    return it
