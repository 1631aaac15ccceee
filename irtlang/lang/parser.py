"""Text -> Lark tree -> AST (with spans) -> nested blocks.

The first syntax error stops parsing and is raised as an ``IrtError`` with a located diagnostic.
"""
from __future__ import annotations

import functools
from collections import OrderedDict
from importlib import resources
from pathlib import Path
from typing import Callable

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, VisitError

from . import ast as A
from ..core import diskcache
from ..core.diagnostics import IrtError, Source, Span, did_you_mean, error
from ..core.units import UNITS, parse_qty_token


def grammar_text() -> str:
    """The grammar, from the installed package (irtlang.grammar) or a source checkout (grammar/)."""
    try:
        return resources.files("irtlang.grammar").joinpath("irt.lark").read_text(encoding="utf-8")
    except (ModuleNotFoundError, FileNotFoundError):
        here = Path(__file__).resolve().parents[2] / "grammar" / "irt.lark"
        return here.read_text(encoding="utf-8")


@functools.lru_cache(maxsize=1)
def lark_parser() -> Lark:
    return Lark(grammar_text(), parser="lalr", propagate_positions=True, maybe_placeholders=False,
                start=["start", "expr"], cache=True)


# ---------------------------------------------------------------- tree -> AST
def _tok_span(src: Source, t: Token, line_offset: int = 0, col_offset: int = 0) -> Span:
    return Span(src, t.line + line_offset, t.column + (col_offset if t.line == 1 else 0),
                t.end_line + line_offset, t.end_column + (col_offset if t.end_line == 1 else 0))


def _meta_span(src: Source, meta, line_offset: int = 0, col_offset: int = 0) -> Span:
    return Span(src, meta.line + line_offset, meta.column + (col_offset if meta.line == 1 else 0),
                meta.end_line + line_offset, meta.end_column + (col_offset if meta.end_line == 1 else 0))


