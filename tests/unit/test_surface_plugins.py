"""Generic tests over the surface registry (irtlang/plugins/surfaces): every kind keeps the plugin contract of
the registry's docstring, and its packed form, bounds, hit and normal agree with each other.

What is checked for every kind, on its EXAMPLE (a MESH: a box written here), without tracing (each plugin's small
njit functions compile in seconds):
* the contract's names are there; the kind's code is its registry index and the kernel's generated dispatch has
  a branch for it (under its FEATURE flag);
* ``pack`` fits the table (N_PAR, N_ASPH); the row the packer writes holds those values at the layout's columns;
* rays aimed from outside at points of the bounding sphere: every crossing ``hit`` reports lies inside
  ``bounds`` (an independent check of bounds against the intersection code), on the ray, with a unit
  ``normal``; starting again on that crossing with ``leaving`` does not find the departure point again.
These are consistency checks between a plugin's own functions, not physics: each kind's geometry has its oracle
tests (test_geometry, test_biconic, test_bvh, ...).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from irtlang.compile import specialize
from irtlang.compile.pack import Features, pack
from irtlang.kernels import layout
from irtlang.lang.diagnostics import Source
from irtlang.lang.interp import Interpreter
from irtlang.plugins.surfaces import CODES, REGISTRY

CONTRACT = ("KIND", "FORM", "EXAMPLE", "build", "FEATURE", "pack", "bounds", "size", "hit", "normal")


def _scene(tmp_path, kind):
    mod = REGISTRY[kind]
    if mod.EXAMPLE is None:         # MESH: a closed box
        import trimesh

        trimesh.creation.box(extents=(20.0, 10.0, 6.0)).export(tmp_path / "box.stl")
        frag = f"SURFACE\n  MESH '{tmp_path / 'box.stl'}'\nOBJECT 'thing'"
    else:
        frag = mod.EXAMPLE
    text = f"WAVELENGTHS 500 NM\n{frag}\n  INTERFACE REFLECT\nGRID DISK Z 1e6 1 RAYS 10\nSOURCE DIRECTION 0 0 -1\nTRACE\n"
    path = tmp_path / "s.inr"
    path.write_text(text)
    it = Interpreter(check_only=True)
    it.run_source(Source(str(path), text))
    assert not it.diags, it.diags.items
    return [s for s in it.steps if s.kind == "TRACE"][0].scene


@pytest.mark.parametrize("kind", list(REGISTRY))
def test_contract_and_dispatch(kind):
    mod = REGISTRY[kind]
    missing = [n for n in CONTRACT if not hasattr(mod, n)]
    assert not missing, f"{kind} lacks {missing}"
    assert mod.FEATURE is None or mod.FEATURE in Features.__dataclass_fields__
    assert list(REGISTRY).index(kind) == CODES[kind]
    src = specialize.surface_dispatch(specialize.all_features())
    assert f"if k == {CODES[kind]}:" in src and f"import hit as _hit_{CODES[kind]}" in src
    if mod.FEATURE is not None:     # a kernel without the kind's feature has no branch for it
        off = specialize.surface_dispatch(Features())
        assert f"_hit_{CODES[kind]}" not in off


@pytest.mark.parametrize("kind", list(REGISTRY))
def test_packed_row_bounds_hit_normal(kind, tmp_path):
    scene = _scene(tmp_path, kind)
    pk = pack(scene)
    f, si, mi = pk.surface_tables()
    mod = REGISTRY[kind]
    surf = next(iter(scene.objects.values())).surfaces[0]
    sp = mod.pack(surf)
    par, asph = tuple(sp.get("par", ())), tuple(sp.get("asph", ()))
    assert len(par) <= layout.N_PAR and len(asph) <= layout.N_ASPH
    j = 0
    assert si[j, layout.SI_KIND] == CODES[kind]
    # the scene turns on its kind's feature, so its specialized kernel has the kind's branch (and a scene without
    # the kind compiles none of its code: test_contract_and_dispatch)
    assert mod.FEATURE is None or getattr(pk.features, mod.FEATURE)
    assert f"import hit as _hit_{CODES[kind]}" in specialize.surface_dispatch(pk.features)
    assert tuple(f[j, layout.SF_PAR:layout.SF_PAR + len(par)]) == par
    assert tuple(f[j, layout.SF_ASPH:layout.SF_ASPH + len(asph)]) == asph
    assert si[j, layout.SI_NASPH] == len(asph)
    S = layout.Surfaces(f, si, mi, pk.bvh_bmin, pk.bvh_bmax, pk.bvh_child, pk.bvh_count, pk.bvh_tris, pk.bvh_ids,
                        pk.bvh_fn)
    cx, cy, cz, r = mod.bounds(surf)
    c = np.array([cx, cy, cz])
    if not math.isfinite(r):
        r = 10.0 * float(mod.size(surf))        # an unbounded surface: aim within a finite region of it
    rng = np.random.default_rng(7)
    found = 0
    for _ in range(300):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        v = rng.normal(size=3)
        v /= np.linalg.norm(v)
        target = c + r * rng.uniform() ** (1 / 3) * v
        o = target + 3.0 * r * u
        d = (target - o) / np.linalg.norm(target - o)
        t1, t2, face = mod.hit(S.f, S.i, S, j, *o, *d, 0.0, False)
        for t in (t1, t2):
            if not math.isfinite(t):
                continue
            p = o + t * d
            if not bool(si[j, layout.SI_APK] == layout.AP_NONE) and not _in_aperture(f, si, j, p):
                continue
            found += 1
            bounds = mod.bounds(surf)
            if math.isfinite(bounds[3]):
                assert np.linalg.norm(p - c) <= bounds[3] * (1 + 1e-9) + 1e-12, "a crossing outside bounds"
            n = np.array(mod.normal(S.f, S.i, S, j, *p, face))
            assert abs(np.linalg.norm(n) - 1.0) < 1e-12
            # leaving from this crossing: the departure point itself is not found again
            tl1, tl2, _ = mod.hit(S.f, S.i, S, j, *p, *d, 1e-9 * max(float(mod.size(surf)), 1.0), kind != "MESH")
            for tt in (tl1, tl2):
                assert not (0 <= tt < 1e-9 * r), f"{kind}: leaving found its own departure point (t = {tt})"
    assert found > 20, f"{kind}: only {found} crossings found aiming at its bounding sphere"


def _in_aperture(f, si, j, p):
    from irtlang.kernels.geometry import in_annulus, in_disk, in_ellipse, in_rect

    k, a0, a1 = si[j, layout.SI_APK], f[j, layout.SF_AP], f[j, layout.SF_AP + 1]
    x, y = p[0], p[1]
    return {layout.AP_RECT: lambda: in_rect(x, y, a0, a1), layout.AP_DISK: lambda: in_disk(x, y, a0),
            layout.AP_ANNULUS: lambda: in_annulus(x, y, a0, a1), layout.AP_ELLIPSE: lambda: in_ellipse(x, y, a0, a1)}[k]()
