"""Command signatures: a small declarative language, and the binder that matches argument items to it.

A command is ``HEAD`` followed by a ``Form``: positional parameters (possibly a ``Variants`` choice
selected by a keyword) and keyword ``Clause``s that may come in any order.  Plugins (surfaces, scatter
models, sources) declare their own forms with these classes, so a new kind is one module.

Keywords match case-insensitively, exactly or by a prefix of at least three letters that no other keyword
allowed at that place shares.  In a list of values a bare word that matches a keyword allowed there ends the
list; anywhere else a bare word in a value position is a variable (wrap a variable in parentheses to force
it to be a value).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Sequence

from . import ast as A
from ..core.diagnostics import Span, did_you_mean, error
from ..core.units import Dim, NONE, Quantity, dim_name

# ---------------------------------------------------------------- declarations


@dataclass(frozen=True)
class Param:
    """One positional parameter.

    kind: name | ref | refs | val | vals | perline | axis | path | choice | rest
    """

    label: str
    kind: str
    dim: Dim | None = NONE
    n: int | None = None            # exact count (vals)
    min_n: int = 1                  # least count (vals, refs)
    integer: bool = False
    check: Callable[[float], str | None] | None = None   # returns an error message or None
    ns: str | None = None           # namespace of a ref
    words: tuple = ()               # choice
    optional: bool = False
    doc: str = ""

    def usage(self) -> str:
        lab = self.label
        if self.kind in ("vals", "perline", "refs") and self.n is None:
            lab += "..."
        elif self.kind == "vals" and self.n:
            lab = " ".join(f"{lab}{i + 1}" for i in range(self.n)) if self.n <= 3 else f"{lab}1..{lab}{self.n}"
        if self.kind == "choice":
            lab = "|".join(self.words)
        if self.kind == "path":
            lab = f"'{lab}'"
        return f"[{lab}]" if self.optional else lab


@dataclass(frozen=True)
class Clause:
    kw: str
    params: tuple = ()
    required: bool = False
    doc: str = ""

    def usage(self) -> str:
        inner = " ".join([self.kw] + [p.usage() for p in self.params])
        return inner if self.required else f"[{inner}]"


@dataclass(frozen=True)
class Variants:
    label: str
    options: dict                    # keyword -> Form
    default: "Form | None" = None    # when the next item is none of the keywords


@dataclass(frozen=True)
class Form:
    params: tuple = ()
    clauses: tuple = ()

    def __post_init__(self):  # allow Form(Variants(...)) and Form(param) without a 1-tuple
        if not isinstance(self.params, tuple):
            object.__setattr__(self, "params", (self.params,))
        if not isinstance(self.clauses, tuple):
            object.__setattr__(self, "clauses", (self.clauses,))

    def usages(self, prefix: str) -> list[str]:
        out = [prefix]
        for p in self.params:
            if isinstance(p, Variants):
                subs = []
                for kw, f in p.options.items():
                    subs.extend(f.usages(f"{kw}"))
                if p.default is not None:
                    subs.extend(p.default.usages(""))
                tail = " ".join(c.usage() for c in self.clauses)
                return [" ".join(x for x in (o, s, tail) if x) for o in out for s in subs]
            out = [f"{o} {p.usage()}".strip() for o in out]
        tail = " ".join(c.usage() for c in self.clauses)
        return [f"{o} {tail}".strip() for o in out]


def V(label, dim=NONE, **kw) -> Param:
    return Param(label, "val", dim, **kw)


def Vs(label, dim=NONE, **kw) -> Param:
    return Param(label, "vals", dim, **kw)


def PL(label, dim=NONE, **kw) -> Param:
    return Param(label, "perline", dim, **kw)


def Name(label, **kw) -> Param:
    return Param(label, "name", None, **kw)


def Ref(label, ns, **kw) -> Param:
    return Param(label, "ref", None, ns=ns, **kw)


def Path(label, **kw) -> Param:
    return Param(label, "path", None, **kw)


def Axis(label="axis", **kw) -> Param:
    return Param(label, "axis", None, words=("X", "Y", "Z"), **kw)


def Choice(label, words, **kw) -> Param:
    return Param(label, "choice", None, words=tuple(words), **kw)


def Rest(label, **kw) -> Param:
    return Param(label, "rest", None, **kw)


# checks
def positive(x):
    return None if x > 0 else "must be > 0"


def nonneg(x):
    return None if x >= 0 else "must be >= 0"


def unit_interval(x):
    return None if 0.0 <= x <= 1.0 else "must be in [0, 1]"


MAX_REPEAT = 100_000        # the largest n of n@v (and of WAVELENGTHS RANGE)


# ---------------------------------------------------------------- keyword matching
def match_keyword(word: str, allowed: Iterable[str], span: Span) -> str | None:
    """The keyword `word` stands for among `allowed`: exact, or a unique prefix of >= 3 letters."""
    w = word.upper()
    allowed = list(dict.fromkeys(a.upper() for a in allowed))
    if w in allowed:
        return w
    if len(w) < 3:
        return None
    cands = [a for a in allowed if a.startswith(w)]
    if len(cands) == 1:
        return cands[0]
    if len(cands) > 1:
        raise error(span, f"ambiguous abbreviation '{word}': it could be " + ", ".join(sorted(cands)),
                    "write more letters")
    return None


# ---------------------------------------------------------------- binding
@dataclass(frozen=True)
class PerLine:
    """A wavelength-dependent value normalized to one value per system line."""

    values: tuple
    spectrum: str | None = None


@dataclass
class Bound:
    head: str
    span: Span
    head_span: Span
    values: dict = field(default_factory=dict)
    spans: dict = field(default_factory=dict)
    variants: dict = field(default_factory=dict)

    def __getitem__(self, k):
        return self.values[k]

    def get(self, k, default=None):
        return self.values.get(k, default)

    def __contains__(self, k):
        return k in self.values

    def span_of(self, k) -> Span:
        return self.spans.get(k, self.span)


class BindContext:
    """What binding needs from the interpreter (values, names, wavelength lines)."""

    def eval(self, expr) -> Any: ...
    def to_dim(self, value, dim, span: Span) -> float: ...
    def resolve(self, ns: str, name: str, span: Span) -> str: ...
    def is_variable(self, name: str) -> bool: ...
    def n_lines(self) -> int: ...
    def spectrum_on_lines(self, name: str, span: Span) -> tuple: ...
    def string(self, item) -> str: ...
    def variable_names(self) -> list[str]: ...


class _Cursor:
    def __init__(self, items: Sequence, end_span: Span):
        self.items = list(items)
        self.i = 0
        self.end_span = end_span

    def peek(self):
        return self.items[self.i] if self.i < len(self.items) else None

    def next(self):
        it = self.items[self.i]
        self.i += 1
        return it

    def done(self) -> bool:
        return self.i >= len(self.items)


def _item_desc(it) -> str:
    if isinstance(it, A.Word):
        return f"'{it.name}'"
    if isinstance(it, A.Num):
        return f"'{it.text}'"
    if isinstance(it, A.Str):
        return f"the string '{it.text}'"
    if isinstance(it, A.WordOp):
        return it.op
    return "an expression"


def bind(head: str, form: Form, cmd: A.Command, ctx: BindContext) -> Bound:
    b = Bound(head, cmd.span, cmd.head_span)
    cur = _Cursor(cmd.args, Span(cmd.span.source, cmd.span.end_line, cmd.span.end_col,
                                 cmd.span.end_line, cmd.span.end_col + 1))
    clauses: list[Clause] = []
    _bind_form(form, cur, ctx, b, clauses, head)
    _bind_clauses(clauses, cur, ctx, b, head)
    return b


def _clause_kws(clauses) -> list[str]:
    return [c.kw for c, _ in clauses]


def _bind_form(form: Form, cur: _Cursor, ctx, b: Bound, clauses: list, where: str) -> None:
    clauses.extend((c, where) for c in form.clauses)
    for p in form.params:
        if isinstance(p, Variants):
            it = cur.peek()
            kw = None
            if isinstance(it, A.Word):
                kw = match_keyword(it.name, p.options, it.span)
            if kw is not None:
                cur.next()
                b.variants[p.label] = kw
                b.spans["variant:" + p.label] = it.span
                _bind_form(p.options[kw], cur, ctx, b, clauses, f"{where} {kw}")
            elif p.default is not None:
                b.variants[p.label] = None
                _bind_form(p.default, cur, ctx, b, clauses, where)
            else:
                opts = ", ".join(p.options)
                if it is None:
                    raise error(cur.end_span, f"{where} needs one of: {opts}")
                hint = did_you_mean(it.name, p.options) if isinstance(it, A.Word) else None
                raise error(it.span, f"{where}: expected one of {opts}, got {_item_desc(it)}", hint)
            continue
        _bind_param(p, cur, ctx, b, _clause_kws(clauses), where)


def _bind_clauses(clauses: list, cur: _Cursor, ctx, b: Bound, where: str) -> None:
    kws = _clause_kws(clauses)
    seen: dict[str, Span] = {}
    while not cur.done():
        it = cur.peek()
        kw = match_keyword(it.name, kws, it.span) if isinstance(it, A.Word) else None
        if kw is None:
            if not kws:
                if isinstance(it, A.Word) and not ctx.is_variable(it.name) and _after_bare_number(cur):
                    raise _unknown_unit(it, None)
                raise error(it.span, f"unexpected {_item_desc(it)}: {where} takes nothing more here")
            hint = did_you_mean(it.name, kws) if isinstance(it, A.Word) else None
            if hint is None and isinstance(it, A.Word) and ctx.is_variable(it.name):
                hint = "a value here needs a keyword before it"
            if hint is None and isinstance(it, A.Word) and _after_bare_number(cur):
                raise _unknown_unit(it, f"{where} takes " + ", ".join(kws) + " here")
            raise error(it.span, f"unexpected {_item_desc(it)} in {where}: expected "
                        + ", ".join(kws), hint)
        if kw in seen:
            raise error(it.span, f"{kw} given twice in {where}")
        seen[kw] = it.span
        cur.next()
        cl, cwhere = next((c, w) for c, w in clauses if c.kw == kw)
        b.spans["kw:" + kw] = it.span
        if not cl.params:
            b.values[kw.lower()] = True
        for p in cl.params:
            _bind_param(p, cur, ctx, b, kws, f"{cwhere} {kw}")
    for c, cwhere in clauses:
        if c.required and c.kw not in seen:
            raise error(b.span, f"{cwhere} needs {c.kw}", "usage: " + c.usage())


def _after_bare_number(cur: _Cursor) -> bool:
    """Whether the item before the cursor is a number without a unit on the same line (`5 furlongs`)."""
    prev = cur.items[cur.i - 1] if cur.i > 0 else None
    it = cur.peek()
    return (isinstance(prev, A.Num) and prev.unit is None and it is not None
            and it.span.line == prev.span.end_line)


def _unknown_unit(it, also: str | None):
    from ..core.units import UNITS
    hint = did_you_mean(it.name, UNITS)
    if hint is None:
        hint = "known units: " + " ".join(u for u in UNITS if u != "%") + (f"; {also}" if also else "")
    return error(it.span, f"unknown unit '{it.name}'", hint)


def _value_item(it) -> bool:
    return isinstance(it, (A.Num, A.Word, A.Paren, A.Call, A.UnOp, A.BinOp))


def _bind_param(p: Param, cur: _Cursor, ctx, b: Bound, stop_kws: list, where: str) -> None:
    it = cur.peek()
    if (it is None and p.kind != "rest") or (isinstance(it, A.Word) and p.kind in ("val", "vals", "perline")
                      and match_keyword(it.name, stop_kws, it.span)):
        if p.optional:
            return
        span = cur.end_span if it is None else it.span
        raise error(span, f"{where} needs {_need(p)}" + (f", got {_item_desc(it)}" if it is not None else ""),
                    None)
    k = p.kind
    if k in ("name", "ref"):
        if isinstance(it, A.Word) and match_keyword(it.name, stop_kws, it.span) and p.optional:
            return
        if not isinstance(it, (A.Word, A.Str)):
            if p.optional:
                return
            raise error(it.span, f"{where}: expected {p.label} (a name), got {_item_desc(it)}")
        cur.next()
        name = it.name if isinstance(it, A.Word) else ctx.string(it)
        if k == "ref":
            name = ctx.resolve(p.ns, name, it.span)
        b.values[p.label], b.spans[p.label] = name, it.span
        return
    if k == "refs":
        names, spans = [], []
        while not cur.done() and isinstance(cur.peek(), (A.Word, A.Str)):
            w = cur.peek()
            if isinstance(w, A.Word) and match_keyword(w.name, stop_kws, w.span):
                break
            cur.next()
            nm = w.name if isinstance(w, A.Word) else ctx.string(w)
            names.append(ctx.resolve(p.ns, nm, w.span))
            spans.append(w.span)
        if len(names) < p.min_n and not p.optional:
            raise error(cur.end_span if cur.done() else cur.peek().span, f"{where} needs {_need(p)}")
        b.values[p.label], b.spans[p.label] = tuple(names), (spans[0].to(spans[-1]) if spans else b.span)
        return
    if k == "path":
        if not isinstance(it, A.Str):
            if p.optional:
                return
            raise error(it.span, f"{where}: expected a quoted file name for {p.label}, got {_item_desc(it)}",
                        "write it in quotes: 'file.ext'")
        cur.next()
        b.values[p.label], b.spans[p.label] = ctx.string(it), it.span
        return
    if k in ("axis", "choice"):
        kw = match_keyword(it.name, p.words, it.span) if isinstance(it, A.Word) else None
        if kw is None:
            if p.optional:
                return
            hint = did_you_mean(it.name, p.words) if isinstance(it, A.Word) else None
            raise error(it.span, f"{where}: expected {' or '.join(p.words)}, got {_item_desc(it)}", hint)
        cur.next()
        b.values[p.label], b.spans[p.label] = kw, it.span
        return
    if k == "rest":
        items = []
        while not cur.done():
            items.append(cur.next())
        b.values[p.label] = tuple(items)
        b.spans[p.label] = items[0].span.to(items[-1].span) if items else b.span
        return
    if k == "val":
        if not _value_item(it):
            if p.optional:
                return
            raise error(it.span, f"{where}: expected {_need(p)}, got {_item_desc(it)}")
        cur.next()
        b.values[p.label] = _convert(p, it, ctx, where)
        b.spans[p.label] = it.span
        return
    if k == "perline":
        if isinstance(it, A.Word) and match_keyword(it.name, ["SPECTRUM"], it.span) and not ctx.is_variable(it.name):
            cur.next()
            nm = cur.peek()
            if not isinstance(nm, (A.Word, A.Str)):
                raise error(cur.end_span if nm is None else nm.span, f"{where}: SPECTRUM needs a spectrum name")
            cur.next()
            name = ctx.resolve("spectrum", nm.name if isinstance(nm, A.Word) else ctx.string(nm), nm.span)
            vals = ctx.spectrum_on_lines(name, nm.span)
            for x in vals:
                _check(p, x, nm.span, where)
            b.values[p.label], b.spans[p.label] = PerLine(tuple(vals), name), it.span.to(nm.span)
            return
    # vals / perline: a greedy list
    vals, spans = _take_list(p, cur, ctx, stop_kws, where)
    if p.n is not None and len(vals) != p.n:
        sp = spans[0].to(spans[-1]) if spans else cur.end_span
        raise error(sp, f"{where} expects {p.n} values for {p.label}, got {len(vals)}")
    if len(vals) < p.min_n and not (p.optional and not vals):
        raise error(cur.end_span if not spans else spans[-1], f"{where} needs {_need(p)}")
    sp = spans[0].to(spans[-1]) if spans else b.span
    if k == "perline":
        n = ctx.n_lines()
        if len(vals) == 1:
            vals = vals * n
        elif len(vals) != n:
            if getattr(ctx, "wavelengths_failed", False):  # the WAVELENGTHS that failed probably had this many
                raise ctx.follow_on(sp, f"{where}: {len(vals)} values for {p.label}, but the last WAVELENGTHS failed")
            raise error(sp, f"{where}: {len(vals)} values for {p.label}, but WAVELENGTHS has {n} line"
                        + ("s" if n != 1 else ""), "give one value for all lines, or one per line")
        b.values[p.label] = PerLine(tuple(vals))
    else:
        b.values[p.label] = tuple(vals)
    b.spans[p.label] = sp


def _need(p: Param) -> str:
    if p.kind in ("val",):
        return f"{p.label} ({dim_name(p.dim) if p.dim is not None else 'a value'})"
    if p.kind in ("vals", "perline"):
        what = dim_name(p.dim) if p.dim is not None else "values"
        if p.n:
            return f"{p.n} values for {p.label} ({what})"
        return f"{p.label} (one or more values: {what})"
    if p.kind == "refs":
        return f"{p.label} (one or more names)"
    return p.label


def _take_list(p: Param, cur: _Cursor, ctx, stop_kws: list, where: str):
    raw: list = []   # (item, count)
    while not cur.done():
        it = cur.peek()
        if p.n is not None and sum(c for _, c in raw) >= p.n:
            break
        if isinstance(it, A.Word) and match_keyword(it.name, stop_kws, it.span):
            break
        if isinstance(it, A.Repeat):
            cnt = ctx.eval(it.count)
            if isinstance(cnt, str) or cnt.dim not in (None, NONE) or cnt.value != int(cnt.value) or cnt.value < 1:
                raise error(it.count.span, "the count of n@v must be a whole number >= 1")
            if cnt.value > MAX_REPEAT:  # `1e9@0.9` would build a list of a billion values
                raise error(it.count.span, f"the count of n@v is {cnt.value:g}; at most {MAX_REPEAT} values")
            cur.next()
            raw.append((it.value, int(cnt.value)))
            continue
        if not _value_item(it):
            break
        if isinstance(it, A.Word) and not ctx.is_variable(it.name):
            # neither a keyword allowed here nor a variable: say so, with both kinds of hint
            from ..core.units import UNITS
            if it.name.lower() in UNITS:
                raise error(it.span, f"a unit ('{it.name}') must follow a number directly",
                            "write the number and its unit together, e.g. 5 mm")
            hint = did_you_mean(it.name, list(stop_kws) + list(ctx.variable_names()))
            if hint is None and _after_bare_number(cur):  # `5 furlongs`
                raise _unknown_unit(it, f"{where} takes " + ", ".join(stop_kws) + " here" if stop_kws else None)
            raise error(it.span, f"unknown keyword or undefined variable '{it.name}' in {where}", hint)
        cur.next()
        raw.append((it, 1))
    # a unit on the last value of a list applies to its bare numbers: WAVELENGTHS 450 550 650 NM
    trailing = None
    if len(raw) > 1 and isinstance(raw[-1][0], A.Num) and raw[-1][0].unit is not None and all(
            isinstance(r[0], A.Num) and r[0].unit is None for r in raw[:-1]):
        trailing = raw[-1][0].unit
    vals, spans = [], []
    if trailing is not None:  # a wrong unit is reported at the number that carries it (SHIFT 1 2 5 deg: the 5)
        _convert(p, raw[-1][0], ctx, where)
    for it, count in raw:
        if trailing is not None and isinstance(it, A.Num) and it.unit is None:
            it = A.Num(it.value, trailing, it.text, it.span)
        v = _convert(p, it, ctx, where)
        vals.extend([v] * count)
        spans.extend([it.span] * count)
    return vals, spans


def _convert(p: Param, it, ctx, where: str) -> float:
    v = ctx.eval(it)
    x = ctx.to_dim(v, p.dim, it.span)
    if isinstance(x, float) and not math.isfinite(x):  # a huge bare length times a large UNITS
        raise error(it.span, f"{where}: {p.label} is out of range")
    if p.integer:
        if x != int(x):
            raise error(it.span, f"{where}: {p.label} must be a whole number, got {x:g}")
        x = int(x)
    # a bare number is shown as written (x is in canonical units: EXTINCTION -0.001 under UNITS KM is -1e-06 /m)
    bare = p.dim not in (None, NONE) and not isinstance(v, str) and (v.dim is None or v.dim == NONE)
    _check(p, x, it.span, where, f"{v.value:g}" if bare else None)
    return x


def _check(p: Param, x, span, where, shown=None):
    if p.check is not None:
        msg = p.check(x)
        if msg:
            raise error(span, f"{where}: {p.label} {msg}, got {shown if shown is not None else format(x, 'g')}")
