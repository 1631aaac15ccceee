"""``irt fmt``: print a script in canonical formatting.

Canonical form:

* command heads and keywords in upper case and unabbreviated (``spo pos`` -> ``SPOTS POSITION``); names,
  variables, numbers, units and strings are kept exactly as written;
* one statement per line (``a ; b`` becomes two lines); a statement continued with ``&`` keeps its line
  breaks, its continuation lines indented four spaces past the statement;
* two spaces of indentation per level inside DO, IF, MACRO and GROUP blocks, and for the surfaces of a
  ``SURFACE ... OBJECT`` block and the modifiers (INTERFACE, SCATTER, SHIFT, ROTATE, DETECTOR) that follow
  its OBJECT;
* one space between a command's arguments, around ``=`` in assignments and DO headers, after the commas
  of a DO header and around the reserved words (DO IF THEN ELSE END AND OR NOT); other spacing inside an
  argument or expression is kept, runs of blanks shrunk to one;
* comments kept: a comment on its own line is indented with the code, a trailing comment keeps its column
  when the code still fits before it; runs of blank lines shrink to one.

The structure comes from the real parser (the grammar drops comments, so the text is rebuilt line by line
from the parser's own token stream, with each physical line's comment put back).  Which words are keywords
is decided exactly as the binder decides it (``irtlang.lang.spec``), walking each command's ``Form``
statically; where that cannot be decided without running the script the words are left as written, so
formatting never changes what a script means.  The result is idempotent: ``fmt(fmt(x)) == fmt(x)``.
A script with syntax or block errors is not formatted: the parser's diagnostic is raised (``IrtError``).
"""
from __future__ import annotations

import re
from pathlib import Path

from . import ast as A
from ..core.diagnostics import IrtError, Source, Span
from .parser import _ToAst, _transform, lark_parser, parse_source, read_source
from .spec import Form, Variants, match_keyword

INDENT = "  "
CONT_INDENT = "    "
RESERVED = ("DO", "IF", "THEN", "ELSE", "END", "AND", "OR", "NOT")
MODIFIERS = ("INTERFACE", "SCATTER", "OPAQUE", "SHIFT", "ROTATE", "DETECTOR")
_NOSPAN = Span(None, 0, 0, 0, 0)


# ---------------------------------------------------------------- entry points
def format_file(path: str | Path) -> str:
    src = read_source(path)
    return format_source(src.text, src.name)


def format_source(text: str, name: str = "<input>") -> str:
    """The canonical text of a script (raises IrtError if it does not parse)."""
    return _Formatter(text, name).run()


# ---------------------------------------------------------------- command table helpers
def _table():
    from . import commands

    return commands.TABLE


def command_heads() -> list[str]:
    """The command keywords a statement can start with (``END GROUP`` is two words, handled by the parser)."""
    return [k for k in _table() if " " not in k]


def canonical_head(word: str) -> str | None:
    """The command `word` stands for (exact or a unique prefix of >= 3 letters), or None."""
    try:
        return match_keyword(word, command_heads(), _NOSPAN)
    except IrtError:
        return None


def _is_macro_head(head: str) -> bool:
    return canonical_head(head) == "MACRO"


# ---------------------------------------------------------------- static keyword resolution
class _Stop(Exception):
    """The binder's path cannot be followed statically: leave the remaining words as written."""


def _match(word: str, allowed) -> str | None:
    try:
        return match_keyword(word, allowed, _NOSPAN)
    except IrtError:  # ambiguous: an error in the script; keep it as written
        raise _Stop from None


def _value_item(it) -> bool:
    return isinstance(it, (A.Num, A.Word, A.Paren, A.Call, A.UnOp, A.BinOp))


class _Cur:
    def __init__(self, items):
        self.items, self.i = list(items), 0

    def peek(self):
        return self.items[self.i] if self.i < len(self.items) else None

    def next(self):
        self.i += 1

    def done(self) -> bool:
        return self.i >= len(self.items)


