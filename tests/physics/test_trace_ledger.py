"""The energy ledger through the tracer: absorbing media (Beer's law), Russian roulette, LEVEL cut-offs and
escapes.  The ledger must close to rounding (sum of absorbed_W over all rows == EMITTED) whatever happens,
and each row must hold the flux that independent arithmetic gives."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import ABS, EMITTED, ESCAPED, HALTED, INC, LOST, REF, TRA, ledger_gap, row, trace_text  # noqa: E402

HEAD = "SYSTEM NEW\nUNITS MM\nWAVELENGTHS 450 550 650 NM\nSEED 5\n"


@pytest.mark.parametrize("deg", [0.0, 40.0])
def test_beer_law_in_an_index_matched_absorber(tmp_path, deg):
    """MEDIUM dark INDEX 1 ABSORB 0.1 (per mm), 10 mm thick, index-matched: no reflection, so every ray crosses
    once and keeps exp(-alpha L / cos theta) of its flux: no Monte Carlo noise, the result is exact.
    The absorption per line differs (0.05 0.1 0.2 per mm)."""
    th = math.radians(deg)
    text = HEAD + f"""MEDIUM dark INDEX 1 ABSORB 0.05 0.1 0.2
SURFACE
  PLANE Z 0
OBJECT entry
  INTERFACE TRANSMIT AIR dark
SURFACE
  PLANE Z 10
OBJECT exit
  INTERFACE TRANSMIT dark AIR
SURFACE
  PLANE Z 30
OBJECT catcher
LEVEL 50
HALT 0
GRID RECT Z -5 -2 2 -2 2 20 20
SOURCE DIRECTION {math.sin(th)!r} 0 {math.cos(th)!r}
FLUX TOTAL 3 W
TRACE
"""
    res = trace_text(tmp_path, text, records=False)
    names = [n.upper() for n in res.rows]
    cat = res.ledger[names.index("CATCHER"), INC]            # per line
    med = res.ledger[names.index("MEDIUM DARK")]
    for k, alpha in enumerate((0.05, 0.1, 0.2)):
        keep = math.exp(-alpha * 10.0 / math.cos(th))
        assert cat[k] == pytest.approx(keep, rel=1e-13)       # 1 W per line
        assert med[ABS, k] == pytest.approx(1.0 - keep, rel=1e-13)
        assert med[INC, k] == pytest.approx(1.0, rel=1e-13)
    assert ledger_gap(res) < 1e-12


def test_roulette_is_unbiased_and_closes(tmp_path):
    """Four grey filters (COATING grey TRANSMIT 0.5: A = 0.5) in a row, HALT 0.5.  Weight after each filter:
    1/2 (not below the threshold), then 1/4 < 1/2 three times: each time the ray survives with p = 1/2 and is
    raised to 1/2.  So a ray reaches the catcher with weight 1/2 with probability 1/8, else 0: the mean is
    1/16 = 0.5^4, exactly the deterministic answer; per-ray variance 1/4 x 1/8 - (1/16)^2 = 7/256, so the
    standard error of the catcher's flux (1 W emitted) is sqrt(7/256 / N)."""
    planes = "".join(f"SURFACE\n  PLANE Z {z}\nOBJECT f{z}\n  INTERFACE COATING grey AIR AIR\n" for z in (0, 10, 20, 30))
    text = HEAD.replace("450 550 650", "550") + "COATING grey TRANSMIT 0.5\n" + planes + """SURFACE
  PLANE Z 50
OBJECT catcher
LEVEL 50
HALT 0.5
GRID RECT Z -5 -2 2 -2 2 200 200
SOURCE DIRECTION 0 0 1
FLUX TOTAL 1 W
TRACE
"""
    res = trace_text(tmp_path, text, records=False)
    n = res.n_traced
    got = row(res, "catcher")[INC]
    sigma = math.sqrt(7 / 256 / n)                            # 40000 rays: 8.3e-4
    assert abs(got - 1 / 16) <= 5 * sigma, (got, sigma)
    assert row(res, "HALTED")[ABS] != 0.0
    assert ledger_gap(res) < 1e-12


def test_level_cut_off_halts_everything(tmp_path):
    """Two facing mirrors with a ray between them: every ray bounces until LEVEL stops it; the HALTED row
    holds the whole emitted flux, the mirrors' incident flux is LEVEL x the emitted flux (each interaction
    counts once, the last one included)."""
    text = HEAD + """SURFACE
  PLANE Z 0
OBJECT m1
  INTERFACE REFLECT
SURFACE
  PLANE Z 10
OBJECT m2
  INTERFACE REFLECT
LEVEL 7
HALT 0
GRID RECT Z 5 -1 1 -1 1 10 10
SOURCE DIRECTION 0.1 0 1
FLUX TOTAL 1 W
TRACE
"""
    res = trace_text(tmp_path, text, records=False)
    led = res.ledger.sum(axis=2)
    assert led[HALTED, ABS] == pytest.approx(1.0, rel=1e-13)
    assert row(res, "m1")[INC] + row(res, "m2")[INC] == pytest.approx(7.0, rel=1e-13)
    assert led[ESCAPED, ABS] == 0.0
    assert ledger_gap(res) < 1e-12


def test_everything_at_once_closes(tmp_path):
    """An absorbing prism-like block with Fresnel faces, a lossy partial mirror, roulette, a LEVEL that cuts
    some paths and an open scene that lets others escape: each terminal row is used and the ledger closes."""
    text = HEAD + """MEDIUM glass INDEX 1.5 1.52 1.54 ABSORB 0.02
COATING lossy REFLECT 0.3 TRANSMIT 0.2
SURFACE
  PLANE Z 0 DISK 20
OBJECT g_in
  INTERFACE TRANSMIT AIR glass
SURFACE
  PLANE Z 20 DISK 20
OBJECT g_out
  INTERFACE TRANSMIT glass AIR
  ROTATE X 10 ABOUT 0 0 20
SURFACE
  TUBE Z 0 20 20 20
OBJECT g_rim
  INTERFACE TRANSMIT glass AIR
SURFACE
  PLANE Z 40 DISK 15
OBJECT partial
  INTERFACE COATING lossy AIR AIR
  ROTATE Y 20 ABOUT 0 0 40
SURFACE
  SPHERE 0 0 0 100
OBJECT dome
  INTERFACE COATING lossy AIR AIR
LEVEL 12
HALT 0.05
GRID DISK Z -10 12 RAYS 20000 RANDOM
SOURCE DIRECTION 0.2 0.1 1
FLUX TOTAL 1 W
TRACE
"""
    res = trace_text(tmp_path, text, records=False)
    led = res.ledger.sum(axis=2)
    names = [n.upper() for n in res.rows]
    assert led[names.index("MEDIUM GLASS"), ABS] > 0
    assert led[ESCAPED, ABS] > 0
    assert led[HALTED, ABS] != 0
    assert led[LOST, ABS] == 0
    for o in ("G_IN", "G_OUT", "PARTIAL", "DOME"):
        r = led[names.index(o)]
        assert r[INC] > 0
        assert r[REF] + r[TRA] + r[ABS] == pytest.approx(r[INC], rel=1e-12)
    assert ledger_gap(res) < 1e-12
    # per line too
    for k in range(3):
        assert abs(res.ledger[:, ABS, k].sum() - res.ledger[EMITTED, INC, k]) <= 1e-12 * res.ledger[EMITTED, INC, k]
