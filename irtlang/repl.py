"""``irt repl``: an interactive session on the same interpreter as ``irt run``.

Each input is parsed and run as it is entered; definitions, variables and macros stay for the next one.
A line that opens a block (``DO``, ``IF (...) THEN``, ``MACRO``) or ends with ``&`` is continued with the
``...>`` prompt until the block is closed; whether a block is still open is asked of the real parser (its
"DO without END DO" diagnostics), not guessed from the text.  Errors are shown as diagnostics and the
session goes on.

REPL-only commands (only at the ``irt>`` prompt, any case): ``SHOW [what]``, ``HELP [command]``, ``EXIT``,
``QUIT``.  Ctrl-C clears the current input, Ctrl-D (or EXIT) leaves.

``ReplSession`` holds the logic and needs no terminal (``feed(line) -> output``); ``main()`` drives it with
prompt_toolkit (history in ``~/.irt_history`` or ``$IRT_HISTORY``, Tab completion), or, when standard input
is not a terminal, reads plain lines from it (``printf 'x = 3\\nPRINT x\\n' | irt repl`` prints 3).
"""
from __future__ import annotations

import os
import re
import sys
from pathlib import Path

from ._version import __version__
from .lang import ast as A
from .core.diagnostics import Diagnostic, DiagnosticBag, IrtError, NO_SPAN, Source, did_you_mean
from .lang.parser import parse_source
from .lang.spec import Form, Variants, match_keyword
from .core.units import LENGTH, Quantity, fmt_number

PROMPT = "irt> "
CONT_PROMPT = "...> "
REPL_COMMANDS = {
    "SHOW": ("SHOW [SYSTEM|VARIABLES|MEDIA|COATINGS|SPECTRA|MODELS|MAPS|OBJECTS|GROUPS|MACROS|SOURCES]",
             "list what is defined (REPL only)"),
    "HELP": ("HELP [command]", "list the commands, or one command's usage (REPL only)"),
    "EXIT": ("EXIT", "leave the session (also QUIT or Ctrl-D)"),
    "QUIT": ("QUIT", "leave the session (also EXIT or Ctrl-D)"),
}
CONTROL_HELP = {
    "DO": (["DO var = first, last [, step]", "  ...", "END DO"], "repeat a block for var = first .. last (inclusive)"),
    "IF": (["IF (condition) THEN", "  ...", "ELSE IF (condition) THEN", "  ...", "ELSE", "  ...", "END IF",
            "IF (condition) command"], "run a block (or one command) when a condition holds"),
    "END": (["END DO", "END IF", "END MACRO", "END GROUP"], "close a block"),
    "ELSE": (["ELSE", "ELSE IF (condition) THEN"], "the other branch of an IF block"),
}
SHOW_WHAT = ("SYSTEM", "VARIABLES", "MEDIA", "COATINGS", "SPECTRA", "MODELS", "MAPS", "OBJECTS", "GROUPS",
             "MACROS", "SOURCES")
SHOW_ALIASES = {"MEDIUM": "MEDIA", "SPECTRUM": "SPECTRA", "VARIABLE": "VARIABLES", "VARS": "VARIABLES"}
_OPEN_BLOCK = re.compile(r"^(DO|IF|MACRO) without END \1$")
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
INPUT_NAME = "<input>"


# ---------------------------------------------------------------- the engine, made on first use
class _LazyEngine:
    """An ``Engine`` with a ``RunFolder`` in ``out_dir``, created when the first step reaches it."""

    def __init__(self, out_dir: str | Path):
        self.out_dir = Path(out_dir)
        self.engine = None
        self.folder = None

    def run_step(self, step, interp) -> None:
        if self.engine is None:
            from .engine import Engine
            from .io.manifest import RunFolder

            self.folder = RunFolder(self.out_dir, "<repl>", interp.script_hash, interp.state.seed)
            try:  # records and ray histories kept: the session does not know what comes next
                self.engine = Engine(self.folder, out=interp.out)
            except TypeError:  # an Engine without an output hook
                self.engine = Engine(self.folder)
            import tempfile

            from .io.results import ResultsCollector

            self.spill = Path(tempfile.mkdtemp(prefix=".irt-results-", dir=self.folder.root))
            self.engine.collector = ResultsCollector(self.spill)   # results.nc when the session ends
        self.engine.run_step(step, interp)

    def close(self, interp) -> None:
        if self.folder is not None:
            import shutil

            from .api import _write_results

            self.folder.info["script_sha256"] = interp.script_hash
            try:
                _write_results(self.folder, self.engine.collector)
            finally:
                shutil.rmtree(self.spill, ignore_errors=True)
            self.folder.write_manifest("repl session ended")


