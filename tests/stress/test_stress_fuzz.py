"""Stress: hypothesis geometry fuzzing (docs/tracer.md, "Stress tests").

Random scenes at a random scale (UNITS M, 1e-9 .. 1e12): planes with every aperture, conics (apertures up
to their domain's edge), spheres, ellipsoids, tubes and cones (apex included), meshes, each randomly shifted
and rotated; mirrors, absorbers, glass, partial and anti-reflection coatings, Lambertian scatter with split
rays; a detector; collimated grids with unnormalized directions of any magnitude, diverging and converging
grids, point and sphere emitters; zero, denormal and ordinary fluxes; random LEVEL and HALT; sometimes the
whole scene in a GROUP placed up to 1e12 m away.  Every scene must pass the common invariants
(tests/stress/_stress_util.py): exit code 0, no NaN or inf in any output, a closed ledger, no numerical
failure (LOST), no hang.  The fast tier runs a few derandomized examples; the slow tier many more.
"""
import itertools

import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st
from _stress_util import DATA, check_run, fmt, head, outputs

_count = itertools.count()

unit = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
frac = st.floats(0.05, 1.0, allow_nan=False)
ANGLE = st.sampled_from([0.0, 1e-7, 30.0, 45.0, 90.0, -17.3, 180.0])
AXIS = st.sampled_from("XYZ")
INTERFACES = ["INTERFACE REFLECT", "INTERFACE ABSORB", "", "INTERFACE TRANSMIT AIR glass",
              "INTERFACE TRANSMIT glass AIR", "INTERFACE COATING part AIR AIR", "INTERFACE COATING ar glass AIR"]


@st.composite
def vec(draw, scale=1.0):
    return tuple(draw(unit) * 3.0 * scale for _ in range(3))


@st.composite
def direction(draw):
    """A direction of any length: components 0, tiny or O(1), times 1e-300 .. 1e300."""
    comp = st.sampled_from([0.0, 1.0, -1.0, 0.37, -0.6, 1e-9, -1e-12])
    d = [draw(comp) for _ in range(3)]
    if not any(d):
        d[2] = 1.0
    mag = draw(st.sampled_from([1.0, 7.0, 1e-300, 1e300, 1e-150]))
    if any(abs(x) == 1e-12 for x in d) and mag == 1e-300:
        mag = 1.0     # 1e-312 is still a valid component, but keep the exponent range of the others too
    return " ".join(fmt(x * mag) for x in d)


@st.composite
def aperture(draw, s, rmax=None):
    kind = draw(st.sampled_from(["", "RECT", "DISK", "ANNULUS", "ELLIPSE"] if rmax is None
                                else ["DISK", "ANNULUS", "RECT"]))
    lim = 2.5 * s if rmax is None else min(rmax * 0.999, 2.5 * s)
    a, b = draw(frac) * lim, draw(frac) * lim
    if kind == "":
        return ""
    if kind == "RECT":
        if rmax is not None:   # corners inside the domain
            a, b = a / 1.4143, b / 1.4143
        return f" RECT {fmt(a)} {fmt(b)}"
    if kind == "DISK":
        return f" DISK {fmt(max(a, b))}"
    if kind == "ANNULUS":
        return f" ANNULUS {fmt(min(a, b) * 0.5)} {fmt(max(a, b))}"
    return f" ELLIPSE {fmt(a)} {fmt(b)}"


@st.composite
def surface(draw, s):
    kind = draw(st.sampled_from(["plane", "conic", "sphere", "ellipsoid", "tube", "mesh"]))
    if kind == "plane":
        return f"PLANE {draw(AXIS)} {fmt(draw(unit) * 2 * s)}" + draw(aperture(s))
    if kind == "conic":
        R = draw(st.sampled_from([1.0, -1.0])) * draw(st.floats(0.5, 5.0)) * s
        k = draw(st.sampled_from([-3.0, -1.0, -0.5, 0.0, 0.7]))
        rmax = abs(R) / (1 + k) ** 0.5 if k > -1 else None
        ap = draw(aperture(s, rmax=rmax if rmax is not None else 1e300))
        return f"CONIC {draw(AXIS)} {fmt(draw(unit) * s)} RADIUS {fmt(R)} CONIC {fmt(k)}" + ap
    if kind == "sphere":
        c = draw(vec(s / 3))
        return f"SPHERE {' '.join(fmt(x) for x in c)} {fmt(draw(frac) * 2 * s)}"
    if kind == "ellipsoid":
        ax = [draw(frac) * 2 * s for _ in range(3)]
        c = draw(vec(s / 3))
        return f"ELLIPSOID {' '.join(fmt(x) for x in ax)} AT {' '.join(fmt(x) for x in c)}"
    if kind == "tube":
        z1 = draw(unit) * 2 * s
        z2 = z1 + draw(frac) * 3 * s
        r1 = draw(st.sampled_from([0.0, 0.3, 1.0])) * s
        r2 = draw(frac) * 1.5 * s
        return f"TUBE {draw(AXIS)} {fmt(z1)} {fmt(r1)} {fmt(z2)} {fmt(r2)}"
    return f"MESH '{DATA / 'icosphere_r10.stl'}' SCALE {fmt(draw(frac) * 0.2 * s)}"


