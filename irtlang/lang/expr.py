"""Evaluation of expressions with units.

Values are ``Quantity`` (canonical units, or bare) or ``str``.  Rules:

* ``+ - < <= > >= == !=``: both operands of one dimension; a bare operand takes the other's default unit
  (UNITS for a length, degrees for an angle, the canonical unit otherwise).
* ``* /``: dimensions multiply; a bare operand is a pure scale factor. ``^`` needs a pure exponent.
* ``sin cos tan`` read a bare argument as degrees; ``asin acos atan atan2`` return angles (shown in deg).
* ``floor ceil round`` act on the value in its display unit (``floor(2.5 mm)`` is 2 mm with UNITS MM).
* Comparisons and AND/OR/NOT give 1 or 0; comparisons treat values within a relative 1e-12 as equal.
"""
from __future__ import annotations

import math
from typing import Callable

from . import ast as A
from ..core.diagnostics import Span, did_you_mean, error
from ..core.units import ANGLE, LENGTH, NONE, UNITS, Quantity, dim_name, quantity

Value = Quantity | str

CONSTANTS = {"PI": Quantity(math.pi), "E": Quantity(math.e)}
FUNCTIONS = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sqrt", "exp", "log", "log10", "abs",
             "min", "max", "floor", "ceil", "round")


class Env:
    """What an expression can see: variables and the unit of bare lengths."""

    def __init__(self, lookup: Callable[[str], Value | None], length_unit: Callable[[], str],
                 names: Callable[[], list[str]]):
        self.lookup = lookup
        self.length_unit = length_unit
        self.names = names

    def default_factor(self, dim) -> float:
        if dim == LENGTH:
            return UNITS[self.length_unit().lower()][0]
        if dim == ANGLE:
            return math.pi / 180.0
        if dim is not None and dim[0] != 0 and all(d == 0 for d in dim[1:]):
            return UNITS[self.length_unit().lower()][0] ** dim[0]
        return 1.0


def evaluate(e, env: Env) -> Value:
    if isinstance(e, A.Num):
        if e.unit is not None and e.unit not in UNITS:
            raise error(e.span, f"unknown unit '{e.unit}'", did_you_mean(e.unit, UNITS))
        return _finite(quantity(e.value, e.unit), e.span, "number out of range")
    if isinstance(e, A.Word):
        v = env.lookup(e.name)
        if v is None:
            c = CONSTANTS.get(e.name.upper())
            if c is not None:
                return c
            failed = getattr(env, "failed_var", None)
            if failed is not None:
                failed(e.name, e.span)  # raises for a variable whose assignment failed: no cascade
            raise error(e.span, f"undefined variable '{e.name}'",
                        did_you_mean(e.name, list(env.names()) + list(CONSTANTS)))
        return v
    if isinstance(e, A.Str):
        return interpolate(e, env)
    if isinstance(e, A.Paren):
        return evaluate(e.expr, env)
    if isinstance(e, A.UnOp):
        v = evaluate(e.operand, env)
        if e.op == "NOT":
            return Quantity(0.0 if truth(v, e.span) else 1.0)
        q = _num(v, e.operand.span)
        return Quantity(-q.value if e.op == "-" else q.value, q.dim)
    if isinstance(e, A.BinOp):
        return _finite(_binop(e, env), e.span, "arithmetic overflow: the result is not a finite number")
    if isinstance(e, A.Call):
        return _finite(_call(e, env), e.span, "arithmetic overflow: the result is not a finite number")
    if isinstance(e, A.Repeat):
        raise error(e.span, "n@v repeats values in an argument list; it is not a value by itself")
    if isinstance(e, A.WordOp):
        raise error(e.span, f"{e.op} belongs inside an expression or a SELECT predicate")
    raise error(getattr(e, "span", None), f"cannot evaluate {type(e).__name__}")  # pragma: no cover


def _finite(v: Value, span: Span, message: str) -> Value:
    """Values are always finite: 1e400, 1e200 * 1e200 and the like are errors where they are written."""
    if isinstance(v, Quantity) and not math.isfinite(v.value):
        raise error(span, message)
    return v


def truth(v: Value, span: Span) -> bool:
    if isinstance(v, str):
        raise error(span, "a string is not a condition")
    return v.value != 0.0


def _num(v: Value, span: Span) -> Quantity:
    if isinstance(v, str):
        raise error(span, f"expected a number, got the string '{v}'")
    return v


