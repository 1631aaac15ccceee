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
    assert not f.hero and mod.F_HERO is False
    assert f.source_kinds == ("GRID DISK", "SOURCE DIRECTION")
    assert "emitting_sphere" not in Path(mod.__file__).read_text()


# a planet seen by a camera with four filters and by a one-pixel pupil: the flagship's two camera traces in small
CAMERAS = """UNITS M
WAVELENGTHS RANGE 400 700 16 NM
SPECTRUM red TABLE '{grass}'
MODEL paint LAMBERTIAN 0.6
SURFACE
  SPHERE 0 0 0 100
OBJECT ball
  INTERFACE ABSORB
  SCATTER MODEL paint
SURFACE
  PLANE Z 1e5 RECT 0.01 0.01
OBJECT cam
  INTERFACE ABSORB
  DETECTOR PIXELS 8 FILTERS red red red red
SURFACE
  PLANE Z 1e5 DISK 0.25
OBJECT pupil
  DETECTOR PIXELS 1
EMITTING SPHERE 8.66e8 0 5e8 1e6 RAYS 1
TRACE CAMERA cam AIM ball SPECTRAL 4 {image}
EMITTING SPHERE 8.66e8 0 5e8 1e6 RAYS 1
TRACE CAMERA pupil AIM ball DIRECTIONS 2 {pupil}
"""


@pytest.mark.parametrize("image, pupil, hero", [("HERO 2", "HERO 4", (True, True)), ("", "", (False, False)),
                                                ("", "HERO 4", (False, True))])
def test_only_a_trace_with_hero_wavelengths_compiles_their_code(image, pupil, hero, monkeypatch):
    """HERO's code (about a third of a camera kernel's first compile) is in a kernel only where a camera source
    uses it (Features.hero, F_HERO); the flagship's image and pupil traces, both with HERO, share one kernel."""
    from irtlang.ahead import plan

    monkeypatch.setenv("IRT_KERNEL_FEATURES", "specialized")
    grass = Path(__file__).resolve().parents[2] / "docs" / "examples" / "grass.csv"
    it = Interpreter(check_only=True)
    it.run_source(Source("cams.inr", CAMERAS.format(grass=grass, image=image, pupil=pupil)))
    assert not it.diags, it.diags.items
    feats = [pack(sc, records=r, history=h).features for sc, r, h, _lv in plan(it.steps)]
    assert [f.hero for f in feats] == list(hero) and all(f.camera for f in feats)
    assert (feats[0].key() == feats[1].key()) == (hero[0] == hero[1])
    assert [specialize.kernel_module(f).F_HERO for f in feats] == list(hero)


# A scattering scene for the shares of a hit (R, T, diffuse, slab keep): a Lambertian ground, an atmosphere shell on
# an index step whose fraction map picks a cloud slab (HG) over a Rayleigh slab, and a gated shell above (OPAQUE
# WHERE), every model sending rays TOWARD a far disk, so that both a scattered ray's and a ray aimed at the target's
# shares (the fraction map in expectation, _nee_map_mix) are taken at every kind of hit.
SHARES_SCRIPT = """UNITS KM
WAVELENGTHS 450 650 NM
SEED 9
MEDIUM gas INDEX 1.0003 1.0002
MODEL ground LAMBERTIAN 0.3
MODEL air RAYLEIGH TAU 0.2 0.05 ALBEDO 1
MODEL cloud HG G 0.85 TAU 5 ALBEDO 0.999 ORDERS 4
MAP frac LATLON '{frac}'
MAP gate LATLON '{gate}'
SURFACE
  SPHERE 0 0 0 6000
OBJECT ground
  INTERFACE ABSORB
  SCATTER MODEL ground TOWARD target
SURFACE
  SPHERE 0 0 0 6100
OBJECT shell
  INTERFACE TRANSMIT gas AIR
  SCATTER MAP frac MODELS cloud TOWARD target
  SCATTER MODEL air TOWARD target
SURFACE
  SPHERE 0 0 0 6200
OBJECT veil
  INTERFACE TRANSMIT AIR AIR
  OPAQUE WHERE gate FROM 0.5 TO 1.5
  SCATTER MODEL ground TOWARD target
SURFACE
  PLANE X 1e6 RECT 2000 2000
OBJECT target
  INTERFACE ABSORB
  DETECTOR PIXELS 5 5
GRID RECT X 7000 -6300 6300 -6300 6300 20000 1 RANDOM
SOURCE DIRECTION -1 0 0
FLUX TOTAL 1 W
LEVEL 12
HALT 0.05
TRACE
"""


def test_one_line_rays_of_a_hero_kernel_take_the_scalar_shares(tmp_path, monkeypatch):
    """A kernel with hero wavelengths (the all-features kernel of a scene without polarization) takes every hit's
    shares from _hero_shares, a one-line ray's as a block of one (docs/architecture.md, "One set of shares per
    hit"); the specialized kernel of this scene has no HERO code and computes them as before.  Both must make the
    same decisions on the same random numbers: the ledger and the target's image agree to rounding (a wrong share
    would change decisions and move them by far more).  A regression guard of the kernel's bookkeeping, not a
    physics oracle (the physics tests run on the all-features kernel, so on the new path)."""
    frac = np.array([[0.2, 0.7, 0.5, 0.9], [0.6, 0.3, 0.8, 0.4]])
    gate = np.zeros((2, 4))
    gate[:, 1] = 1.0
    np.save(tmp_path / "frac.npy", frac)
    np.save(tmp_path / "gate.npy", gate)
    scene = _scene(SHARES_SCRIPT.format(frac=tmp_path / "frac.npy", gate=tmp_path / "gate.npy"))
    feats = pack(scene).features
    assert feats.maps and feats.scatter and feats.importance and feats.refract and not feats.hero
    monkeypatch.setenv("IRT_KERNEL_FEATURES", "all")
    assert specialize.kernel_module(feats).HERO_SHARES          # the one-line rays' shares from _hero_shares
    monkeypatch.setenv("IRT_KERNEL_FEATURES", "specialized")
    assert not specialize.kernel_module(feats).HERO_SHARES      # the scalar code
    a = _trace(scene, monkeypatch, "specialized")
    b = _trace(scene, monkeypatch, "all")
    assert b.ledger[:, 3].sum() > 0 and b.images["target"][0].sum() > 0   # scattered, and the target lit
    np.testing.assert_allclose(a.ledger, b.ledger, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(a.images["target"][0], b.images["target"][0], rtol=1e-12, atol=1e-24)
