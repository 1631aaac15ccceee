"""irtlang.kernels.numba_speedups: the faster compile passes compute what Numba's own compute.

The oracle is Numba itself: its original functions (kept by ``install``) run on the same intermediate code as
the replacements, here the kernel template's largest functions (thousands of blocks and variables) and a
small one.  A compile with the replacements must also give the same machine results as plain Python.
"""
from __future__ import annotations

import collections

import numba
import numpy as np
import pytest
from numba.core import analysis, compiler, ir_utils, types

from irtlang.kernels import numba_speedups as ns

pytestmark = pytest.mark.skipif(not ns.installed, reason="Numba is not the version the speedups were checked on")


def _irs():
    from irtlang.kernels import geometry, trace_kernel

    def small(a, n):
        s = 0.0
        t = a
        for i in range(n):
            u = t
            if i % 3 == 0:
                s += u[i]
            else:
                t = a
                s -= t[i] * 2
        return s

    for fn in (small, geometry.hit_conic_plain.py_func, trace_kernel._nearest.py_func,
               trace_kernel.trace_batch.py_func):
        yield fn.__name__, compiler.run_frontend(fn)


@pytest.mark.parametrize("name,func_ir", list(_irs()), ids=lambda v: v if isinstance(v, str) else "")
def test_same_as_numba(name, func_ir):
    blocks = func_ir.blocks
    assert ns._ORIGINAL, "install() replaced nothing"
    if "compute_live_map" in ns._ORIGINAL:
        cfg = analysis.compute_cfg_from_blocks(blocks)
        ud = analysis.compute_use_defs(blocks)
        want = ns._ORIGINAL["compute_live_map"](cfg, blocks, ud.usemap, ud.defmap)
        got = ns.compute_live_map(cfg, blocks, ud.usemap, ud.defmap)
        assert got == want
        assert any(want.values())
    if "copy_propagate" in ns._ORIGINAL:
        typemap = collections.defaultdict(lambda: types.float64)
        want = ns._ORIGINAL["copy_propagate"](blocks, typemap)
        got = ns.copy_propagate(blocks, typemap)
        assert got == want
        assert any(want[1].values())      # the function has copies to propagate: not an empty comparison


def test_installed_in_the_modules_numba_calls_from():
    from numba.core import inline_closurecall
    from numba.parfors import parfor

    if "copy_propagate" in ns.installed:
        assert ir_utils.copy_propagate is ns.copy_propagate is parfor.copy_propagate
    if "compute_live_map" in ns.installed:
        assert analysis.compute_live_map is ns.compute_live_map is parfor.compute_live_map
        assert ir_utils.compute_live_map is ns.compute_live_map
    if "inline_ir" in ns.installed:
        assert inline_closurecall.InlineWorker.inline_ir is not ns._ORIGINAL["inline_ir"]


@numba.njit(inline="always")
def _helper(a, i, x):
    if x > 0.5:
        a[i] += x * x
        return x - 1.0
    return x / 3.0


@numba.njit(parallel=True)
def _inlined_loop(a, xs):
    out = np.empty(xs.shape[0])
    for i in numba.prange(xs.shape[0]):
        y = _helper(a, i, xs[i])
        y = _helper(a, i, y + 0.7)
        out[i] = y
    return out


def test_compiled_with_the_speedups_equals_python():
    xs = np.random.default_rng(3).random(50)
    a1 = np.zeros(50)
    a2 = np.zeros(50)
    got = _inlined_loop(a1, xs)
    want = np.empty(50)
    for i in range(50):
        y = _helper.py_func(a2, i, xs[i])
        want[i] = _helper.py_func(a2, i, y + 0.7)
    assert np.array_equal(got, want) and np.array_equal(a1, a2)