def _strip_comment(line: str) -> str:
    """A line without its '!!' comment (a '!!' inside quotes is text)."""
    quote = None
    for i, c in enumerate(line):
        if quote:
            if c == quote:
                quote = None
        elif c in "'\"":
            quote = c
        elif line.startswith("!!", i):
            return line[:i]
    return line


def _ends_with_continuation(line: str) -> bool:
    """Whether a line's code ends with '&' (quotes and a trailing '!!' comment understood)."""
    return _strip_comment(line).rstrip().endswith("&")


def _statement_text(line: str) -> str:
    """The part of a line after its last ';' outside quotes (the statement being typed)."""
    quote = None
    start = 0
    for i, c in enumerate(line):
        if quote:
            if c == quote:
                quote = None
        elif c in "'\"":
            quote = c
        elif c == ";":
            start = i + 1
    return line[start:]


def _words_outside_quotes(text: str) -> list[str]:
    return re.findall(r"[A-Za-z_][A-Za-z0-9_]*", re.sub(r"'[^']*'|\"[^\"]*\"", " ", text))


def _in_quote(text: str) -> bool:
    quote = None
    for c in text:
        if quote:
            if c == quote:
                quote = None
        elif c in "'\"":
            quote = c
    return quote is not None


def form_keywords(form: Form | None, typed: list[str]) -> list[str]:
    """The keywords a command's Form allows, following the variant already typed if there is one."""
    out: list[str] = []
    if form is None:
        return out

    def param(p):
        if p.kind in ("choice", "axis"):
            out.extend(w for w in p.words if len(w) > 1)
        elif p.kind == "perline":
            out.append("SPECTRUM")

    def visit(f: Form):
        for c in f.clauses:
            out.append(c.kw)
            for p in c.params:
                param(p)
        for p in f.params:
            if isinstance(p, Variants):
                chosen = None
                for w in typed:
                    try:
                        chosen = match_keyword(w, p.options, NO_SPAN)
                    except IrtError:
                        chosen = None
                    if chosen:
                        break
                if chosen:
                    visit(p.options[chosen])
                else:
                    out.extend(p.options)
                    if p.default is not None:
                        visit(p.default)
            else:
                param(p)

    visit(form)
    return list(dict.fromkeys(out))


