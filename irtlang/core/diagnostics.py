"""Source spans and compiler-style diagnostics.

Every diagnostic renders as::

    file.inr:12:7: error: expected a length, got 5 deg
       12 | SHIFT Z 5 deg
          |         ^^^^^
    hint: did you mean ...?

Semantic errors are collected (``DiagnosticBag``) so a whole script is reported in one pass; a syntax
error stops parsing at once (``IrtError`` carrying one diagnostic).
"""
from __future__ import annotations

import difflib
import unicodedata
from dataclasses import dataclass, field
from typing import Iterable, Sequence


@dataclass(frozen=True)
class Source:
    """A script's text and the name it is reported under."""

    name: str
    text: str

    def line(self, n: int) -> str:
        # lines end at "\n" only, as the lexer counts them (str.splitlines also splits at \f, \x85, \u2028 ...)
        lines = self.text.split("\n")
        return lines[n - 1].removesuffix("\r") if 1 <= n <= len(lines) else ""


@dataclass(frozen=True)
class Span:
    """A region of a source file: 1-based line and column, end exclusive."""

    source: Source | None
    line: int
    col: int
    end_line: int
    end_col: int

    @property
    def file(self) -> str:
        return self.source.name if self.source else "<input>"

    def __repr__(self) -> str:  # short, for debugging and AST dumps
        return f"Span({self.file}:{self.line}:{self.col})"

    def to(self, other: "Span") -> "Span":
        """The span from the start of self to the end of other."""
        return Span(self.source, self.line, self.col, other.end_line, other.end_col)


NO_SPAN = Span(None, 0, 0, 0, 0)


@dataclass(frozen=True)
class Diagnostic:
    span: Span
    message: str
    hint: str | None = None
    severity: str = "error"
    notes: tuple[tuple[Span, str], ...] = ()

    def render(self) -> str:
        s = self.span
        if s.source is None or s.line <= 0:
            head = f"{s.file}: {self.severity}: {self.message}"
            out = [head]
        else:
            out = [f"{s.file}:{s.line}:{s.col}: {self.severity}: {self.message}"]
            out.extend(_excerpt(s))
        for nspan, ntext in self.notes:
            if nspan.source is not None and nspan.line > 0:
                out.append(f"{nspan.file}:{nspan.line}:{nspan.col}: note: {ntext}")
                out.extend(_excerpt(nspan))
            else:
                out.append(f"note: {ntext}")
        if self.hint:
            out.append(f"hint: {self.hint}")
        return "\n".join(out)


def _excerpt(s: Span) -> list[str]:
    # a control character shows as a space, so that the caret stays under its column
    line, col = s.source.line(s.line), s.col
    cut = 0
    if len(line) > 200:  # a very long line: the 200 characters around the caret (limit `statement`)
        cut = max(0, min(col - 100, len(line) - 200))
        line = line[cut:cut + 200]
        col -= cut
    text = "".join(" " if unicodedata.category(c) in ("Cc", "Zl", "Zp") else c for c in line)
    gutter = f"{s.line:5d} | "
    width = (s.end_col - s.col) if s.end_line == s.line and s.end_col > s.col else 1
    width = max(1, min(width, max(1, len(text) - col + 1)))
    caret = " " * (len(gutter) - 2) + "| " + " " * (col - 1) + "^" * width
    return [gutter + text, caret]


class IrtError(Exception):
    """One or more diagnostics; raised out of the front end and caught by the command line."""

    def __init__(self, diagnostics: Diagnostic | Sequence[Diagnostic]):
        if isinstance(diagnostics, Diagnostic):
            diagnostics = [diagnostics]
        self.diagnostics = list(diagnostics)
        super().__init__(self.render())

    def render(self) -> str:
        return "\n".join(d.render() for d in self.diagnostics)


def error(span: Span, message: str, hint: str | None = None, notes=()) -> IrtError:
    return IrtError(Diagnostic(span, message, hint, notes=tuple(notes)))


@dataclass
class DiagnosticBag:
    """Collects semantic diagnostics, dropping exact repeats (a loop repeats its errors)."""

    items: list[Diagnostic] = field(default_factory=list)
    _seen: set = field(default_factory=set)

    def add(self, d: Diagnostic) -> None:
        key = (d.span.file, d.span.line, d.span.col, d.message)
        if key not in self._seen:
            self._seen.add(key)
            self.items.append(d)

    def extend(self, ds: Iterable[Diagnostic]) -> None:
        for d in ds:
            self.add(d)

    def __bool__(self) -> bool:
        return bool(self.items)


def did_you_mean(word: str, candidates: Iterable[str], n: int = 3) -> str | None:
    """A "did you mean" hint, or None when nothing is close."""
    cands = sorted({c for c in candidates if c})
    if not cands:
        return None
    lower = {c.lower(): c for c in cands}
    w = word.lower()
    close = difflib.get_close_matches(w, list(lower), n=n, cutoff=0.6)
    if not close:
        close = [c for c in lower if c.startswith(w[:3])][:n] if len(w) >= 3 else []
    if not close:
        return None
    shown = [lower[c] for c in close]
    if len(shown) == 1:
        return f"did you mean {shown[0]}?"
    return "did you mean " + ", ".join(shown[:-1]) + " or " + shown[-1] + "?"


# ---- run-time failures of a script (raised by the engine and the steps it runs; the CLI prints them as
# diagnostics, exit 1 and 3)
class MissingCapability(Exception):
    """The script needs a capability this build does not have: exit 3."""

    def __init__(self, span: Span, what: str, capability: str):
        self.span, self.what, self.capability = span, what, capability
        super().__init__(f"{what} needs {capability}, which this version of irtlang does not have yet")


class RuntimeFailure(Exception):
    """A step failed at run time (bad data, a missing result): reported at its span, exit 1."""

    def __init__(self, span: Span, message: str):
        self.span, self.message = span, message
        super().__init__(message)