def _align(a: Quantity, b: Quantity, env: Env, span: Span, what: str) -> tuple[float, float, object]:
    """Bring two quantities to one dimension for + - and comparisons."""
    if a.dim == b.dim:
        return a.value, b.value, a.dim
    if a.dim is None or a.dim == NONE:
        if b.dim is None or b.dim == NONE:
            return a.value, b.value, NONE
        return a.value * env.default_factor(b.dim), b.value, b.dim
    if b.dim is None or b.dim == NONE:
        return a.value, b.value * env.default_factor(a.dim), a.dim
    raise error(span, f"cannot {what} {dim_name(a.dim)} and {dim_name(b.dim)} "
                      f"({a.describe(env.length_unit())} and {b.describe(env.length_unit())})")


def _binop(e: A.BinOp, env: Env) -> Value:
    if e.op in ("AND", "OR"):
        lv = truth(evaluate(e.left, env), e.left.span)
        if e.op == "AND" and not lv:
            return Quantity(0.0)
        if e.op == "OR" and lv:
            return Quantity(1.0)
        return Quantity(1.0 if truth(evaluate(e.right, env), e.right.span) else 0.0)
    lv, rv = evaluate(e.left, env), evaluate(e.right, env)
    if isinstance(lv, str) or isinstance(rv, str):
        if e.op == "+" and isinstance(lv, str) and isinstance(rv, str):
            return _short(lv + rv, e.span, env)
        if e.op in ("==", "!=") and isinstance(lv, str) and isinstance(rv, str):
            return Quantity(float((lv.lower() == rv.lower()) == (e.op == "==")))
        raise error(e.op_span, f"'{e.op}' does not apply to a string")
    a, b = lv, rv
    if e.op in ("+", "-"):
        x, y, d = _align(a, b, env, e.op_span, "add" if e.op == "+" else "subtract")
        r = x + y if e.op == "+" else x - y
        return Quantity(r, None if (a.dim is None and b.dim is None) else d)
    if e.op in ("==", "!=", "<", "<=", ">", ">="):
        x, y, _ = _align(a, b, env, e.op_span, "compare")
        # values within a relative 1e-12 are equal: a unit conversion must not decide a comparison
        # (asin(0.5) is 30 degrees, although pi/6 and 30 * pi/180 differ in the last bit)
        eq = math.isclose(x, y, rel_tol=1e-12)
        r = {"==": eq, "!=": not eq, "<": x < y and not eq, "<=": x < y or eq, ">": x > y and not eq,
             ">=": x > y or eq}[e.op]
        return Quantity(1.0 if r else 0.0)
    if e.op == "*":
        return Quantity(a.value * b.value, _dmul(a.dim, b.dim, 1))
    if e.op == "/":
        if b.value == 0.0:
            raise error(e.right.span, "division by zero")
        return Quantity(a.value / b.value, _dmul(a.dim, b.dim, -1))
    if e.op == "^":
        if b.dim not in (None, NONE):
            raise error(e.right.span, f"an exponent must be a pure number, got {b.describe()}")
        if a.dim in (None, NONE):
            try:
                r = a.value ** b.value
            except (OverflowError, ZeroDivisionError):
                raise error(e.span, "arithmetic overflow or 0 to a negative power") from None
            if isinstance(r, complex):
                raise error(e.span, "a negative number to a fractional power")
            return Quantity(float(r), a.dim)
        if b.value != int(b.value):
            raise error(e.right.span, f"{dim_name(a.dim)} can only be raised to an integer power")
        n = int(b.value)
        try:
            r = a.value ** n
        except (OverflowError, ZeroDivisionError):
            raise error(e.span, "arithmetic overflow or 0 to a negative power") from None
        return Quantity(r, tuple(x * n for x in a.dim))
    raise error(e.op_span, f"unknown operator {e.op}")  # pragma: no cover


def _dmul(da, db, sign):
    if da is None and db is None:
        return None
    da = da or NONE
    db = db or NONE
    return tuple(x + sign * y for x, y in zip(da, db))


def _angle_rad(q: Quantity, span: Span) -> float:
    if q.dim in (None, NONE):
        return math.radians(q.value)
    if q.dim == ANGLE:
        return q.value
    raise error(span, f"expected an angle, got {q.describe()}")


def _pure(q: Quantity, span: Span, fname: str) -> float:
    if q.dim not in (None, NONE):
        raise error(span, f"{fname}() needs a pure number, got {q.describe()}")
    return q.value


