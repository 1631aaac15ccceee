"""Specialized kernels (one per scene feature set) agree with the all-features kernel the other tests use, and a
mirrors-only scene's kernel is compiled without refraction, scattering, maps, volumes or records."""
from pathlib import Path

import numpy as np
import pytest

from irtlang.compile import specialize
from irtlang.compile.pack import pack
from irtlang.lang.diagnostics import Source
from irtlang.lang.interp import Interpreter
from irtlang.tracer import Progress, run_trace

SCRIPT = """
WAVELENGTHS 500 600 NM
SEED 5
MEDIUM glass INDEX 1.5 1.49
SURFACE
  CONIC Z 0 RADIUS 2000 CONIC -1 DISK 100
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z 600 DISK 30
OBJECT window
  INTERFACE TRANSMIT AIR glass
SURFACE
  PLANE Z 1000 RECT 5 5
OBJECT fpa
  DETECTOR PIXELS 9 9
GRID DISK Z 500 100 RAYS 4000 RANDOM
SOURCE DIRECTION 0 0 -1
TRACE
"""


def _scene(text):
    it = Interpreter(check_only=True)
    it.run_source(Source("spec.inr", text))
    assert not it.diags, it.diags.items
    return [s for s in it.steps if s.kind == "TRACE"][0].scene


def _trace(scene, monkeypatch, mode):
    monkeypatch.setenv("IRT_KERNEL_FEATURES", mode)
    return run_trace(scene, seed=5, level=20, halt=0.0, progress=Progress(0, enabled=False))


def test_specialized_and_all_features_kernels_agree(monkeypatch):
    scene = _scene(SCRIPT)
    a = _trace(scene, monkeypatch, "specialized")
    b = _trace(scene, monkeypatch, "all")
    # the same paths: the same random numbers and decisions; sums may differ only by rounding
    np.testing.assert_allclose(a.ledger, b.ledger, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(a.images["fpa"][0], b.images["fpa"][0], rtol=1e-12, atol=1e-15)


def test_mirrors_only_scene_compiles_no_other_features(monkeypatch):
    monkeypatch.setenv("IRT_KERNEL_FEATURES", "specialized")
    scene = _scene(SCRIPT.replace("  INTERFACE TRANSMIT AIR glass", "  INTERFACE ABSORB"))
    pk = pack(scene)
    f = pk.features
    assert f.conic and not (f.refract or f.scatter or f.maps or f.volume or f.mesh or f.records or f.precise
                            or f.importance or f.absorb_media)
    mod = specialize.kernel_module(f)
    assert (mod.F_REFRACT, mod.F_SCATTER, mod.F_MAPS, mod.F_VOLUME, mod.F_MESH, mod.F_RECORDS) == (False,) * 6
    assert mod.F_CONIC is True
    # a forward trace compiles no camera sampling, and only its own source kinds' dispatch
    assert not f.camera and mod.F_CAMERA is False
    assert f.source_kinds == ("GRID DISK", "SOURCE DIRECTION")
    assert "emitting_sphere" not in Path(mod.__file__).read_text()