class _ToAst(Transformer):
    """Builds AST nodes.  Offsets place interpolated sub-expressions inside their string."""

    def __init__(self, src: Source, line_offset: int = 0, col_offset: int = 0):
        super().__init__()
        self.src, self.lo, self.co = src, line_offset, col_offset

    def _sp(self, x) -> Span:
        if isinstance(x, Token):
            return _tok_span(self.src, x, self.lo, self.co)
        if isinstance(x, Tree):
            return _meta_span(self.src, x.meta, self.lo, self.co)
        return x.span

    # -- atoms
    @v_args(tree=True)
    def qty(self, tree):
        tok = tree.children[0]
        num, unit = parse_qty_token(str(tok))
        return A.Num(num, unit, str(tok), self._sp(tok))

    def word(self, children):
        tok = children[0]
        return A.Word(str(tok), self._sp(tok))

    def string(self, children):
        tok = children[0]
        span = self._sp(tok)
        raw = str(tok)[1:-1]
        return A.Str(raw, tuple(_interpolate(raw, self.src, span)), span)

    def word_op(self, children):
        tok = children[0]
        return A.WordOp(str(tok).upper(), self._sp(tok))

    @v_args(tree=True)
    def call(self, tree):
        name_tok = tree.children[0]
        args = tuple(c for c in tree.children[1:] if not isinstance(c, Token))
        return A.Call(str(name_tok), args, _meta_span(self.src, tree.meta, self.lo, self.co),
                      self._sp(name_tok))

    @v_args(tree=True)
    def paren(self, tree):
        return A.Paren(tree.children[0], _meta_span(self.src, tree.meta, self.lo, self.co))

    @v_args(tree=True)
    def neg(self, tree):
        return A.UnOp("-", tree.children[0], _meta_span(self.src, tree.meta, self.lo, self.co))

    uneg = neg

    @v_args(tree=True)
    def repeat(self, tree):
        cnt, val = tree.children
        if isinstance(cnt, Token):  # QTY or NAME token
            cnt = (A.Num(*parse_qty_token(str(cnt)), str(cnt), self._sp(cnt)) if cnt.type == "QTY"
                   else A.Word(str(cnt), self._sp(cnt)))
        return A.Repeat(cnt, val, _meta_span(self.src, tree.meta, self.lo, self.co))

    # -- operators
    @v_args(tree=True)
    def binop(self, tree):
        left, op, right = tree.children
        return A.BinOp(str(op), left, right, _meta_span(self.src, tree.meta, self.lo, self.co), self._sp(op))

    compare = binop

    @v_args(tree=True)
    def pow(self, tree):
        left, right = tree.children
        sp = _meta_span(self.src, tree.meta, self.lo, self.co)
        return A.BinOp("^", left, right, sp, sp)

    def _bool(self, tree, op):
        left, _, right = tree.children
        return A.BinOp(op, left, right, _meta_span(self.src, tree.meta, self.lo, self.co),
                       self._sp(tree.children[1]))

    @v_args(tree=True)
    def or_op(self, tree):
        return self._bool(tree, "OR")

    @v_args(tree=True)
    def and_op(self, tree):
        return self._bool(tree, "AND")

    @v_args(tree=True)
    def not_op(self, tree):
        return A.UnOp("NOT", tree.children[1], _meta_span(self.src, tree.meta, self.lo, self.co))

    # -- statements (flat; blocks are built afterwards)
    @v_args(tree=True)
    def assign(self, tree):
        name, expr = tree.children
        return A.Assign(str(name), self._sp(name), expr, _meta_span(self.src, tree.meta))

    @v_args(tree=True)
    def command(self, tree):
        head, *items = tree.children
        for a, b in zip(items, items[1:]):  # `550nmm`: letters touching a number are a unit it does not know
            if (isinstance(a, A.Num) and a.unit is None and isinstance(b, A.Word) and b.span.line == a.span.end_line
                    and b.span.col == a.span.end_col and not a.text.rstrip().endswith("%")):
                raise _unknown_unit(b.span, b.name)
        return A.Command(str(head), self._sp(head), tuple(items), _meta_span(self.src, tree.meta))

    @v_args(tree=True)
    def do_head(self, tree):
        _, var, start, stop, *step = tree.children
        return ("DO", A.Do(str(var), self._sp(var), start, stop, step[0] if step else None, (),
                           _meta_span(self.src, tree.meta)))

    @v_args(tree=True)
    def if_then(self, tree):
        return ("IF", tree.children[1], _meta_span(self.src, tree.meta))

    @v_args(tree=True)
    def if_line(self, tree):
        sp = _meta_span(self.src, tree.meta)
        return A.If((A.Branch(tree.children[1], (tree.children[2],), sp),), sp)

    @v_args(tree=True)
    def elseif_head(self, tree):
        return ("ELSEIF", tree.children[2], _meta_span(self.src, tree.meta))

    @v_args(tree=True)
    def else_stmt(self, tree):
        return ("ELSE", None, _meta_span(self.src, tree.meta))

    @v_args(tree=True)
    def end_stmt(self, tree):
        what = str(tree.children[1]).upper() if len(tree.children) > 1 else ""
        return ("END", what, _meta_span(self.src, tree.meta))

    def start(self, children):
        return [c for c in children if not isinstance(c, Token)]