def _call(e: A.Call, env: Env) -> Value:
    name = e.name.lower()
    if name not in FUNCTIONS:
        raise error(e.name_span, f"unknown function '{e.name}'", did_you_mean(e.name, FUNCTIONS))
    args = [_num(evaluate(a, env), a.span) for a in e.args]
    nargs = {"atan2": 2}.get(name, None if name in ("min", "max") else 1)
    if nargs is not None and len(args) != nargs:
        raise error(e.span, f"{name}() takes {nargs} argument{'s' if nargs > 1 else ''}, got {len(args)}")
    if nargs is None and not args:
        raise error(e.span, f"{name}() needs at least one argument")
    sp = e.args[0].span if e.args else e.span
    try:
        if name in ("sin", "cos", "tan"):
            return Quantity(getattr(math, name)(_angle_rad(args[0], sp)))
        if name in ("asin", "acos"):
            x = _pure(args[0], sp, name)
            if not -1.0 <= x <= 1.0:
                raise error(sp, f"{name}() needs a value in [-1, 1], got {x:g}")
            return Quantity(getattr(math, name)(x), ANGLE)
        if name == "atan":
            return Quantity(math.atan(_pure(args[0], sp, name)), ANGLE)
        if name == "atan2":
            y, x, _ = _align(args[0], args[1], env, e.span, "compare")
            return Quantity(math.atan2(y, x), ANGLE)
        if name == "sqrt":
            q = args[0]
            if q.value < 0:
                raise error(sp, "sqrt() of a negative number")
            if q.dim in (None, NONE):
                return Quantity(math.sqrt(q.value), q.dim)
            if any(d % 2 for d in q.dim):
                raise error(sp, f"sqrt() of {q.describe()} has no unit")
            return Quantity(math.sqrt(q.value), tuple(d // 2 for d in q.dim))
        if name in ("exp", "log", "log10"):
            x = _pure(args[0], sp, name)
            if name != "exp" and x <= 0:
                raise error(sp, f"{name}() of a number <= 0")
            return Quantity(getattr(math, name)(x))
        if name == "abs":
            return Quantity(abs(args[0].value), args[0].dim)
        if name in ("min", "max"):
            best = args[0]
            for q in args[1:]:
                x, y, d = _align(best, q, env, e.span, "compare")
                if (y < x) if name == "min" else (y > x):
                    best = q if q.dim is not None or best.dim is None else Quantity(y, d)
                elif best.dim is None and q.dim is not None:
                    best = Quantity(x, d)
            return best
        # floor ceil round: in the display unit of the dimension
        q = args[0]
        f = env.default_factor(q.dim) if q.dim not in (None, NONE) else 1.0
        # round: halves away from zero (as Fortran NINT and C round), not Python's round-half-to-even
        fn = {"floor": math.floor, "ceil": math.ceil,
              "round": lambda x: math.copysign(math.floor(abs(x)) + (abs(x) % 1.0 >= 0.5), x)}[name]
        return Quantity(float(fn(q.value / f)) * f, q.dim)
    except OverflowError:
        raise error(e.span, f"{name}() overflows") from None


def _limits(env: Env):
    lim = getattr(env, "limits", None)
    if lim is None:
        from ..limits import current
        lim = env.limits = current()
    return lim


def _short(text: str, span: Span, env: Env) -> str:
    """A string value no longer than the limit `string` (irtlang/limits.py)."""
    lim = _limits(env)
    over = lim.exceeded("string", len(text))
    if over:
        raise error(span, f"this string would be too long: {over}", lim.hint("string"))
    return text


def _check_spec(spec: str, span: Span, env: Env) -> None:
    """Widths and precisions of a format ('{x:>4000000000}' would build a 4 GB string) within the limit
    `format`."""
    import re

    lim = _limits(env)
    for m in re.finditer(r"[0-9]+", spec):
        over = lim.exceeded("format", int(m.group()))
        if over:
            raise error(span, f"format '{spec}': a width or precision of {over}", lim.hint("format"))


def format_value(v: Value, env: Env, spec: str | None = None) -> str:
    from ..core.units import fmt_number, DISPLAY

    if isinstance(v, str):
        return v
    x = v.value
    if v.dim not in (None, NONE):
        if v.dim in DISPLAY:
            x = v.value / DISPLAY[v.dim][1]
        else:
            x = v.value / env.default_factor(v.dim)
    if spec:
        if spec[-1:] in ("d", "x", "X", "o", "b", "c", "n") and math.isfinite(x) and x == int(x):
            x = int(x)  # a whole number takes the integer formats ('{i:03d}')
        return format(x, spec)  # ValueError for a bad spec: reported by interpolate()
    return fmt_number(x)


def interpolate(s: A.Str, env: Env) -> str:
    out = []
    for p in s.parts:
        if out and len(out) % 16 == 0:   # many long pieces: stop before they are joined
            _short("".join(out), s.span, env)
        if isinstance(p, str):
            out.append(p)
        elif isinstance(p, tuple):
            _, ex, spec = p
            _check_spec(spec, s.span, env)
            v = evaluate(ex, env)
            try:
                out.append(format_value(v, env, spec))
            except (ValueError, OverflowError, TypeError):   # OverflowError: '{x:c}' of a large x
                raise error(s.span, f"bad format '{spec}' in an interpolation",
                            "use a Python format such as :.3f") from None
        else:
            out.append(format_value(evaluate(p, env), env))
    return _short("".join(out), s.span, env)
