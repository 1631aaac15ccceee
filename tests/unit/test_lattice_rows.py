"""A regular GRID DISK is a square lattice clipped to the disk.  The tracer no longer stores its points: it
keeps one row table (irtlang.compile.pack.disk_lattice_rows) and turns each ray index into its point.  The
oracle is the direct construction: every lattice point (a h, b h) with x^2 + y^2 <= R^2, in row order."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from irtlang.compile.pack import disk_lattice_rows

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "physics"))
from _trace_util import ledger_gap, trace_text  # noqa: E402


def _brute(radius, rays):
    h = math.sqrt(math.pi * radius ** 2 / rays)
    m = int(math.ceil(radius / h)) + 1
    xs = np.arange(-m, m + 1) * h
    X, Y = np.meshgrid(xs, xs)
    keep = X ** 2 + Y ** 2 <= radius ** 2
    return np.stack([X[keep], Y[keep]], axis=1), h


def _points(table, h):
    out = []
    for k in range(len(table) - 1):
        start, end = int(table[k, 0]), int(table[k + 1, 0])
        amax = (end - start - 1) // 2
        out += [(a * h, table[k, 1] * h) for a in range(-amax, amax + 1)]
    return np.array(out)


@pytest.mark.parametrize("radius,rays", [(0.15, 1000), (1.0, 1), (2.5, 77), (0.3, 20000), (7.0, 12345)])
def test_row_table_is_the_lattice(radius, rays):
    table, h = disk_lattice_rows(radius, rays)
    ref, h_ref = _brute(radius, rays)
    assert h == h_ref
    assert int(table[-1, 0]) == len(ref)
    assert np.array_equal(_points(table, h), ref)          # the same points, the same order, bit for bit
    # a row is symmetric: its point count is odd
    assert np.all(np.diff(table[:, 0]) % 2 == 1)


def test_traced_start_points_are_the_lattice(tmp_path):
    """The start points the kernel computes from the row table are the lattice's, ray by ray."""
    res = trace_text(tmp_path, """UNITS MM
WAVELENGTHS 550 NM
SURFACE
  PLANE Z 0 DISK 10
OBJECT target
  INTERFACE ABSORB
GRID DISK Z 5 3 RAYS 500
SOURCE DIRECTION 0 0 -1
TRACE
""")
    ref, _h = _brute(3e-3, 500)
    st = res.records["start"]
    assert len(st) == len(ref)
    got = st[np.lexsort((st[:, 0], st[:, 1]))]
    assert np.array_equal(got, ref)
    assert ledger_gap(res) < 1e-12
