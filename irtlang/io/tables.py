"""Reading small tabulated inputs (CSV or whitespace separated; '#' or '!!' comments; an optional header)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.diagnostics import Span, error


@dataclass(frozen=True)
class Table:
    data: np.ndarray     # (rows, cols), first column wavelength in nm, increasing
    path: Path

    @property
    def ncols(self) -> int:
        return self.data.shape[1]

    def interp(self, col: int, wavelengths_nm, span: Span) -> np.ndarray:
        w = self.data[:, 0]
        x = np.asarray(wavelengths_nm, float)
        if x.min() < w[0] or x.max() > w[-1]:
            raise error(span, f"{self.path.name} covers {w[0]:g}-{w[-1]:g} nm but the lines reach "
                        f"{x.min():g}-{x.max():g} nm")
        return np.interp(x, w, self.data[:, col])


def read_rows(path: Path, span: Span) -> list[tuple[int, list]]:
    """(line number, values) of every data row of a text table: CSV, ';' or blank separated; '#' and '!!'
    start comments; lines before the first numeric row are a header.  Equal row widths and finite values are
    checked here; what the columns mean is the caller's."""
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise error(span, f"cannot read '{path.name}': {e.strerror}") from None
    if b"\x00" in raw[:4096]:
        raise error(span, f"'{path.name}' is not a text table")
    rows = []
    for ln, line in enumerate(raw.decode("utf-8", "replace").splitlines(), 1):
        s = line.split("!!")[0].split("#")[0].strip()
        if not s:
            continue
        try:
            vals = [float(p) for p in s.replace(",", " ").replace(";", " ").split()]
        except ValueError:
            if not rows:
                continue  # a header line
            # the line itself is not quoted: a diagnostic never shows what a data file holds (issue 21)
            raise error(span, f"{path.name}:{ln}: a value that is not a number (after the first numeric row)") from None
        rows.append((ln, vals))
    if len({len(v) for _, v in rows}) > 1:
        raise error(span, f"'{path.name}': rows have different numbers of columns")
    if rows and not np.all(np.isfinite(np.array([v for _, v in rows], float))):
        raise error(span, f"'{path.name}' holds a value that is not finite")
    return rows


def read_table(path: Path, span: Span, min_cols: int = 2, max_cols: int = 2, what: str = "wavelength_nm, value") -> Table:
    rows = []
    for ln, vals in read_rows(path, span):
        if not min_cols <= len(vals) <= max_cols:
            raise error(span, f"{path.name}:{ln}: expected columns {what}, got {len(vals)} values")
        rows.append(vals)
    if len(rows) < 2:
        raise error(span, f"'{path.name}' needs at least two rows of {what}")
    data = np.array(rows, float)
    if np.any(np.diff(data[:, 0]) <= 0):
        raise error(span, f"'{path.name}': wavelengths must increase down the first column")
    return Table(data, path)
