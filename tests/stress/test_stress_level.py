"""Stress: the event limit (docs/tracer.md, "Stress tests").  LEVEL 1, and large LEVELs with rays trapped
between two facing mirrors, inside a mirror sphere, ellipsoid and closed mirror mesh, and between two partial
mirrors whose weights decay to denormals and zero (HALT 0) or play Russian roulette.  Besides the common
invariants (tests/stress/_stress_util.py: no NaN or inf, a closed ledger, no hang), a trapped ray meets the
mirrors exactly LEVEL times and ends HALTED: nothing escapes.  A white scattering lining with RAYS n inside
a closed mirror (n^LEVEL paths without a bound) must end quickly.  The slow form traces 5e7 events per ray.
"""
import pytest
from _stress_util import DATA, check_run, head, outputs

CAVITY = """SURFACE
  PLANE Z 0 DISK 10
OBJECT m1
  INTERFACE {itf}
SURFACE
  PLANE Z 10 DISK 10
OBJECT m2
  INTERFACE {itf}
"""


def _trapped(runner, tmp_path, level, n=2, geometry=None, name="trap", direction="0 0 1"):
    geometry = geometry or CAVITY.format(itf="REFLECT")
    text = head() + geometry + f"""LEVEL {level}
HALT 0
GRID RECT Z 5 -1 1 -1 1 {n} {n}
SOURCE DIRECTION {direction}
TRACE
""" + outputs()
    r = check_run(runner.run(tmp_path, text, name))
    emitted = r.row("EMITTED")[0]
    inc = sum(v[0] for k, v in r.ledger.items() if k not in ("EMITTED", "ESCAPED", "HALTED", "LOST"))
    assert r.row("HALTED")[4] == pytest.approx(emitted, rel=1e-12)
    assert r.row("ESCAPED")[4] == 0.0
    assert inc == pytest.approx(level * emitted, rel=1e-9)
    return r


def test_level_1(runner, tmp_path):
    """LEVEL 1: one interaction, then HALTED, whatever comes next."""
    r = _trapped(runner, tmp_path, 1)
    assert r.row("m1")[0] == 0.0


@pytest.mark.parametrize("level", [2, 1000, 200_000])
def test_level_cavity(runner, tmp_path, level):
    _trapped(runner, tmp_path, level)


@pytest.mark.slow
def test_level_cavity_long(runner, tmp_path):
    _trapped(runner, tmp_path, 50_000_000, n=1)      # 1e8 events in one thread


@pytest.mark.parametrize("geometry", ["sphere", "ellipsoid", "mesh"])
def test_level_closed_mirrors(runner, tmp_path, geometry):
    surf = {"sphere": "SPHERE 0 0 5 20", "ellipsoid": "ELLIPSOID 30 20 12 AT 0 0 5",
            "mesh": f"MESH '{DATA / 'icosphere_r10.stl'}' SCALE 2"}[geometry]
    g = f"SURFACE\n  {surf}\nOBJECT shell\n  INTERFACE REFLECT\n"
    _trapped(runner, tmp_path, 20_000, n=3, geometry=g, name=geometry, direction="0.3 0.001 1")


@pytest.mark.parametrize("coat,halt", [("REFLECT 0.5", "0"), ("REFLECT 0.999", "1e-6"),
                                       ("REFLECT 0.9 TRANSMIT 0.05", "0.5"), ("REFLECT 0.9 TRANSMIT 0.05", "0")])
def test_lossy_cavity_to_nothing(runner, tmp_path, coat, halt):
    """Partial mirrors: with HALT 0 the weights decay through the denormals to exactly zero (R = 0.5: after
    ~1075 bounces) and the paths end; with roulette they end by it.  The ledger still closes."""
    text = head() + f"COATING m {coat}\n" + CAVITY.format(itf="COATING m AIR AIR") + f"""LEVEL 10000000
HALT {halt}
GRID RECT Z 5 -1 1 -1 1 4 4
SOURCE DIRECTION 0 0 1
TRACE
""" + outputs()
    r = check_run(runner.run(tmp_path, text, "lossy"))
    if halt == "0":
        assert r.row("HALTED")[4] == 0.0
        if "TRANSMIT" not in coat:
            assert r.row("ESCAPED")[4] == 0.0


@pytest.mark.parametrize("rays", [2, 3])
def test_split_rays_in_a_closed_scattering_scene(runner, tmp_path, rays):
    """A white Lambertian lining (albedo 1) with RAYS n inside a closed mirror sphere: every scattering splits
    the path, nothing is ever lost and the weights relative to each path's start never fall, so without a
    bound a source ray would make n^LEVEL paths (a hang), and its pending paths would overflow the stack (flux
    LOST).  The tracer stops splitting at 4096 paths per source ray or when the stack is full: the run ends
    quickly, nothing is LOST, every path is HALTED by LEVEL, nothing escapes and the ledger closes."""
    text = head(lines="550 NM") + f"""MODEL white LAMBERTIAN 1
SURFACE
  SPHERE 0 0 0 20
OBJECT shell
  INTERFACE REFLECT
  SCATTER MODEL white RAYS {rays}
LEVEL 150
HALT 1e-6
GRID RECT Z 0 -1 1 -1 1 2 2
SOURCE DIRECTION 0.1 0.2 1
TRACE
""" + outputs(spectra=("shell",))
    r = check_run(runner.run(tmp_path, text, "split", timeout=60))
    emitted = r.row("EMITTED")[0]
    assert r.row("HALTED")[4] == pytest.approx(emitted, rel=1e-12)
    assert r.row("ESCAPED")[4] == 0.0
    assert r.row("shell")[3] > 0      # scattered