def _interpolate(raw: str, src: Source, span: Span) -> list:
    """Split ``'VANE_{i}'`` into literal text and parsed expressions; ``{{`` and ``}}`` are literal."""
    parts: list = []
    buf = []
    i = 0
    while i < len(raw):
        ch = raw[i]
        if ch == "{" and raw.startswith("{{", i):
            buf.append("{")
            i += 2
            continue
        if ch == "}" and raw.startswith("}}", i):
            buf.append("}")
            i += 2
            continue
        if ch == "{":
            j = raw.find("}", i + 1)
            col = span.col + 1 + i  # column of '{' (the string starts with its quote)
            if j < 0:
                raise error(Span(src, span.line, col, span.line, col + 1),
                            "unterminated interpolation: '{' without its '}'",
                            "write {{ for a literal brace")
            inner = raw[i + 1:j]
            fmt = None
            if ":" in inner:
                inner, fmt = inner.split(":", 1)
            if buf:
                parts.append("".join(buf))
                buf = []
            if not inner.strip():
                raise error(Span(src, span.line, col, span.line, col + 2), "empty interpolation '{}'")
            expr = parse_expression(inner, src, span.line, col + 1)
            parts.append(("fmt", expr, fmt) if fmt else expr)
            i = j + 1
            continue
        if ch == "}":
            col = span.col + 1 + i
            raise error(Span(src, span.line, col, span.line, col + 1), "'}' without its '{'",
                        "write }} for a literal brace")
        buf.append(ch)
        i += 1
    if buf:
        parts.append("".join(buf))
    return parts


def parse_expression(text: str, src: Source, line: int, col: int) -> A.Expr:
    """Parse an expression that sits at (line, col) of src (used for {interpolations})."""
    try:
        tree = lark_parser().parse(text, start="expr")
    except UnexpectedInput as e:
        raise _syntax_error(e, Source(src.name, src.text), text, line - 1, col - 1) from None
    return _transform(_ToAst(src, line - 1, col - 1), tree)


def _transform(t: _ToAst, tree):
    try:
        return t.transform(tree)
    except VisitError as e:  # a diagnostic raised inside a rule (e.g. a bad {interpolation})
        if isinstance(e.orig_exc, IrtError):
            raise e.orig_exc from None
        if isinstance(e.orig_exc, RecursionError):
            raise _too_deep(t, tree) from None
        raise
    except RecursionError:  # `x = 1 + 1 + ... + 1` with hundreds of terms nests as deep as it is long
        raise _too_deep(t, tree) from None


def _too_deep(t: _ToAst, tree) -> IrtError:
    """The statement whose tree nests deepest (measured without recursion)."""
    best, where = -1, tree
    for st in (tree.children if tree.data == "start" else [tree]):
        if not isinstance(st, Tree):
            continue
        depth, stack = 0, [(st, 1)]
        while stack:
            node, d = stack.pop()
            depth = max(depth, d)
            stack.extend((c, d + 1) for c in node.children if isinstance(c, Tree))
        if depth > best:
            best, where = depth, st
    span = _meta_span(t.src, where.meta, t.lo, t.co) if not where.meta.empty else Span(t.src, 1, 1, 1, 2)
    return error(span, f"this statement nests too deeply ({best} levels of operators or calls)",
                 "split it into several assignments")


# ---------------------------------------------------------------- syntax errors
_TOKEN_WORDS = {
    "_NL": "end of line", "$END": "end of file", "RPAR": "')'", "LPAR": "'('", "EQUAL": "'='",
    "COMMA": "','", "QTY": "a number", "NAME": "a name", "STRING": "a string", "CALLNAME": "a function",
    "SEMICOLON": "';'", "THEN": "THEN", "DO": "DO", "IF": "IF", "ELSE": "ELSE", "END": "END",
    "MINUS": "'-'", "PLUS": "'+'", "AT": "'@'", "COMP_OP": "a comparison", "ADD_OP": "'+' or '-'",
    "MUL_OP": "'*' or '/'", "CIRCUMFLEX": "'^'", "AND": "AND", "OR": "OR", "NOT": "NOT",
}


def _describe_expected(expected) -> str:
    words = sorted({_TOKEN_WORDS.get(t, t) for t in expected if not t.startswith("__")})
    if len(words) > 6:
        return ""
    return "expected " + ", ".join(words)