# ---------------------------------------------------------------- the session
class ReplSession:
    """One interactive session: feed it lines, get back what to print.

    ``feed(line)`` returns the text to show ('' when there is nothing, for instance while a block is still
    open: then ``continuing`` is true and ``prompt`` is the continuation prompt).  ``done`` turns true after
    EXIT or QUIT.  ``complete(text)`` lists the completions of the last word of `text`.
    """

    def __init__(self, out_dir: str | Path = "irt-out/repl", engine: bool = True):
        from .lang.interp import Interpreter

        self._out: list[str] = []
        self._engine = _LazyEngine(out_dir) if engine else None
        self.interp = Interpreter(engine=self._engine, out=self._out.append)
        self.buffer: list[str] = []
        self.done = False

    # ------------------------------------------------------------ state
    @property
    def continuing(self) -> bool:
        return bool(self.buffer)

    @property
    def prompt(self) -> str:
        return CONT_PROMPT if self.buffer else PROMPT

    def cancel(self) -> str:
        """Ctrl-C: forget the input being typed."""
        had = bool(self.buffer)
        self.buffer = []
        return "(input cleared)" if had else ""

    def close(self) -> None:
        if self._engine is not None:
            try:
                self._engine.close(self.interp)
            except OSError:
                pass

    # ------------------------------------------------------------ input
    def feed(self, line: str) -> str:
        line = line.rstrip("\r\n")
        if not self.buffer:
            if not line.strip():
                return ""
            reply = self._repl_command(line.strip())
            if reply is not None:
                return reply
        self.buffer.append(line)
        if _ends_with_continuation(line):
            return ""
        text = "\n".join(self.buffer) + "\n"
        src = Source(INPUT_NAME, text)
        try:
            prog = parse_source(src, self.interp.is_macro_head)
        except IrtError as e:
            d = e.diagnostics[0]
            if _OPEN_BLOCK.match(d.message):
                return ""
            shown = e.render()
            if len(self.buffer) > 1 and d.span.line >= len(self.buffer):
                # the line just typed is wrong: drop it and stay in the open block
                self.buffer.pop()
                return shown + "\n(that line was not added; the block is still open: finish it, or Ctrl-C)"
            self.buffer = []
            return shown
        self.buffer = []
        return self._run(src, prog)

    def _run(self, src: Source, prog: A.Program) -> str:
        from .engine import MissingCapability, RuntimeFailure
        from .lang.interp import StepFailed, StopScript

        it = self.interp
        out: list[str] = []
        echo = self._echo(prog)
        if echo is not None:
            return echo
        it.sources.append(src)
        del self._out[:]
        try:
            it.exec_block(prog.stmts)
        except StopScript:
            pass
        except MissingCapability as e:
            it.diags.add(Diagnostic(e.span, f"{e.what} needs {e.capability}, which this version of irtlang "
                                            f"(v{__version__}) does not have yet"))
        except RuntimeFailure as e:
            it.diags.add(Diagnostic(e.span, e.message))
        except StepFailed as e:
            it.diags.extend(e.error.diagnostics)
        except KeyboardInterrupt:
            self._out.append("interrupted")
        except RecursionError:
            it.diags.add(Diagnostic(NO_SPAN, "too deeply nested (recursion limit)"))
        out.extend(self._out)
        del self._out[:]
        out.extend(d.render() for d in it.diags.items)
        it.diags = DiagnosticBag()
        return "\n".join(out)

    def _echo(self, prog: A.Program) -> str | None:
        """A bare variable name on its own shows its value."""
        if len(prog.stmts) != 1 or not isinstance(prog.stmts[0], A.Command):
            return None
        st = prog.stmts[0]
        if st.args or self._head(st.head) is not None:
            return None
        k = st.head.upper()
        if k not in self.interp.globals:
            return None
        name, v = self.interp.globals[k]
        return f"{name} = {self._value(v)}"

    @staticmethod
    def _head(word: str) -> str | None:
        from .lang.fmt import canonical_head

        return canonical_head(word)

    def _value(self, v) -> str:
        if isinstance(v, str):
            return "'" + v + "'"
        return v.describe(self.interp.state.units)

    # ------------------------------------------------------------ REPL-only commands
    def _repl_command(self, line: str) -> str | None:
        words = _strip_comment(line).split()
        if not words or (len(words) > 1 and words[1].startswith("=")):   # `show = 3` is an assignment
            return None
        w0 = words[0].upper()
        if w0 in ("EXIT", "QUIT") and len(words) == 1:
            self.done = True
            return ""
        if w0 == "SHOW":
            if len(words) > 2:
                return "error: SHOW takes one word: " + REPL_COMMANDS["SHOW"][0]
            return self.show(words[1] if len(words) == 2 else None)
        if w0 == "HELP":
            if len(words) > 2:
                return "error: usage: HELP [command]"
            return self.help(words[1] if len(words) == 2 else None)
        return None

    def show(self, what: str | None = None) -> str:
        if what is not None:
            w = SHOW_ALIASES.get(what.upper(), what.upper())
            try:
                key = match_keyword(w, SHOW_WHAT, NO_SPAN)
            except IrtError as e:
                return "error: " + e.diagnostics[0].message
            if key is None:
                hint = did_you_mean(what, SHOW_WHAT)
                return f"error: SHOW {what}: expected one of " + " ".join(SHOW_WHAT) + (f" ({hint})" if hint else "")
            cats = [key]
        else:
            cats = list(SHOW_WHAT)
        parts = []
        for c in cats:
            lines = getattr(self, "_show_" + c.lower())()
            if lines:
                parts.append(c.lower() + ":\n" + "\n".join("  " + x for x in lines))
            elif what is not None:
                parts.append(c.lower() + ": (none)")
        return "\n".join(parts)

    # each _show_* returns lines
    def _len(self, metres: float) -> str:
        return Quantity(metres, LENGTH).describe(self.interp.state.units)

    @staticmethod
    def _nums(values, limit: int = 6) -> str:
        vals = [fmt_number(float(v)) for v in values]
        if len(vals) > 1 and len(set(vals)) == 1:
            return vals[0]
        if len(vals) > limit:
            return " ".join(vals[:limit]) + f" ... ({len(vals)} values)"
        return " ".join(vals)

    def _show_system(self) -> list[str]:
        st = self.interp.state
        lines = [f"UNITS {st.units}", "WAVELENGTHS " + self._nums(st.wavelengths_nm, 8) + " nm"
                 + (f" ({len(st.wavelengths_nm)} lines)" if len(st.wavelengths_nm) > 1 else ""),
                 f"SEED {st.seed}", f"LEVEL {st.level}", f"HALT {fmt_number(st.halt)}"]
        if st.block is not None:
            lines.append(f"open SURFACE block ({len(st.block.surfaces)} surface"
                         f"{'s' if len(st.block.surfaces) != 1 else ''}): close it with OBJECT name")
        if st.current is not None and st.current in st.objects:
            lines.append(f"current object {st.objects[st.current].name}")
        if st.group_stack:
            lines.append("open GROUP " + " > ".join(st.groups[g].name for g in st.group_stack))
        return lines

    def _show_variables(self) -> list[str]:
        return [f"{name} = {self._value(v)}" for name, v in self.interp.globals.values()]

    def _show_media(self) -> list[str]:
        st = self.interp.state
        out = []
        for m in st.media.values():
            s = f"{m.name}  {m.kind.upper()}  n {self._nums(m.index)}"
            if any(a != 0 for a in m.absorb):
                unit_m = _unit_metres(st.units)
                s += f"  ABSORB {self._nums([a * unit_m for a in m.absorb])} /{st.units.lower()}"
            out.append(s)
        return out

    def _show_coatings(self) -> list[str]:
        out = []
        for c in self.interp.state.coatings.values():
            if c.kind == "fresnel":
                out.append(f"{c.name}  FRESNEL")
            elif c.kind == "metal":
                out.append(f"{c.name}  METAL {self._nums(c.reflect)}  EXTINCTION {self._nums(c.transmit)}")
            else:
                out.append(f"{c.name}  REFLECT {self._nums(c.reflect)}  TRANSMIT {self._nums(c.transmit)}")
        return out

    def _show_spectra(self) -> list[str]:
        out = []
        for s in self.interp.state.spectra.values():
            w = s.wavelengths_nm
            rng = f"{fmt_number(min(w))}-{fmt_number(max(w))} nm, {len(w)} samples" if len(w) else "no samples"
            out.append(f"{s.name}  {s.kind.upper()}  ({rng})  on lines: {self._nums(s.on_lines)}"
                       + (f" {s.unit}" if s.unit else ""))
        return out

    def _show_models(self) -> list[str]:
        out = []
        for m in self.interp.state.models.values():
            ps = []
            for k, v in m.params.items():
                if isinstance(v, (tuple, list)):
                    try:
                        ps.append(f"{k} {self._nums(v)}")
                    except (TypeError, ValueError):
                        ps.append(f"{k} {v}")
                elif isinstance(v, (int, float)):
                    ps.append(f"{k} {fmt_number(float(v))}")
                else:
                    ps.append(f"{k} {v}")
            out.append(f"{m.name}  {m.kind}" + ("  " + ", ".join(ps) if ps else ""))
        return out

    def _show_maps(self) -> list[str]:
        return [f"{m.name}  {m.kind}  " + (f"DEFAULT {m.dataset}" if m.path is None else f"'{m.path}'")
                for m in self.interp.state.maps.values()]

    def _show_objects(self) -> list[str]:
        st = self.interp.state
        out = []
        for o in st.objects.values():
            s = f"{o.name}  " + " + ".join(x.kind for x in o.surfaces)
            if o.group is not None and o.group in st.groups:
                s += f"  in GROUP {st.groups[o.group].name}"
            T = o.transform.T
            if any(T):
                s += "  shifted " + " ".join(self._len(x) for x in T)
            if o.transform.R != (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0):
                s += "  rotated"
            if o.interface is not None:
                itf = o.interface
                s += f"  INTERFACE {itf.kind.upper()}"
                if itf.coating:
                    s += f" {_display(st.coatings, itf.coating)}"
                if itf.kind in ("coating", "transmit"):
                    s += f" {_display(st.media, itf.back)} {_display(st.media, itf.front)}"
            for sc in o.scatter:
                if sc.model:
                    s += f"  SCATTER MODEL {_display(st.models, sc.model)}"
                else:
                    s += f"  SCATTER MAP {_display(st.maps, sc.map)}"
            if o.detector is not None:
                s += f"  DETECTOR {o.detector.nx} x {o.detector.ny}"
            out.append(s)
        return out

    def _show_groups(self) -> list[str]:
        st = self.interp.state
        out = []
        for g in st.groups.values():
            s = g.name
            if g.parent is not None and g.parent in st.groups:
                s += f"  in {st.groups[g.parent].name}"
            if g.placed is not None:
                s += "  placed AT " + " ".join(self._len(x) for x in g.placement.T)
            else:
                s += "  (not placed)"
            out.append(s)
        return out

    def _show_macros(self) -> list[str]:
        return [" ".join([m.name, *m.params]) for m in self.interp.macros.values()]

    def _show_sources(self) -> list[str]:
        st = self.interp.state
        out = []
        for s in st.sources:
            fl = s.flux
            flux = f"FLUX TOTAL {fmt_number(fl.value)} W" if fl.kind == "total" else f"FLUX SPECTRUM {fl.spectrum}"
            out.append(f"{s.kind.replace('+', ' + ')}  {flux}" + (f"  in GROUP {s.group}" if s.group else ""))
        if st.pending_grid is not None:
            out.append(f"{st.pending_grid[0]}  (waiting for its SOURCE direction)")
        return out

    def help(self, what: str | None = None) -> str:
        from .lang import commands

        table = commands.TABLE
        if what is None:
            sections: dict[str, list[str]] = {}
            for k, c in table.items():
                sections.setdefault(c.section, []).append(f"  {k:<12} {c.summary}")
            out = ["Commands (HELP command shows its usage; keywords may be shortened to 3 letters):"]
            for sec, lines in sections.items():
                out.append(f"{sec}:")
                out.extend(lines)
            out.append("control flow:")
            out.append("  name = expr   a variable")
            for k, (_, summary) in CONTROL_HELP.items():
                out.append(f"  {k:<12} {summary}")
            out.append("session (REPL only):")
            for k, (_, summary) in REPL_COMMANDS.items():
                out.append(f"  {k:<12} {summary}")
            return "\n".join(out)
        w = what.upper()
        if w in REPL_COMMANDS:
            u, s = REPL_COMMANDS[w]
            return f"{w}: {s}\nusage:\n  {u}"
        if w in CONTROL_HELP:
            u, s = CONTROL_HELP[w]
            return f"{w}: {s}\nusage:\n" + "\n".join("  " + x for x in u)
        if w == "END" or w.startswith("END "):
            u, s = CONTROL_HELP["END"]
            return f"END: {s}\nusage:\n" + "\n".join("  " + x for x in u)
        try:
            key = match_keyword(w, [k for k in table if " " not in k], NO_SPAN)
        except IrtError as e:
            return "error: " + e.diagnostics[0].message
        if key is None:
            hint = did_you_mean(what, list(table) + list(REPL_COMMANDS) + list(CONTROL_HELP))
            return f"error: no command '{what}'" + (f"; {hint}" if hint else "") + " (HELP lists them)"
        c = table[key]
        return f"{key}: {c.summary}\nusage:\n" + "\n".join("  " + x for x in commands.usages(key))

    # ------------------------------------------------------------ completion
    def defined_names(self) -> list[str]:
        it = self.interp
        st = it.state
        names = [v[0] for v in it.globals.values()]
        for table in (st.media, st.coatings, st.spectra, st.models, st.maps, st.objects, st.groups):
            names.extend(x.name for x in table.values())
        names.extend(m.name for m in it.macros.values())
        return list(dict.fromkeys(names))

    def keywords_after(self, words: list[str]) -> list[str]:
        """Keywords that may follow the words already typed in a statement."""
        from .lang import commands

        w0 = words[0].upper()
        if w0 == "SHOW":
            return list(SHOW_WHAT)
        if w0 == "HELP":
            return [k for k in commands.TABLE if " " not in k] + list(REPL_COMMANDS) + list(CONTROL_HELP)
        if w0 == "END":
            return ["DO", "IF", "MACRO", "GROUP"]
        if w0 == "ELSE":
            return ["IF"]
        if w0 == "IF":
            return ["THEN", "AND", "OR", "NOT"]
        head = self._head(words[0])
        if head is None:
            return []
        if head == "SELECT":
            return ["ALL", "HIT", "LAST", "SCATTERED", "PATH", "WAVELENGTH", "AND", "OR", "NOT"]
        return form_keywords(commands.TABLE[head].form, words[1:])

    def _names_after(self, first: str) -> list[str]:
        """The defined names worth offering in a statement that starts with `first`."""
        from .lang import commands

        head = self._head(first)
        if head is None:  # control flow (DO, IF, ...), an assignment, or a REPL command
            return [] if first.upper() in ("SHOW", "HELP", "END", "ELSE") else [v[0] for v in self.interp.globals.values()]
        kinds = _form_param_kinds(commands.TABLE[head].form)
        if kinds & {"ref", "refs", "rest"}:
            return self.defined_names()
        if kinds & {"val", "vals", "perline"}:
            return [v[0] for v in self.interp.globals.values()]
        return []

    def complete(self, text: str) -> list[str]:
        """Completions for the word at the end of `text` (the line up to the cursor)."""
        from .lang import commands

        stmt = _statement_text(text)
        if _in_quote(stmt):
            return []
        m = re.search(r"[A-Za-z_][A-Za-z0-9_]*$", stmt)
        word = m.group(0) if m else ""
        before = stmt[: len(stmt) - len(word)]
        if word and before and before[-1] in "0123456789.":
            return []  # a unit after a number, not a name
        words = _words_outside_quotes(before)
        if not words:
            kws = [k for k in commands.TABLE if " " not in k] + ["DO", "IF", "ELSE", "END"]
            if not self.buffer:
                kws += list(REPL_COMMANDS)
            names = [v[0] for v in self.interp.globals.values()]
        else:
            kws = self.keywords_after(words)
            names = self._names_after(words[0])
        u = word.upper()
        out = [k for k in kws if k.upper().startswith(u)]
        for n in names:
            if n.upper().startswith(u):
                out.append(n if _IDENT.match(n) else "'" + n + "'")
        return list(dict.fromkeys(out))


