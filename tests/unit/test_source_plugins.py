"""Generic tests over the source registry (irtlang/plugins/sources): every kind keeps the kernel contract of the
registry's docstring, and each Lambertian emitter's two ways of drawing a direction agree.

* Contract: a grid or an emitter has ``emit`` and its code is its index among those (the packer's
  ``EMITTER_CODES``); a direction kind has ``DIRECTION_CODES`` and ``direction``; the generated dispatch has a
  branch for each.
* ``emit`` puts the start point where the kind says (inside a GRID RECT's extent, a disk, on a sphere) with a
  unit emission axis (a sphere's: its outward normal).
* Unbiasedness (an independent identity, not the code's own formula): a direction drawn uniformly over the whole
  sphere and weighted by ``toward(cos, 4 pi)`` must carry on average what ``lambert``'s own sampling carries (its
  weight factor): both estimate the same emitted flux.  Checked to 5 standard errors for each emitter, with and
  without a CONE.  ``lambert``'s directions stay inside the cone.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from irtlang.compile import specialize
from irtlang.kernels import layout
from irtlang.plugins.sources import EMITTER_CODES, REGISTRY
from irtlang.plugins.sources import _common


def _table(kind_code, par, random=layout.SAMPLE_RANDOM):
    S = 1
    P = np.zeros((S, layout.N_SRC_PAR))
    P[0, :len(par)] = par
    return layout.Sources(kind=np.array([kind_code], np.int32), dir=np.array([layout.DIR_LAMBERT], np.int32), par=P,
                          R=np.eye(3).reshape(1, 9), Th=np.zeros((1, 3)), Tl=np.zeros((1, 3)),
                          n=np.array([100], np.int64), off=np.zeros(1, np.int64), w=np.ones((1, 1)),
                          random=np.array([random], np.int32), toward=np.full(1, -1, np.int32),
                          pts=np.zeros((0, 2)), pts_off=np.zeros(1, np.int64), lmap=np.zeros((1, 1), np.int64))


def test_contract_and_dispatch():
    src = specialize.source_dispatch()
    emitters = [k for k, m in REGISTRY.items() if hasattr(m, "emit")]
    assert list(EMITTER_CODES) == emitters and list(EMITTER_CODES.values()) == list(range(len(emitters)))
    for k, m in REGISTRY.items():
        if m.ROLE in ("grid", "emitter"):
            assert hasattr(m, "emit"), k
            assert f"_emit_{EMITTER_CODES[k]}(SRC" in src
        else:
            assert m.ROLE == "direction" and hasattr(m, "direction") and m.DIRECTION_CODES, k
            assert f"import direction as" in src and all(f"dk == {c}" in src for c in m.DIRECTION_CODES)
    codes = [c for m in REGISTRY.values() for c in getattr(m, "DIRECTION_CODES", ())]
    assert sorted(codes) == sorted(set(codes)), "a direction code claimed twice"


@pytest.mark.parametrize("kind", list(REGISTRY))
def test_a_kernel_dispatches_over_its_scenes_source_kinds_only(kind):
    """compile.pack.source_kinds_of maps the packed codes back to the kinds (each registered kind alone, and a
    collimated grid: GRID DISK + SOURCE DIRECTION), and the dispatch generated for a kind set has those kinds'
    branches and no other (a smaller kernel to compile: docs/architecture.md, "Compile time")."""
    from irtlang.compile.pack import source_kinds_of

    m = REGISTRY[kind]
    if hasattr(m, "emit"):
        assert source_kinds_of([EMITTER_CODES[kind]], [layout.DIR_LAMBERT]) == (kind,)
    else:
        for c in m.DIRECTION_CODES:
            assert source_kinds_of([], [c]) == (kind,)
    pair = source_kinds_of([EMITTER_CODES["GRID DISK"]], [layout.DIR_COLLIMATED])
    assert pair == ("GRID DISK", "SOURCE DIRECTION")
    src = specialize.source_dispatch((kind,))
    for k, other in REGISTRY.items():
        assert (f"import {'emit' if hasattr(other, 'emit') else 'direction'} as" in src
                and other.__name__ in src) == (k == kind), k


# kind, par, a check of the start point
CASES = {
    "GRID RECT": ((-2.0, 3.0, -1.0, 5.0, 10, 20, 0, 0, 1.0), lambda x, y, z: -2 <= x <= 3 and -1 <= y <= 5 and z == 0),
    "GRID DISK": ((4.0,), lambda x, y, z: math.hypot(x, y) <= 4.0 and z == 0),
    "EMITTING SPHERE": ((7.0,), lambda x, y, z: abs(math.sqrt(x * x + y * y + z * z) - 7.0) < 1e-12),
    "EMITTING DISK": ((3.0, math.radians(30)), lambda x, y, z: math.hypot(x, y) <= 3.0 and z == 0),
    "EMITTING POINT": ((0.0, math.radians(50), 0.0, 0.6, 0.8), lambda x, y, z: (x, y, z) == (0, 0, 0)),
}


@pytest.mark.parametrize("kind", list(EMITTER_CODES))
def test_emit_puts_rays_where_the_kind_says(kind):
    par, inside = CASES[kind]
    m = REGISTRY[kind]
    SRC = _table(EMITTER_CODES[kind], par)
    rng = np.random.default_rng(3)
    for q in range(200):
        u0, u1 = rng.uniform(size=2)
        x, y, z, ax, ay, az = m.emit(SRC, 0, q, u0, u1)
        assert inside(x, y, z), (kind, x, y, z)
        assert abs(math.sqrt(ax * ax + ay * ay + az * az) - 1.0) < 1e-12
        if kind == "EMITTING SPHERE":
            assert np.allclose(np.array([ax, ay, az]) * 7.0, [x, y, z], atol=1e-12)


@pytest.mark.parametrize("kind,cone", [("EMITTING SPHERE", None), ("EMITTING DISK", 90), ("EMITTING DISK", 25),
                                       ("EMITTING POINT", 180), ("EMITTING POINT", 40), ("GRID RECT", None)])
def test_toward_and_lambert_carry_the_same_flux(kind, cone):
    m = REGISTRY[kind]
    par = list(CASES[kind][0])
    if cone is not None:
        par[1] = math.radians(cone)
    SRC = _table(EMITTER_CODES[kind], par)
    lam = getattr(m, "lambert", _common.lambert)
    tow = getattr(m, "toward", _common.toward)
    rng = np.random.default_rng(11)
    N = 200_000
    # lambert: the weight factor it applies, and its directions (about +z) inside the cone
    wl = np.empty(N)
    zs = np.empty(N)
    for k in range(N // 20):
        x, y, z, f = lam(SRC, 0, *rng.uniform(size=2))
        wl[k], zs[k] = f, z
        assert abs(x * x + y * y + z * z - 1.0) < 1e-12
    n_l = N // 20
    if cone is not None and cone < 90 or kind == "EMITTING POINT" and cone < 180:
        assert zs[:n_l].min() >= math.cos(math.radians(cone)) - 1e-12
    # toward with a cone holding the whole sphere (omega = 4 pi): directions uniform over the sphere
    c = rng.uniform(-1.0, 1.0, size=N)          # cos to the axis of a uniform direction
    wt = np.array([tow(SRC, 0, float(ci), 4.0 * math.pi) for ci in c])
    mean_t, se_t = wt.mean(), wt.std() / math.sqrt(N)
    mean_l = wl[:n_l].mean()                    # a constant per kind (no variance)
    assert np.all(wl[:n_l] == wl[0])
    assert abs(mean_t - mean_l) < 5 * se_t + 1e-12, (kind, cone, mean_t, se_t, mean_l)