def _syntax_error(e: UnexpectedInput, src: Source, text: str, line_offset: int = 0, col_offset: int = 0):
    line = (e.line if e.line and e.line > 0 else text.count("\n") + 1)
    col = e.column if e.column and e.column > 0 else 1
    if getattr(getattr(e, "token", None), "type", None) == "$END":  # lark places it on the last token
        rows = text.rstrip("\r\n").split("\n")
        line, col = len(rows), len(rows[-1]) + 1
    gl, gc = line + line_offset, col + (col_offset if line == 1 else 0)
    at = Span(src, gl, gc, gl, gc + 1)
    line_text = text.split("\n")[line - 1] if text.split("\n")[line - 1:line] else ""

    if isinstance(e, UnexpectedCharacters):
        ch = text[e.pos_in_stream] if e.pos_in_stream < len(text) else ""
        if ch in "'\"":
            end = len(line_text) + 1
            return error(Span(src, gl, gc, gl, max(gc + 1, end + (col_offset if line == 1 else 0))),
                         "unterminated string", f"close it with {ch} on the same line")
        if ch == "&":
            return error(at, "'&' continues a line only as the last thing on it")
        if ch == "{" or ch == "}":
            return error(at, f"unexpected '{ch}': braces belong inside a quoted string ('NAME_{{i}}')")
        if ch == "!":
            return error(at, "unexpected '!': a comment starts with '!!'")
        return error(at, f"unexpected character {ch!r}")

    tok = getattr(e, "token", None)
    ttype = getattr(tok, "type", "$END")
    expected = getattr(e, "expected", None) or getattr(e, "accepts", None) or set()
    # an open parenthesis on this line that never closed
    if ttype in ("_NL", "$END", "SEMICOLON") and "RPAR" in expected:
        depth, open_col = 0, None
        stack = []
        in_str = None
        upto = (col - 1) if ttype != "$END" else len(line_text)
        for i, c in enumerate(line_text[:upto]):
            if in_str:
                if c == in_str:
                    in_str = None
            elif c in "'\"":
                in_str = c
            elif c == "(":
                stack.append(i)
            elif c == ")" and stack:
                stack.pop()
        if stack:
            open_col = stack[-1] + 1 + (col_offset if line == 1 else 0)
            return error(Span(src, gl, open_col, gl, open_col + 1), "unterminated parenthesis: '(' is never closed",
                         "add the missing ')'")
    if ttype in ("_NL", "$END"):
        if tok is not None and ttype == "_NL":
            pass
        what = ("the line ends too early" if ttype == "_NL" else
                "the expression ends too early" if line_offset or col_offset else "the script ends too early")
        exp = _describe_expected(expected)
        return error(at, what + (f": {exp}" if exp else ""))
    val = str(tok)
    exp = _describe_expected(expected)
    pos = getattr(tok, "start_pos", None)
    if ttype == "NAME" and pos and (text[pos - 1].isdigit() or text[pos - 1] == "."):
        return _unknown_unit(Span(src, gl, gc, gl, gc + len(val)), val)
    if ttype == "EQUAL":
        return error(at, "unexpected '=': an assignment is 'name = value' at the start of a statement"
                     + (f"; {exp}" if exp else ""), "compare with '=='")
    if ttype == "END":
        return error(at, "END must start its own statement", "put it on a new line or after ';'")
    if ttype in ("MUL_OP", "CIRCUMFLEX", "COMP_OP", "ADD_OP"):
        return error(at, f"unexpected {val!r}" + (f": {exp}" if exp else ""),
                     "an expression among a command's arguments needs parentheses: (D/2)")
    return error(at, f"unexpected {val!r}" + (f": {exp}" if exp else ""))


def _unknown_unit(span: Span, word: str):
    known = " ".join(u for u in UNITS if u != "%")
    return error(span, f"unknown unit '{word}'", did_you_mean(word, UNITS) or f"known units: {known}")