class KeywordWalker:
    """Finds the argument words that the binder reads as keywords, without evaluating anything.

    It mirrors ``spec.bind`` step by step; ``is_var(name)`` says whether a name may be a variable (only
    needed where the binder asks the interpreter).  ``marks`` maps an item's (line, col) to its keyword.
    """

    def __init__(self, is_var):
        self.is_var = is_var
        self.marks: dict[tuple[int, int], str] = {}

    def _mark(self, it, kw: str) -> None:
        self.marks[(it.span.line, it.span.col)] = kw

    def command(self, form: Form | None, args) -> dict:
        if form is None:
            return self.marks
        cur = _Cur(args)
        clauses: list = []
        try:
            self._form(form, cur, clauses)
            self._clauses(clauses, cur)
        except _Stop:
            pass
        return self.marks

    def _form(self, form: Form, cur: _Cur, clauses: list) -> None:
        clauses.extend(form.clauses)
        for p in form.params:
            if isinstance(p, Variants):
                it = cur.peek()
                kw = _match(it.name, p.options) if isinstance(it, A.Word) else None
                if kw is not None:
                    self._mark(it, kw)
                    cur.next()
                    self._form(p.options[kw], cur, clauses)
                elif p.default is not None:
                    self._form(p.default, cur, clauses)
                else:
                    raise _Stop
                continue
            self._param(p, cur, [c.kw for c in clauses])

    def _clauses(self, clauses: list, cur: _Cur) -> None:
        kws = [c.kw for c in clauses]
        while not cur.done():
            it = cur.peek()
            kw = _match(it.name, kws) if isinstance(it, A.Word) else None
            if kw is None:
                raise _Stop
            self._mark(it, kw)
            cur.next()
            cl = next(c for c in clauses if c.kw == kw)
            for p in cl.params:
                self._param(p, cur, kws)

    def _param(self, p, cur: _Cur, stop: list) -> None:
        it = cur.peek()
        k = p.kind
        if it is None or (isinstance(it, A.Word) and k in ("val", "vals", "perline") and _match(it.name, stop)):
            if p.optional:
                return
            raise _Stop
        if k in ("name", "ref"):
            if isinstance(it, A.Word) and _match(it.name, stop) and p.optional:
                return
            if not isinstance(it, (A.Word, A.Str)):
                if p.optional:
                    return
                raise _Stop
            cur.next()
            return
        if k == "refs":
            while not cur.done() and isinstance(cur.peek(), (A.Word, A.Str)):
                w = cur.peek()
                if isinstance(w, A.Word) and _match(w.name, stop):
                    break
                cur.next()
            return
        if k == "path":
            if not isinstance(it, A.Str):
                if p.optional:
                    return
                raise _Stop
            cur.next()
            return
        if k in ("axis", "choice"):
            kw = _match(it.name, p.words) if isinstance(it, A.Word) else None
            if kw is None:
                if p.optional:
                    return
                raise _Stop
            self._mark(it, kw)
            cur.next()
            return
        if k == "rest":
            while not cur.done():
                cur.next()
            return
        if k == "val":
            if not _value_item(it):
                if p.optional:
                    return
                raise _Stop
            cur.next()
            return
        if k == "perline" and isinstance(it, A.Word) and _match(it.name, ["SPECTRUM"]):
            if self.is_var(it.name):
                raise _Stop  # a keyword or a variable: only the run knows
            self._mark(it, "SPECTRUM")
            cur.next()
            nm = cur.peek()
            if not isinstance(nm, (A.Word, A.Str)):
                raise _Stop
            cur.next()
            return
        # vals / perline: a greedy list, as spec._take_list
        count = 0
        while not cur.done():
            it = cur.peek()
            if p.n is not None and count >= p.n:
                break
            if isinstance(it, A.Word) and _match(it.name, stop):
                break
            if isinstance(it, A.Repeat):
                c = it.count
                if not (isinstance(c, A.Num) and c.unit is None and c.value == int(c.value) and c.value >= 1):
                    raise _Stop
                count += int(c.value)
                cur.next()
                continue
            if not _value_item(it):
                break
            if isinstance(it, A.Word) and not self.is_var(it.name):
                raise _Stop  # the binder reports an unknown word here
            count += 1
            cur.next()
        if p.n is not None and count != p.n:
            raise _Stop


