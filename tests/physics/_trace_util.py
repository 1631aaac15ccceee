"""Helpers for the physics tests that drive whole scripts through the tracer (tests/physics/test_trace_*.py).

A script is checked with ``irtlang.lang.interp.check_file`` (the same front end as ``irt run``), and the scene
of one of its TRACE steps is traced with ``irtlang.tracer.run_trace``.  Nothing here knows about the kernel's
internals: the tests compare what comes out with independent numbers.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from irtlang.lang.interp import check_file
from irtlang.tracer import run_trace

EXAMPLES = Path(__file__).resolve().parents[2] / "examples_scripts"

def small_cassegrain(detector: str = "") -> str:
    """The small Cassegrain of the camera-side tests as SURFACE/OBJECT blocks (metres: primary f = 1 m, secondary
    magnification 5, a 24 x 24 pixel detector 12 mm square, 0.2 m behind the primary's vertex); `detector` ends the
    DETECTOR line (e.g. " FILTERS blue red")."""
    return f"""SURFACE
  CONIC Z 0 RADIUS 2 CONIC -1 ANNULUS 0.06 0.25
OBJECT primary
  INTERFACE REFLECT
SURFACE
  CONIC Z 0.8 RADIUS 0.5 CONIC -2.25 DISK 0.055
OBJECT secondary
  INTERFACE REFLECT
SURFACE
  PLANE Z (-0.2 - 0.00025) RECT 0.006 0.006
OBJECT fpa
  INTERFACE ABSORB
  DETECTOR PIXELS 24 24{detector}
"""


# ledger rows are objects, absorbing media, [IMPORTANCE], then these four (always the last four)
EMITTED, ESCAPED, HALTED, LOST = -4, -3, -2, -1
INC, REF, TRA, SCA, ABS = range(5)


def trace_steps(path):
    """The TRACE steps of a checked script."""
    it = check_file(path)
    steps = [s for s in it.steps if s.kind == "TRACE"]
    assert steps, f"{path} has no TRACE"
    return steps


def trace_file(path, *, which: int = -1, records: bool = True, history: bool = False, **kw):
    """Trace the scene of the script's TRACE number `which` (default: the last one)."""
    st = trace_steps(path)[which]
    p = st.params
    return run_trace(st.scene, seed=st.scene.seed, level=p["level"], halt=p["halt"], records=records,
                     history=history, **kw)


def trace_text(tmp_path, text: str, *, name: str = "scene.inr", **kw):
    f = Path(tmp_path) / name
    f.write_text(text)
    return trace_file(f, **kw)


def row(res, name: str) -> np.ndarray:
    """The ledger row of an object (or EMITTED, ESCAPED, ...), summed over lines: (incident, R, T, S, A)."""
    names = [n.upper() for n in res.rows]
    return res.ledger[names.index(name.upper())].sum(axis=1)


def ledger_gap(res) -> float:
    """|sum of absorbed - EMITTED| / EMITTED: the ledger closes when this is at rounding level."""
    led = res.ledger.sum(axis=2)
    emitted = led[EMITTED, INC]
    return abs(led[:, ABS].sum() - emitted) / emitted


def binomial_sigma(p: float, n: int) -> float:
    """Standard error of a share estimated from n independent rays that each carry their whole weight to one
    outcome or another (a Bernoulli trial with probability p): sqrt(p (1 - p) / n)."""
    return math.sqrt(p * (1.0 - p) / n)


def fresnel_unpolarized_ref(theta_i: float, n1: float, n2: float) -> float:
    """Unpolarized Fresnel reflectance from the amplitude coefficients, written out here (independent of
    irtlang.kernels.optics); 1 beyond the critical angle.  cos(theta_t) is formed as sqrt((1 - s)(1 + s)),
    s = n1 sin(theta_i) / n2, which keeps its relative precision next to the critical angle."""
    s = n1 * math.sin(theta_i) / n2
    if s >= 1.0:
        return 1.0
    ci = math.cos(theta_i)
    ct = math.sqrt((1.0 - s) * (1.0 + s))
    rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)
    rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct)
    return 0.5 * (rs * rs + rp * rp)


def fmt(x: float) -> str:
    """A number written so that the script reads back the same double."""
    return repr(float(x))