# ---------------------------------------------------------------- blocks
def _check_text(data: bytes, name: str) -> str:
    nul = data.find(b"\x00")
    if nul >= 0:   # reported where it is (line:col), so that a stray NUL in a script can be found
        text = data[:nul].decode("utf-8-sig", "replace")
        line = text.count("\n") + 1
        col = len(text) - (text.rfind("\n") + 1) + 1
        src = Source(name, text)     # the text up to the NUL: what follows it is not shown
        raise error(Span(src, line, col, line, col + 1), f"a NUL byte (\\0) here: {name} is not a text script")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        text = data[: e.start].decode("utf-8", "replace")
        line = text.count("\n") + 1
        col = len(text) - (text.rfind("\n") + 1) + 1
        src = Source(name, text)
        raise error(Span(src, line, col, line, col + 1),
                    f"{name} is not a UTF-8 text file (byte 0x{data[e.start]:02x} at offset {e.start})") from None


def read_source(path: str | Path, display_name: str | None = None, max_bytes: float | None = None) -> Source:
    """A script's text; with max_bytes, a larger file (or an endless one, /dev/zero) is an error, read no further."""
    p = Path(path)
    name = display_name or str(path)
    try:
        with open(p, "rb") as f:
            data = f.read(int(max_bytes) + 1) if max_bytes is not None else f.read()
    except (OSError, ValueError) as e:
        raise error(Span(Source(name, ""), 0, 0, 0, 0),
                    f"cannot read {name}: {getattr(e, 'strerror', None) or e}") from None
    if max_bytes is not None and len(data) > max_bytes:
        from ..limits import show

        raise error(Span(Source(name, ""), 0, 0, 0, 0), f"{name} is larger than the limit script="
                    f"{show('script', max_bytes)}", "raise it with `irt run FILE --limit script=VALUE`")
    return Source(name, _check_text(data, name))


# the statements of the texts parsed last, by (name, text): a file INCLUDEd again (in a loop, after SYSTEM NEW) is
# parsed once.  The statements are immutable (frozen dataclasses and tuples); their spans point at the Source
# of the first parse, which has the same name and text.
_FLAT_CACHE: OrderedDict = OrderedDict()
_FLAT_CACHE_SIZE = 32


DISK_CACHE_MIN_BYTES = 32768     # texts this large keep their parse on disk (the Earth's include files: 7 s)


def _disk_key(name: str, text: str) -> str | None:
    """The parse's key in the disk cache (irtlang.core.diskcache): the file's name and text and the code that
    parses it (grammar, parser, AST, units, spans); None for small texts, which parse in milliseconds."""
    if len(text) < DISK_CACHE_MIN_BYTES:
        return None
    here = Path(__file__).resolve()
    code = diskcache.code_hash(str(here), str(here.with_name("ast.py")), str(here.parents[1] / "core" / "units.py"),
                               str(here.parents[1] / "core" / "diagnostics.py"))
    return diskcache.key("parse", 1, code, grammar_text(), name, text)


def parse_source(src: Source, is_macro_head: Callable[[str], bool] | None = None) -> A.Program:
    """Parse a whole script into a Program of nested statements."""
    text = src.text
    if not text.endswith("\n"):
        text += "\n"
    key = (src.name, text)
    flat = _FLAT_CACHE.get(key)
    if flat is None:
        dkey = _disk_key(src.name, text)
        flat = diskcache.load("parse", dkey) if dkey else None
        if flat is None:
            try:
                tree = lark_parser().parse(text, start="start")
            except UnexpectedInput as e:
                raise _syntax_error(e, src, text) from None
            flat = tuple(_transform(_ToAst(src), tree))
            if dkey:
                diskcache.store("parse", dkey, flat)
        _FLAT_CACHE[key] = flat
        while len(_FLAT_CACHE) > _FLAT_CACHE_SIZE:
            _FLAT_CACHE.popitem(last=False)
    else:
        _FLAT_CACHE.move_to_end(key)
    return A.Program(tuple(build_blocks(flat, is_macro_head or (lambda h: h.upper() == "MACRO"))), src)