def _select_marks(args, marks: dict) -> None:
    """SELECT ALL, and the predicate names HIT LAST SCATTERED PATH WAVELENGTH (exact, any case)."""
    from .commands import SELECT_FUNCS

    if len(args) == 1 and isinstance(args[0], A.Word):
        kw = _match_or_none(args[0].name, ["ALL"])
        if kw:
            marks[(args[0].span.line, args[0].span.col)] = kw
        return

    def walk(e):
        if isinstance(e, A.Paren):
            walk(e.expr)
        elif isinstance(e, A.BinOp):
            walk(e.left)
            walk(e.right)
        elif isinstance(e, A.UnOp):
            walk(e.operand)
        elif isinstance(e, A.Call):
            if e.name.upper() in SELECT_FUNCS:
                marks[(e.name_span.line, e.name_span.col)] = e.name.upper()

    for a in args:
        walk(a)


def _match_or_none(word, allowed):
    try:
        return match_keyword(word, allowed, _NOSPAN)
    except IrtError:
        return None


# ---------------------------------------------------------------- the formatter
_QTY_WS = re.compile(r"[ \t\f]+")


class _Stmt:
    """One statement: its tokens, its AST node and how it is laid out."""

    def __init__(self, tokens, node):
        self.tokens = tokens
        self.node = node
        self.first_line = tokens[0].line
        self.last_line = tokens[-1].end_line
        self.marks: dict[tuple[int, int], str] = {}
        self.space_before: set[tuple[int, int]] = set()
        self.no_space_before: set[tuple[int, int]] = set()
        self.level = 0
        self.closer = False