@st.composite
def placement(draw, s):
    out = ""
    if draw(st.booleans()):
        out += f"  SHIFT {' '.join(fmt(x) for x in draw(vec(s / 2)))}\n"
    if draw(st.booleans()):
        out += f"  ROTATE {draw(AXIS)} {fmt(draw(ANGLE))}\n"
    if draw(st.booleans()):
        out += f"  ROTATE {draw(AXIS)} {fmt(draw(ANGLE))} ABOUT {' '.join(fmt(x) for x in draw(vec(s)))}\n"
    return out


@st.composite
def source(draw, s):
    kind = draw(st.sampled_from(["grid", "grid", "position", "point", "sphere"]))
    flux = draw(st.sampled_from(["1 W", "1 W", "0 W", "1e-310 W", "5e-324 W", "3.7e20 W"]))
    z = fmt(draw(unit) * 3 * s)
    if kind == "grid":
        rnd = draw(st.sampled_from(["", " RANDOM"]))
        rect = f"GRID RECT {draw(AXIS)} {z} {fmt(-2 * s)} {fmt(2 * s)} {fmt(-s)} {fmt(2 * s)} 4 3{rnd}"
        g = draw(st.sampled_from([rect, f"GRID DISK {draw(AXIS)} {z} {fmt(2 * s)} RAYS 12{rnd}"]))
        text = f"{g}\nSOURCE DIRECTION {draw(direction())}\n"
    elif kind == "position":
        conv = draw(st.sampled_from(["", " CONVERGE"]))
        p = " ".join(fmt(x) for x in draw(vec(s)))
        text = f"GRID DISK {draw(AXIS)} {z} {fmt(2 * s)} RAYS 12\nSOURCE POSITION {p}{conv}\n"
    elif kind == "point":
        p = " ".join(fmt(x) for x in draw(vec(s)))
        cone = draw(st.sampled_from(["", f" CONE 20 AXIS {draw(direction())}"]))
        text = f"EMITTING POINT {p} RAYS 12{cone}\n"
    else:
        p = " ".join(fmt(x) for x in draw(vec(s / 3)))
        text = f"EMITTING SPHERE {p} {fmt(draw(frac) * s)} RAYS 12\n"
    return text + f"FLUX TOTAL {flux}\n"


@st.composite
def scene(draw):
    s = 10.0 ** draw(st.sampled_from([-9, -6, -3, 0, 3, 6, 9, 12]))
    body = """MEDIUM glass INDEX 1.5
COATING part REFLECT 0.3 TRANSMIT 0.6
COATING ar TRANSMIT 1
MODEL paint LAMBERTIAN 0.5
"""
    inner = ""
    for i in range(draw(st.integers(1, 4))):
        inner += f"SURFACE\n  {draw(surface(s))}\nOBJECT o{i}\n"
        itf = draw(st.sampled_from(INTERFACES))
        if itf:
            inner += f"  {itf}\n"
        if itf != "INTERFACE TRANSMIT AIR glass" and draw(st.integers(0, 4)) == 0:
            inner += f"  SCATTER MODEL paint RAYS {draw(st.integers(1, 3))}\n"
        inner += draw(placement(s))
    inner += f"SURFACE\n  PLANE Z {fmt(draw(unit) * 3 * s)} RECT {fmt(2 * s)} {fmt(1.5 * s)}\nOBJECT det\n"
    inner += "  DETECTOR PIXELS 6 5\n" + draw(placement(s))
    for _ in range(draw(st.integers(1, 2))):
        inner += draw(source(s))
    far = draw(st.sampled_from(["", "", "PLACE g AT 1e12 -3e11 2e11", "PLACE g AT 1e9 0 0 AIM 0 0 0",
                                "PLACE g AT 0 0 0"]))
    if far:
        inner = "GROUP g\n" + inner + "END GROUP\n" + far + "\n"
    tail = f"LEVEL {draw(st.integers(1, 120))}\nHALT {draw(st.sampled_from(['0', '1e-6', '0.3']))}\nTRACE\n"
    return head(units="M", seed=draw(st.integers(0, 1000))) + body + inner + tail + outputs("det")


def _run(runner, tmp_path_factory, text):
    note(text)
    # small scenes (at most 2 x 12 rays per line, LEVEL <= 120, at most 4096 paths per ray): 60 s is plenty
    r = runner.run(tmp_path_factory.mktemp("fuzz"), text, f"fuzz{next(_count)}", timeout=60)
    check_run(r)


SUPPRESS = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large,
            HealthCheck.filter_too_much]


@settings(max_examples=12, deadline=None, suppress_health_check=SUPPRESS)
@given(text=scene())
def test_fuzz_scenes(runner, tmp_path_factory, text):
    _run(runner, tmp_path_factory, text)


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=SUPPRESS)
@given(text=scene())
def test_fuzz_scenes_long(runner, tmp_path_factory, text):
    _run(runner, tmp_path_factory, text)