def build_blocks(flat: list, is_macro_head: Callable[[str], bool]) -> list:
    """Nest DO / IF / MACRO bodies; report END without opener and openers without END."""
    root: list = []
    # stack entries: [kind, node_or_header, body_list, branches]
    stack: list = []

    def body() -> list:
        return stack[-1][2] if stack else root

    for st in flat:
        if isinstance(st, tuple):
            kind = st[0]
            if kind == "DO":
                stack.append(["DO", st[1], []])
            elif kind == "IF":
                stack.append(["IF", st, [], []])
            elif kind in ("ELSEIF", "ELSE"):
                if not stack or stack[-1][0] != "IF":
                    word = "ELSE IF" if kind == "ELSEIF" else "ELSE"
                    raise error(st[2], f"{word} without IF")
                top = stack[-1]
                if top[1] is None:
                    raise error(st[2], f"{'ELSE IF' if kind == 'ELSEIF' else 'ELSE'} after ELSE")
                cond, sp = top[1][1], top[1][2]
                top[3].append(A.Branch(cond, tuple(top[2]), sp))
                top[2] = []
                top[1] = (kind, st[1], st[2]) if kind == "ELSEIF" else None
                if kind == "ELSE":
                    top.append(st[2])  # remember where ELSE is, for the final branch span
            elif kind == "END":
                what, sp = st[1], st[2]
                _close(stack, root, what, sp, body)
            continue
        if isinstance(st, A.Command):
            h = st.head.upper()
            if h in ("ENDDO", "ENDIF"):
                _close(stack, root, h[3:], st.span, body)
                continue
            if h == "ENDMACRO":
                _close(stack, root, "MACRO", st.span, body)
                continue
            if is_macro_head(st.head):
                if stack and stack[-1][0] == "MACRO":
                    raise error(st.span, "a MACRO cannot be defined inside another MACRO")
                if not st.args or not isinstance(st.args[0], (A.Word, A.Str)):
                    raise error(st.span, "MACRO needs a name: MACRO name [param ...]")
                params = []
                for a in st.args[1:]:
                    if not isinstance(a, A.Word):
                        raise error(a.span, "a MACRO parameter must be a plain name")
                    params.append(a.name)
                nm = st.args[0].name if isinstance(st.args[0], A.Word) else st.args[0].text
                stack.append(["MACRO", (nm, tuple(params), st.span, st.args[0].span), []])
                continue
        body().append(st)
    if stack:
        top = stack[-1]
        sp = top[1].span if top[0] == "DO" else (top[1][2] if top[0] == "MACRO" else top[1][2] if top[1] else top[-1])
        if top[0] == "IF":
            sp = top[3][0].span if top[3] else (top[1][2] if top[1] else sp)
        raise error(sp, f"{top[0]} without END {top[0]}", f"close the block with END {top[0]}")
    return root


def _close(stack: list, root: list, what: str, sp: Span, body) -> None:
    if what == "GROUP":
        body().append(A.Command("END GROUP", sp, (), sp))
        return
    if what not in ("DO", "IF", "MACRO", ""):
        raise error(sp, f"END {what}: expected END DO, END IF, END MACRO or END GROUP")
    if not stack:
        raise error(sp, f"END {what or ''} without its opener".replace("  ", " ").strip()
                    + (f": no {what} is open" if what else ""))
    top = stack[-1]
    if what == "":
        raise error(sp, f"END needs a word here: END {top[0]}", f"write END {top[0]}")
    if top[0] != what:
        raise error(sp, f"END {what} without its opener: the open block is {top[0]}",
                    f"close the {top[0]} first with END {top[0]}")
    stack.pop()
    if what == "DO":
        d = top[1]
        node = A.Do(d.var, d.var_span, d.start, d.stop, d.step, tuple(top[2]), d.span)
    elif what == "MACRO":
        nm, params, hsp, nsp = top[1]
        node = A.Macro(nm, params, tuple(top[2]), hsp, nsp)
    else:
        branches = list(top[3])
        if top[1] is not None:
            branches.append(A.Branch(top[1][1], tuple(top[2]), top[1][2]))
        else:
            branches.append(A.Branch(None, tuple(top[2]), top[4]))
        node = A.If(tuple(branches), branches[0].span)
    (stack[-1][2] if stack else root).append(node)