class _Formatter:
    def __init__(self, text: str, name: str):
        self.name = name
        self.text = text if text.endswith("\n") else text + "\n"
        self.src = Source(name, text)

    # ------------------------------------------------------------ parsing
    def run(self) -> str:
        parse_source(self.src, _is_macro_head)  # every syntax and block error, as `irt check` reports it
        parser = lark_parser()
        tokens = list(parser.parse_interactive(self.text, start="start").iter_parse())
        flat = _transform(_ToAst(self.src), parser.parse(self.text, start="start"))
        by_pos = {}
        for node in flat:
            if isinstance(node, tuple):   # ("DO", Do) or (kind, value, span) for IF / ELSEIF / ELSE / END
                sp = node[1].span if node[0] == "DO" else node[2]
            else:
                sp = node.span
            by_pos[(sp.line, sp.col)] = node
        self.lines = self.text.split("\n")
        self.variables = self._static_variables(flat)

        stmts: list[_Stmt] = []
        run: list = []
        for t in tokens + [None]:
            if t is None or t.type in ("_NL", "SEMICOLON"):
                if run:
                    node = by_pos.get((run[0].line, run[0].column))
                    if node is None:  # cannot happen with a parse that succeeded
                        raise RuntimeError(f"fmt: no statement at {run[0].line}:{run[0].column}")
                    stmts.append(_Stmt(run, node))
                    run = []
                continue
            run.append(t)
        for s in stmts:
            self._layout(s)
        self._indent(stmts)
        return self._emit(stmts)

    @staticmethod
    def _static_variables(flat) -> set[str]:
        """Every name a script may use as a variable: assigned, DO variables, MACRO parameters, constants."""
        from .expr import CONSTANTS

        names = set(CONSTANTS)
        for node in flat:
            if isinstance(node, A.Assign):
                names.add(node.name.upper())
            elif isinstance(node, tuple) and node[0] == "DO":
                names.add(node[1].var.upper())
            elif isinstance(node, A.Command) and _is_macro_head(node.head):
                names.update(a.name.upper() for a in node.args if isinstance(a, A.Word))
        return names

    # ------------------------------------------------------------ keywords and spacing
    def _layout(self, s: _Stmt) -> None:
        toks, node = s.tokens, s.node
        pos = [(t.line, t.column) for t in toks]
        reserved = [i for i, t in enumerate(toks) if t.type in RESERVED]
        for i in reserved:  # blanks around the reserved words
            if i > 0:
                s.space_before.add(pos[i])
            if i + 1 < len(toks):
                s.space_before.add(pos[i + 1])
        if isinstance(node, A.Assign):
            s.space_before.update(pos[1:3])
        elif isinstance(node, tuple) and node[0] == "DO":
            s.space_before.update(pos[1:4])
            depth = 0
            for i, t in enumerate(toks):
                depth += {"LPAR": 1, "RPAR": -1}.get(t.type, 0)
                if t.type == "COMMA" and depth == 0:
                    s.no_space_before.add(pos[i])
                    if i + 1 < len(toks):
                        s.space_before.add(pos[i + 1])
        elif isinstance(node, tuple) and node[0] == "END" and len(toks) > 1:
            s.marks[pos[1]] = str(toks[1]).upper()
        elif isinstance(node, A.Command):
            self._command(s, node)
        elif isinstance(node, A.If):  # IF (cond) command on one line
            cmd = node.branches[0].body[0]
            s.space_before.add((cmd.head_span.line, cmd.head_span.col))
            self._command(s, cmd)

    def _command(self, s: _Stmt, cmd: A.Command) -> None:
        hpos = (cmd.head_span.line, cmd.head_span.col)
        head = canonical_head(cmd.head)
        u = cmd.head.upper()
        if u in ("ENDDO", "ENDIF", "ENDMACRO") and not cmd.args:
            s.marks[hpos] = "END " + u[3:]
            return
        if head is None:
            return
        s.marks[hpos] = head
        for a in cmd.args:
            s.space_before.add((a.span.line, a.span.col))
        if head == "MACRO":
            return
        if head == "SELECT":
            _select_marks(cmd.args, s.marks)
            return
        walker = KeywordWalker(lambda n: n.upper() in self.variables)
        s.marks.update(walker.command(_table()[head].form, cmd.args))

    # ------------------------------------------------------------ indentation
    def _indent(self, stmts: list[_Stmt]) -> None:
        stack: list[str] = []

        def pop_implicit():
            while stack and stack[-1] in ("SURF", "OBJ"):
                stack.pop()

        for s in stmts:
            node = s.node
            s.closer = False
            kind = node[0] if isinstance(node, tuple) else None
            head = None
            if isinstance(node, A.Command):
                u = node.head.upper()
                head = ("END " + u[3:]) if u in ("ENDDO", "ENDIF", "ENDMACRO") and not node.args else canonical_head(node.head)
            if kind == "END" or (head or "").startswith("END "):
                what = node[1] if kind == "END" else head[4:]
                pop_implicit()
                target = {"DO": "DO", "IF": "IF", "MACRO": "MACRO", "GROUP": "GROUP"}.get(what)
                if target in stack:
                    idx = len(stack) - 1 - stack[::-1].index(target)
                    del stack[idx:]
                    s.level = idx
                else:
                    s.level = len(stack)
                s.closer = True
            elif kind in ("ELSEIF", "ELSE"):
                pop_implicit()
                s.level = max(len(stack) - 1, 0)
                s.closer = True
            elif kind in ("DO", "IF") or head in ("MACRO", "GROUP", "SURFACE"):
                if head in ("GROUP", "SURFACE"):
                    pop_implicit()
                elif stack and stack[-1] == "OBJ":
                    stack.pop()
                s.level = len(stack)
                stack.append({"DO": "DO", "IF": "IF"}.get(kind) or {"SURFACE": "SURF"}.get(head, head))
            elif head == "OBJECT":
                if stack and stack[-1] in ("SURF", "OBJ"):
                    stack.pop()
                s.level = len(stack)
                stack.append("OBJ")
            elif head in MODIFIERS or (isinstance(node, A.If)
                                       and canonical_head(node.branches[0].body[0].head) in MODIFIERS):
                s.level = len(stack)
            else:
                if stack and stack[-1] == "OBJ":
                    stack.pop()
                s.level = len(stack)
        pop_implicit()
        self.end_level = len(stack)

    # ------------------------------------------------------------ output
    def _comment(self, line_no: int, start: int) -> tuple[str | None, int]:
        """The comment of a physical line after character `start` (text, its column), if any.

        After the last code token of a line there can only be blanks, ';' separators, a '&' and a comment.
        """
        line = self.lines[line_no - 1].rstrip("\r") if line_no - 1 < len(self.lines) else ""
        i = start
        while i < len(line) and line[i] in " \t\f;":
            i += 1
        if line[i:i + 1] == "&":
            i += 1
            while i < len(line) and line[i] in " \t\f":
                i += 1
        if line.startswith("!!", i):
            return line[i:].rstrip(), i
        return None, 0

    def _render_line(self, s: _Stmt, toks) -> str:
        out = []
        prev = None
        for t in toks:
            p = (t.line, t.column)
            txt = s.marks.get(p)
            if txt is None:
                txt = str(t)
                if t.type in RESERVED:
                    txt = txt.upper()
                elif t.type == "QTY":
                    txt = _QTY_WS.sub(" ", txt)
            if prev is not None:
                if p in s.no_space_before:
                    gap = ""
                elif p in s.space_before:
                    gap = " "
                else:
                    touching = prev.end_line == t.line and prev.end_column == t.column
                    gap = "" if touching else " "
                out.append(gap)
            out.append(txt)
            prev = t
        return "".join(out)

    def _emit(self, stmts: list[_Stmt]) -> str:
        owner: dict[int, int] = {}      # the last statement with code on a line owns the line's comment
        code_end: dict[int, int] = {}   # where the code of a line ends (0-based), for finding its comment
        shared: set[int] = set()        # lines holding code of several statements (split by fmt)
        for k, s in enumerate(stmts):
            for t in s.tokens:
                if owner.get(t.line, k) != k:
                    shared.add(t.line)
                owner[t.line] = k
                code_end[t.line] = max(code_end.get(t.line, 0), t.end_column - 1)
        out: list[str] = []
        pending: list[str | None] = []   # comment lines (text) and blank lines (None) before a statement

        def free_line(ln: int) -> None:
            text, _ = self._comment(ln, 0)
            if text is not None:
                pending.append(text)
            elif not self.lines[ln - 1].strip(" \t\f\r;&") and "&" not in self.lines[ln - 1]:
                pending.append(None)

        def flush(level: int) -> None:
            for text in pending:
                if text is None:
                    if out and out[-1] != "":
                        out.append("")
                else:
                    out.append(INDENT * level + text)
            pending.clear()

        prev_last = 0
        for k, s in enumerate(stmts):
            for ln in range(prev_last + 1, s.first_line):
                free_line(ln)
            flush(s.level + 1 if s.closer else s.level)
            indent = INDENT * s.level
            by_line: dict[int, list] = {}
            for t in s.tokens:
                by_line.setdefault(t.line, []).append(t)
            for ln in range(s.first_line, s.last_line + 1):
                toks = by_line.get(ln)
                comment, col = self._comment(ln, code_end.get(ln, 0)) if owner.get(ln, k) == k else (None, 0)
                if toks is None:
                    if comment is None:
                        continue
                    code = indent + CONT_INDENT + "&"
                else:
                    code = (indent if ln == s.first_line else indent + CONT_INDENT) + self._render_line(s, toks)
                    if ln != s.last_line:
                        code += " &"
                if comment is not None:  # the comment keeps its column where the code still fits before it
                    keep = ln not in shared and col >= len(code) + 1
                    code = (code + " " * (col - len(code)) if keep else code + "  ") + comment
                out.append(code)
            prev_last = max(prev_last, s.last_line)
        for ln in range(prev_last + 1, len(self.lines)):   # the text ends with a newline: skip the last ""
            free_line(ln)
        flush(self.end_level)
        while out and out[-1] == "":
            out.pop()
        while out and out[0] == "":
            out.pop(0)
        return "\n".join(out) + "\n" if out else ""