def _display(table: dict, key: str) -> str:
    """A definition's name as written, from its key."""
    v = table.get(key)
    return v.name if v is not None else key


def _form_param_kinds(form: Form | None) -> set[str]:
    kinds: set[str] = set()

    def visit(f):
        for c in f.clauses:
            kinds.update(p.kind for p in c.params)
        for p in f.params:
            if isinstance(p, Variants):
                for sub in p.options.values():
                    visit(sub)
                if p.default is not None:
                    visit(p.default)
            else:
                kinds.add(p.kind)

    if form is not None:
        visit(form)
    return kinds


def _unit_metres(units: str) -> float:
    from .core.units import UNITS

    return UNITS[units.lower()][0]


# ---------------------------------------------------------------- terminals
def history_path() -> Path:
    return Path(os.environ.get("IRT_HISTORY") or os.path.join(os.path.expanduser("~"), ".irt_history"))


def _history():
    from prompt_toolkit.history import FileHistory, InMemoryHistory

    p = history_path()
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        with open(p, "a", encoding="utf-8"):
            pass
        return FileHistory(str(p))
    except OSError:
        return InMemoryHistory()


def _completer(session: ReplSession):
    from prompt_toolkit.completion import Completer, Completion

    class IrtCompleter(Completer):
        def get_completions(self, document, complete_event):
            text = document.text_before_cursor
            m = re.search(r"[A-Za-z_][A-Za-z0-9_]*$", text)
            n = len(m.group(0)) if m else 0
            for c in session.complete(text):
                yield Completion(c, start_position=-n)

    return IrtCompleter()


def _interactive(session: ReplSession) -> None:
    from prompt_toolkit import PromptSession

    ps = PromptSession(history=_history(), completer=_completer(session), complete_while_typing=False)
    print(f"irt {__version__} interactive session. HELP lists the commands, SHOW what is defined; "
          f"EXIT or Ctrl-D leaves.", flush=True)
    while not session.done:
        try:
            line = ps.prompt(session.prompt)
        except KeyboardInterrupt:
            msg = session.cancel()
            if msg:
                print(msg, flush=True)
            continue
        except EOFError:
            break
        try:
            out = session.feed(line)
        except KeyboardInterrupt:
            session.cancel()
            out = "interrupted"
        if out:
            print(out, flush=True)


def _plain(session: ReplSession) -> None:
    while not session.done:
        try:
            line = input()
        except EOFError:
            break
        except KeyboardInterrupt:
            session.cancel()
            continue
        out = session.feed(line)
        if out:
            print(out, flush=True)
    if session.continuing:
        print(f"{INPUT_NAME}: error: the input ended inside an unfinished block; it was not run", flush=True)


def main() -> int:
    session = ReplSession()
    try:
        if sys.stdin.isatty():
            _interactive(session)
        else:
            _plain(session)
    finally:
        session.close()
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
