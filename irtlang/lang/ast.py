"""The abstract syntax tree: frozen dataclasses, each with the Span it came from.

Expressions are shared by argument items and by expression contexts.  In an argument list a bare
identifier is a ``Word``: the command's signature decides whether it is a keyword, a name or a variable.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Union

from ..core.diagnostics import Span


# ---------------------------------------------------------------- expressions and argument items
@dataclass(frozen=True)
class Num:
    value: float
    unit: str | None          # lower-case unit name, or None for a bare number
    text: str
    span: Span


@dataclass(frozen=True)
class Word:
    name: str
    span: Span


@dataclass(frozen=True)
class Str:
    """A quoted string or name; ``parts`` alternate literal text and interpolated expressions."""

    text: str                                  # the raw text between the quotes
    parts: tuple                               # str | Expr, in order
    span: Span


@dataclass(frozen=True)
class Call:
    name: str
    args: tuple
    span: Span
    name_span: Span


@dataclass(frozen=True)
class BinOp:
    op: str                     # + - * / ^ == != < <= > >= AND OR
    left: "Expr"
    right: "Expr"
    span: Span
    op_span: Span


@dataclass(frozen=True)
class UnOp:
    op: str                     # - + NOT
    operand: "Expr"
    span: Span


@dataclass(frozen=True)
class Paren:
    """A parenthesized expression used as an argument: always a value, never a keyword."""

    expr: "Expr"
    span: Span


@dataclass(frozen=True)
class Repeat:
    """``n@v``: n copies of v."""

    count: "Expr"
    value: "Expr"
    span: Span


@dataclass(frozen=True)
class WordOp:
    """AND / OR / NOT standing as an argument item (``SELECT HIT(a) AND NOT HIT(b)``)."""

    op: str
    span: Span


Expr = Union[Num, Word, Str, Call, BinOp, UnOp, Paren, Repeat, WordOp]


# ---------------------------------------------------------------- statements
@dataclass(frozen=True)
class Assign:
    name: str
    name_span: Span
    expr: Expr
    span: Span


@dataclass(frozen=True)
class Command:
    head: str                   # as written (case kept)
    head_span: Span
    args: tuple
    span: Span


@dataclass(frozen=True)
class Do:
    var: str
    var_span: Span
    start: Expr
    stop: Expr
    step: Expr | None
    body: tuple
    span: Span


@dataclass(frozen=True)
class Branch:
    cond: Expr | None           # None for ELSE
    body: tuple
    span: Span


@dataclass(frozen=True)
class If:
    branches: tuple             # of Branch; the last may be ELSE
    span: Span


@dataclass(frozen=True)
class Macro:
    name: str
    params: tuple               # of str
    body: tuple
    span: Span
    name_span: Span


Stmt = Union[Assign, Command, Do, If, Macro]


@dataclass(frozen=True)
class Program:
    stmts: tuple
    source: object              # diagnostics.Source


def expr_span(e) -> Span:
    return e.span
