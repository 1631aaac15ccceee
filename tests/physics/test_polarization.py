"""Polarization (POLARIZATION; docs/tracer.md, "Polarization") against independent numbers:

* Coulson, Dave & Sekera's tables as corrected by Natraj, Li & Yung (2009, ApJ 691, 1909), ORACLES.md: I, Q, U
  reflected and transmitted by a conservative Rayleigh layer (tau = 0.5, no depolarization) over a Lambertian
  ground of albedo 0, 0.25 and 0.8.  The files (tests/physics/data/cds/, tau 0.5 only) are copied unchanged from
  the public repository RemoteSensingTools/vSmartMOM.jl (test/benchmarks/natraj_cds/CDS, Apache-2.0, commit
  d6051b7).  I within 1 % plus 3 standard errors, the degree of polarization within 0.01 (ORACLES.md).
* Fresnel closed forms: the Brewster angle (the reflected light is s-polarized: degree 1), the degree of
  polarization of reflected and transmitted light at other angles, (Rs - Rp) / (Rs + Rp); total internal
  reflection's retardance, tan(delta/2) = cos(theta) sqrt(sin^2 theta - n^2) / sin^2 theta.
* Malus's law through two ideal polarizers, and a quarter-wave retarder's circular light worked out by hand in
  Jones calculus (the sign of V).

Conventions (docs/tracer.md): a detector refers Q and U to its local x projected across the ray (e1) and
e2 = d x e1 (d the ray's direction); V > 0 turns from e1 toward e2.  The tables refer Q and U to the meridian
plane, Q > 0 for a horizontal electric vector (ORACLES.md).  The eye below is a disk whose local x is the
horizontal perpendicular to the meridian plane, so Q_table = Q.  The tables' second axis points the other way
from ours (e2 = d x e1 points up the meridian, toward the zenith for upwelling light; theirs points down it):
U_table = -U, at every geometry, upwelling and downwelling.  That is a convention, fixed once; the test checks it
at geometries where U is large (up to 0.7 I) in both directions, so a wrong sign anywhere would fail.

The test suite traces with one polarized kernel with every feature (tests/conftest.py): one compilation.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import ledger_gap, trace_text  # noqa: E402

DATA = Path(__file__).resolve().parent / "data" / "cds"
D = 1.0e9
R_EYE = 1.0e5
OMEGA = math.pi * R_EYE ** 2 / D ** 2
N_RAYS = 2_000_000


# ------------------------------------------------------------------------------------------------ the tables
def cds_table(stokes: str, where: str) -> dict:
    """{(albedo, mu0, mu): [value at phi = 0, 30, ..., 180]} from one of the table files."""
    out, albedo = {}, None
    for ln in (DATA / f"{stokes}_{where}_TAU_0.5").read_text().splitlines():
        if "albedo =" in ln:
            albedo = float(ln.split("=")[1])
            continue
        parts = ln.split()
        if len(parts) == 9 and albedo is not None:
            try:
                vals = [float(x) for x in parts]
            except ValueError:
                continue
            out[(albedo, vals[0], vals[1])] = vals[2:]
    return out


def test_cds_tables_read_as_published():
    """The files as read: 3 albedos x 7 mu0 x 16 mu rows, and two values of the 00README's examples: the first
    row of I_UP (0.38088723 at phi = 0) and U = 0 at phi = 0 and 180 (the principal plane) everywhere."""
    i_up = cds_table("I", "UP")
    assert len(i_up) == 3 * 7 * 16
    assert i_up[(0.0, 0.1, 0.02)][0] == 0.38088723
    u_up = cds_table("U", "UP")
    assert all(v[0] == 0.0 and v[6] == 0.0 for v in u_up.values())


# ------------------------------------------------------------------------------------------------ the layer
def _eye_block(th: float, alpha: float, up: bool = True) -> str:
    """A disk detector at D in the direction (th from the zenith, or from the nadir if not up; azimuth alpha),
    facing the origin; ROTATE Z 90 first puts its local x, after the tilt and the turn, along the horizontal
    normal to the meridian plane (the tables' Q > 0 direction)."""
    s = math.sin(math.radians(th))
    c = math.cos(math.radians(th))
    pos = (D * s * math.cos(math.radians(alpha)), D * s * math.sin(math.radians(alpha)), D * c if up else -D * c)
    return f"""SURFACE
  PLANE Z 0 ELLIPSE {R_EYE!r} {R_EYE!r}
OBJECT eye
  INTERFACE ABSORB
  DETECTOR PIXELS 1
  ROTATE Z 90
  ROTATE Y {th if up else 180.0 - th!r}
  ROTATE Z {alpha!r}
  SHIFT {pos[0]!r} {pos[1]!r} {pos[2]!r}
"""


def layer_script(albedo: float, mu0: float, mu: float, phi: float, up: bool, n: int, seed: int = 5) -> str:
    """The Rayleigh layer (1 km, tau 0.5) lit by a collimated beam propagating toward azimuth 180 deg at
    theta0 = acos(mu0), watched by a disk eye at D in the direction (theta, 180 deg + phi) (phi = 0: the forward
    side), up or down; every volume and ground scattering sends one ray toward the eye."""
    th0 = math.degrees(math.acos(mu0))
    th = math.degrees(math.acos(mu))
    alpha = 180.0 + phi
    if up:
        ground = f"""MODEL soil LAMBERTIAN {albedo!r}
SURFACE
  PLANE Z 0 RECT 1e6 1e6
OBJECT ground
  INTERFACE COATING black VACUUM layer
  SCATTER MODEL soil TOWARD eye
"""
    else:
        assert albedo == 0.0     # transmitted light is watched from below: no ground in the way
        ground = """SURFACE
  PLANE Z 0 RECT 1e6 1e6
OBJECT ground
  INTERFACE TRANSMIT VACUUM layer
"""
    return f"""UNITS M
WAVELENGTHS 550 NM
SEED {seed}
POLARIZATION
MEDIUM layer INDEX 1 VOLUME EXTINCTION (0.5 / 1000 m) ALBEDO 1 PHASE RAYLEIGH DEPOL 0 TOWARD eye
COATING black REFLECT 0
{ground}SURFACE
  PLANE Z 1000 RECT 1e6 1e6
OBJECT top
  INTERFACE TRANSMIT layer VACUUM
{_eye_block(th, alpha, up)}GRID RECT Z 2000 -5000 5000 -5000 5000 {n} 1 RANDOM
SOURCE DIRECTION (-sin({th0!r})) 0 (-cos({th0!r}))
FLUX TOTAL 1 W
LEVEL 300
HALT 0
TRACE
"""


def eye_stokes(res, mu0: float, mu: float):
    """(I, Q, U, V) in the tables' normalization and their standard errors.  The beam's 1 W over the grid's
    horizontal area A is mu0 E0 A; a radiance L leaving the lit area reaches the eye as L A mu Omega; the
    tables give pi L / E0, so I = pi Phi mu0 / (mu Omega) (ORACLES.md; test_scatter_volume.py's geometry)."""
    s1, s2 = res.stokes["eye"]
    n = res.n_traced
    x = s1[:, 0, 0, 0]
    var = np.maximum(s2[:, 0, 0, 0] - x * x / n, 0.0) * n / (n - 1)
    k = math.pi * mu0 / (mu * OMEGA)
    return x * k, np.sqrt(var) * k


CASES = [  # (albedo, mu0, mu, phi, up)
    (0.0, 0.6, 0.4, 60, True),
    (0.0, 0.6, 0.4, 120, True),
    (0.25, 0.92, 0.64, 90, True),
    (0.8, 0.4, 0.84, 30, True),
    (0.8, 0.6, 0.2, 150, True),
    (0.0, 0.6, 0.52, 90, False),
    (0.0, 0.92, 0.28, 150, False),
]


@pytest.mark.parametrize("albedo,mu0,mu,phi,up", CASES)
def test_rayleigh_layer_against_coulson_dave_sekera(tmp_path, albedo, mu0, mu, phi, up):
    where = "UP" if up else "DN"
    k = [0, 30, 60, 90, 120, 150, 180].index(phi)
    ref = {s: cds_table(s, where)[(albedo, mu0, mu)][k] for s in "IQU"}
    res = trace_text(tmp_path, layer_script(albedo, mu0, mu, phi, up, N_RAYS), records=False)
    (i, q, u, v), (si, sq, su, sv) = eye_stokes(res, mu0, mu)
    u = -u                                  # the tables' U (module docstring)
    assert si < 0.004 * ref["I"]            # the check means something
    assert abs(i - ref["I"]) <= 0.01 * ref["I"] + 3 * si, (i, si, ref)
    dop, dop_ref = math.hypot(q, u) / i, math.hypot(ref["Q"], ref["U"]) / ref["I"]
    assert abs(dop - dop_ref) <= 0.01, (dop, dop_ref)
    for got, se, want in ((q, sq, ref["Q"]), (u, su, ref["U"])):
        assert abs(got - want) <= 0.01 * ref["I"] + 3 * se, (got, se, want)
    assert v == 0.0                         # Rayleigh scattering of unpolarized light makes no circular part
    assert ledger_gap(res) < 1e-12


# ------------------------------------------------------------------------------------------------ the bench
def bench(elements: str, *, n: int = 400) -> str:
    """A collimated 1 W beam (n rays) going down from z = 50 mm through `elements` onto their detectors."""
    return f"""UNITS MM
WAVELENGTHS 550 NM
SEED 2
POLARIZATION
MEDIUM glass INDEX 1.5
{elements}
GRID RECT Z 50 -1 1 -1 1 {n} 1 RANDOM
SOURCE DIRECTION 0 0 -1
FLUX TOTAL 1 W
TRACE
"""


def _det(name: str = "det", where: str = "PLANE Z 0 RECT 5 5", extra: str = "") -> str:
    return f"""SURFACE
  {where}
OBJECT {name}
  INTERFACE ABSORB
  DETECTOR PIXELS 1
{extra}"""


def det_stokes(res, name: str = "det"):
    s1, _ = res.stokes[name]
    return s1[:, 0, 0, 0]


def two_polarizers(theta: float) -> str:
    """Polarizers along x (z = 20 mm) and at theta (z = 10 mm) above a one-pixel detector."""
    return f"""SURFACE
  PLANE Z 20 RECT 5 5
OBJECT p1
  INTERFACE POLARIZER 0
SURFACE
  PLANE Z 10 RECT 5 5
OBJECT p2
  INTERFACE POLARIZER {theta!r}
""" + _det()


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0, 90.0])
def test_malus_law(tmp_path, theta):
    """Unpolarized 1 W through a polarizer along x, then one at theta: I = cos^2(theta) / 2, exactly (ideal
    polarizers weight the ray, no random choice); the light leaves along the second axis: Q = I cos 2 theta and
    U = -I sin 2 theta in the detector's frame (e1 = x, e2 = d x x = -y for light going down)."""
    res = trace_text(tmp_path, bench(two_polarizers(theta)), records=False)
    i, q, u, v = det_stokes(res)
    t = math.radians(theta)
    want = 0.5 * math.cos(t) ** 2
    assert i == pytest.approx(want, abs=1e-12)
    assert q == pytest.approx(want * math.cos(2 * t), abs=1e-12)
    assert u == pytest.approx(-want * math.sin(2 * t), abs=1e-12)
    assert v == 0.0
    assert ledger_gap(res) < 1e-12


def test_quarter_wave_retarder_makes_circular_light(tmp_path):
    """A polarizer along x, then a quarter-wave retarder with its fast axis at +45 deg: by hand in Jones
    calculus, E = x splits into (f - s)/sqrt 2 along the fast and slow axes; the slow one is delayed by
    exp(i pi/2), giving E = ((1 + i) x + (1 - i) y) / 2, whose real field turns from (1, 1) to (1, -1) as
    time goes on: clockwise seen from +z, counter-clockwise seen by an observer facing the light (which goes
    toward -z): V = +I.  A second identical retarder makes linear light along y: Q = -I."""
    qwp = """SURFACE
  PLANE Z {z} RECT 5 5
OBJECT {name}
  INTERFACE RETARDER 45 90
"""
    base = """SURFACE
  PLANE Z 20 RECT 5 5
OBJECT p1
  INTERFACE POLARIZER 0
""" + qwp.format(z=10, name="q1")
    res = trace_text(tmp_path, bench(base + _det()), records=False)
    i, q, u, v = det_stokes(res)
    assert i == pytest.approx(0.5, abs=1e-12)
    assert (q, u) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert v == pytest.approx(0.5, abs=1e-12)
    res = trace_text(tmp_path, bench(base + qwp.format(z=5, name="q2") + _det()), records=False)
    i, q, u, v = det_stokes(res)
    assert (i, q, u, v) == pytest.approx((0.5, -0.5, 0.0, 0.0), abs=1e-12)


def fresnel_power(theta, n1, n2):
    """Textbook Fresnel power coefficients (Hecht, Optics, 4th ed., eqs. 4.34, 4.40, 4.62-4.63): Rs, Rp, Ts, Tp."""
    ci = math.cos(theta)
    st = n1 / n2 * math.sin(theta)
    ct = math.sqrt(1 - st * st)
    rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)
    rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct)
    ts = 2 * n1 * ci / (n1 * ci + n2 * ct)
    tp = 2 * n1 * ci / (n2 * ci + n1 * ct)
    k = n2 * ct / (n1 * ci)
    return rs * rs, rp * rp, k * ts * ts, k * tp * tp


@pytest.mark.parametrize("theta", [30.0, math.degrees(math.atan(1.5)), 70.0])
def test_fresnel_reflection_and_transmission(tmp_path, theta):
    """Unpolarized light onto glass (n = 1.5) at theta (the glass tilted, the beam along -z): the reflected light
    is polarized by (Rs - Rp)/(Rs + Rp), degree 1 at Brewster's angle atan(1.5) = 56.31 deg, and the transmitted
    light by (Tp - Ts)/(Ts + Tp).  Each ray carries its whole weight one way: the fluxes (Rs + Rp)/2 and
    (Ts + Tp)/2 within 5 binomial sigmas, their sum exactly 1; the degrees of polarization exactly (every ray of
    a beam has the same state)."""
    Rs, Rp, Ts, Tp = fresnel_power(math.radians(theta), 1.0, 1.5)
    assert Rs + Ts == pytest.approx(1.0, abs=1e-12) and Rp + Tp == pytest.approx(1.0, abs=1e-12)
    # the face's normal is (sin t, 0, cos t): the reflected beam goes along (sin 2t, 0, cos 2t) to a detector at
    # x = 30 mm, the transmitted one into a detector 10 mm behind the face, parallel to it
    els = f"""SURFACE
  PLANE Z 0 RECT 20 20
OBJECT face
  INTERFACE TRANSMIT glass AIR
  ROTATE Y {theta!r}
""" + _det("rdet", "PLANE X 30 RECT 60 60") + _det("tdet", "PLANE Z -10 RECT 40 40", f"  ROTATE Y {theta!r}\n")
    n = 20000
    res = trace_text(tmp_path, bench(els, n=n), records=False)
    ir, qr, ur, vr = det_stokes(res, "rdet")
    it, qt, ut, vt = det_stokes(res, "tdet")
    R, T = 0.5 * (Rs + Rp), 0.5 * (Ts + Tp)
    sig = math.sqrt(R * (1 - R) / n)
    assert abs(ir - R) <= 5 * sig and abs(it - T) <= 5 * sig, (ir, R, it, T, sig)
    assert ir + it == pytest.approx(1.0, abs=1e-12)          # a lossless interface
    assert math.hypot(qr, ur) / ir == pytest.approx((Rs - Rp) / (Rs + Rp), abs=1e-9)
    assert math.hypot(qt, ut) / it == pytest.approx((Tp - Ts) / (Ts + Tp), abs=1e-9)
    assert vr == 0.0 and vt == 0.0
    assert ledger_gap(res) < 1e-12


@pytest.mark.parametrize("theta", [45.0, 50.0, 60.0, 75.0])
def test_total_internal_reflection_retardance(tmp_path, theta):
    """Linear light at 45 deg to the plane of incidence, totally reflected inside glass (n = 1/1.5 relative):
    the p-s phase difference delta makes it elliptical, |V| / I = |sin delta| with tan(delta/2) = cos(theta)
    sqrt(sin^2 theta - n^2) / sin^2 theta (ORACLES.md); nothing is lost (I = 1/2 after the polarizer) and it
    stays fully polarized.  The polarizer's axis, 45 deg between x and y, is at 45 deg to the plane of
    incidence (x, z)."""
    n = 1.0 / 1.5
    t = math.radians(theta)
    delta = 2 * math.atan(math.cos(t) * math.sqrt(math.sin(t) ** 2 - n * n) / math.sin(t) ** 2)
    els = f"""SURFACE
  PLANE Z 20 RECT 5 5
OBJECT pol
  INTERFACE POLARIZER 45 glass glass
SURFACE
  PLANE Z 0 RECT 20 20
OBJECT face
  INTERFACE TRANSMIT AIR glass
  ROTATE Y {theta!r}
""" + _det("det", "PLANE X 30 RECT 60 60" if 2 * t < math.radians(135) else "PLANE Z -30 RECT 60 60")
    res = trace_text(tmp_path, bench(els), records=False)
    i, q, u, v = det_stokes(res)
    assert i == pytest.approx(0.5, abs=1e-12)
    assert abs(v) / i == pytest.approx(abs(math.sin(delta)), abs=1e-9), (v / i, math.sin(delta))
    assert math.sqrt(q * q + u * u + v * v) / i == pytest.approx(1.0, abs=1e-9)
    assert ledger_gap(res) < 1e-12


def test_without_polarization_nothing_changes(tmp_path):
    """No POLARIZATION: the scene packs for the scalar kernel (pays nothing); with it, or with a POLARIZER
    alone (which only means something to a polarized trace), the polarized one."""
    from irtlang.compile.pack import pack
    from irtlang.lang.interp import check_file

    def feats(text):
        f = Path(tmp_path) / "s.inr"
        f.write_text(text)
        st = [s for s in check_file(f).steps if s.kind == "TRACE"][-1]
        return pack(st.scene).features

    text = bench(_det())
    assert feats(text).polar
    assert not feats(text.replace("POLARIZATION\n", "")).polar
    assert feats(text.replace("POLARIZATION\n", "").replace("INTERFACE ABSORB\n  DETECTOR",
                                                              "INTERFACE POLARIZER 10\n  DETECTOR")).polar


@pytest.mark.parametrize("th0,thv,phi", [(53.0, 53.0, 0.0), (30.0, 30.0, 0.0), (40.0, 60.0, 30.0)])
def test_glint_reflects_by_fresnel_on_the_facets(tmp_path, th0, thv, phi):
    """A glint ocean (ALBEDO 0: no water-leaving term) lit by unpolarized light, watched from (thv, phi): every ray
    reaching the eye was sent toward it from a facet whose normal h bisects the Sun's and the eye's directions,
    so the light is polarized by Fresnel's (Rs - Rp)/(Rs + Rp) for water (n = 1.34) at the facet's incidence
    angle acos(wi . h) (textbook Fresnel), normal to the facet's plane of incidence.  In the principal plane
    (phi = 0, the specular direction and a direction beside it) that is horizontal: Q = +I, U = 0 in the eye's
    frame; near Brewster's angle (53.3 deg) the degree is close to 1.  The eye is 2e-4 rad across, the lit patch
    1e-5 rad: the facet angle varies by < 1e-4 rad over the rays, a change < 1e-4 in the degree."""
    alpha = 180.0 + phi
    text = f"""UNITS M
WAVELENGTHS 550 NM
SEED 4
POLARIZATION
MODEL sea GLINT WIND 5 m/s INDEX 1.34 ALBEDO 0
SURFACE
  PLANE Z 0 RECT 1e6 1e6
OBJECT ocean
  INTERFACE ABSORB
  SCATTER MODEL sea TOWARD eye
{_eye_block(thv, alpha)}GRID RECT Z 10 -5000 5000 -5000 5000 20000 1 RANDOM
SOURCE DIRECTION (-sin({th0!r})) 0 (-cos({th0!r}))
FLUX TOTAL 1 W
TRACE
"""
    res = trace_text(tmp_path, text, records=False)
    i, q, u, v = det_stokes(res, "eye")
    t0, tv, a = math.radians(th0), math.radians(thv), math.radians(alpha)
    wi = np.array([math.sin(t0), 0.0, math.cos(t0)])               # toward the Sun
    wo = np.array([math.sin(tv) * math.cos(a), math.sin(tv) * math.sin(a), math.cos(tv)])
    h = (wi + wo) / np.linalg.norm(wi + wo)
    Rs, Rp, _, _ = fresnel_power(math.acos(float(wi @ h)), 1.0, 1.34)
    dop = (Rs - Rp) / (Rs + Rp)
    assert i > 0
    assert math.hypot(q, u) / i == pytest.approx(dop, abs=2e-4), (math.hypot(q, u) / i, dop)
    assert v == 0.0
    if phi == 0.0:
        assert q / i == pytest.approx(dop, abs=2e-4) and abs(u) / i < 1e-6
    assert ledger_gap(res) < 1e-12


@pytest.mark.parametrize("what,message", [
    ("scalar", "EXPORT det STOKES needs a polarized trace: put POLARIZATION before TRACE"),
    ("no detector", "EXPORT det STOKES needs an object with a DETECTOR"),
])
def test_export_stokes_mistakes_are_clear_errors(tmp_path, capsys, what, message):
    """A script's mistake gets its line and a message, exit 1 (a run-time failure), not a traceback."""
    from irtlang.cli import main

    text = bench(_det() if what == "scalar" else "SURFACE\n  PLANE Z 0 RECT 5 5\nOBJECT det\n  INTERFACE ABSORB\n")
    if what == "scalar":
        text = text.replace("POLARIZATION\n", "")
    text += "EXPORT det 'det.npy' STOKES\n"
    f = Path(tmp_path) / "s.inr"
    f.write_text(text)
    code = main(["run", str(f), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 1 and message in err and "Traceback" not in err, err
    line = text.splitlines().index("EXPORT det 'det.npy' STOKES") + 1
    assert f"s.inr:{line}:" in err


def test_camera_trace_gives_no_stokes_images(tmp_path, capsys):
    """TRACE CAMERA under POLARIZATION gives the polarization-correct I image (test_camera_image.py checks it
    against the forward trace); its Q, U and V would mean nothing for the pixel, so EXPORT ... STOKES after it is a
    run-time error at its line, not a wrong picture."""
    from irtlang.cli import main

    text = """UNITS M
WAVELENGTHS 550 NM
POLARIZATION
MODEL paint LAMBERTIAN 0.6
SURFACE
  SPHERE 0 0 1e5 100
OBJECT ball
  INTERFACE ABSORB
  SCATTER MODEL paint
SURFACE
  PLANE Z 0 RECT 0.01 0.01
OBJECT fpa
  INTERFACE ABSORB
  DETECTOR PIXELS 8
EMITTING SPHERE 8.66e8 0 -4.999e8 1e6 RAYS 1
FLUX TOTAL 1e18 W
TRACE CAMERA fpa AIM ball
EXPORT fpa 'cam.npy'
EXPORT fpa 'cam.npy' STOKES
"""
    f = Path(tmp_path) / "cam.inr"
    f.write_text(text)
    code = main(["run", str(f), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 1 and "STOKES after TRACE CAMERA" in err and "Traceback" not in err, err
    assert "cam.inr:19:" in err
    assert (tmp_path / "out" / "cam.npy").exists()


def test_spectrum_of_stokes(tmp_path, capsys):
    """SPECTRUM OF obj 'f.csv' STOKES from a one-pixel detector behind two polarizers (0 and 30 deg), three lines:
    every line's I is cos^2(30 deg)/2 of what the line emitted (the ledger's EMITTED row), Q = I cos 60 deg,
    U = -I sin 60 deg (module docstring), V = 0; a line's rays all carry the same state, so its Q, U standard
    errors are exactly cos 60 and sin 60 times I's.  A many-pixel detector is refused (its total's error would
    need the pixels' covariances)."""
    from irtlang.cli import main

    text = bench(two_polarizers(30.0), n=3000).replace("WAVELENGTHS 550 NM", "WAVELENGTHS 450 550 650 NM") + \
        "SPECTRUM OF det 'det.csv' STOKES\n"
    f = Path(tmp_path) / "s.inr"
    f.write_text(text)
    assert main(["run", str(f), "--out", str(tmp_path / "out")]) == 0
    rows = (tmp_path / "out" / "det.csv").read_text().splitlines()
    assert rows[0] == "wavelength_nm,I_W,Q_W,U_W,V_W,stderr_I_W,stderr_Q_W,stderr_U_W,stderr_V_W"
    res = trace_text(tmp_path, text, records=False)
    emitted = res.ledger[-4, 0]
    c, s = math.cos(math.radians(60)), math.sin(math.radians(60))
    for k, r in enumerate(rows[1:]):
        lam, i, q, u, v, si, sq, su, sv = (float(x) for x in r.split(","))
        assert lam == [450, 550, 650][k]
        assert i == pytest.approx(0.375 * emitted[k], rel=1e-12)
        assert (q, u, v) == pytest.approx((c * i, -s * i, 0.0), rel=1e-12, abs=1e-15)
        assert si > 0 and (sq, su, sv) == pytest.approx((c * si, s * si, 0.0), rel=1e-9, abs=1e-15)
    capsys.readouterr()
    f.write_text(text.replace("DETECTOR PIXELS 1", "DETECTOR PIXELS 4"))
    assert main(["run", str(f), "--out", str(tmp_path / "out2")]) == 1
    assert "needs a one-pixel DETECTOR without FILTERS" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------------ slab, metals
@pytest.mark.parametrize("th0,thv,phi,up,rho", [(30.0, 40.0, 0.0, True, 0.0), (30.0, 50.0, 0.0, False, 0.0279),
                                                (50.0, 30.0, 90.0, True, 0.0279)])
def test_rayleigh_slab_single_scattering(tmp_path, th0, thv, phi, up, rho):
    """The RAYLEIGH slab model (a single-scattering layer on a surface, as the Earth's air shells use it) lit by
    unpolarized light and watched from (thv, phi), above it (reflection) or below it (transmission): every ray
    reaching the eye scattered once, at the angle Theta between the beam and the eye, so its degree of
    polarization is Rayleigh's P12/P11 = D 3/4 sin^2 / (D 3/4 (1 + cos^2) + 1 - D), D = (1 - rho)/(1 + rho/2)
    (Chandrasekhar 1950; Hansen & Travis 1974, eq. 2.16), with the electric vector normal to the scattering plane.
    In the principal plane that normal is the eye's local x: Q = +degree I, U = 0.  Off it, the angle of linear
    polarization is the angle between the eye's x and that normal, worked out here with vectors.  The eye is
    2e-4 rad across: the scattering angle varies by < 1e-4 rad, the degree by < 1e-4."""
    alpha = 180.0 + phi
    text = f"""UNITS M
WAVELENGTHS 550 NM
SEED 6
POLARIZATION
MODEL air RAYLEIGH TAU 0.3 DEPOL {rho!r}
SURFACE
  PLANE Z 0 RECT 1e6 1e6
OBJECT slab
  INTERFACE TRANSMIT VACUUM VACUUM
  SCATTER MODEL air TOWARD eye
{_eye_block(thv, alpha, up)}GRID RECT Z 10 -5000 5000 -5000 5000 4000 1 RANDOM
SOURCE DIRECTION (-sin({th0!r})) 0 (-cos({th0!r}))
FLUX TOTAL 1 W
TRACE
"""
    res = trace_text(tmp_path, text, records=False)
    i, q, u, v = det_stokes(res, "eye")
    t0, tv, a = math.radians(th0), math.radians(thv), math.radians(alpha)
    d = np.array([-math.sin(t0), 0.0, -math.cos(t0)])               # the beam's direction
    wo = np.array([math.sin(tv) * math.cos(a), math.sin(tv) * math.sin(a), math.cos(tv) if up else -math.cos(tv)])
    c = float(d @ wo)
    D = (1 - rho) / (1 + rho / 2)
    dop = D * 0.75 * (1 - c * c) / (D * 0.75 * (1 + c * c) + 1 - D)
    assert i > 0
    assert math.hypot(q, u) / i == pytest.approx(dop, abs=2e-4), (math.hypot(q, u) / i, dop)
    assert v == 0.0
    # the electric vector lies along the scattering plane's normal n.  The eye's frame: e1 its local x, the
    # horizontal normal to its meridian plane (-sin a, cos a, 0) projected across the ray (direction wo), and
    # e2 = wo x e1; the angle of linear polarization 1/2 atan2(U, Q) is chi, the angle from e1 to n
    n = np.cross(d, wo)
    n /= np.linalg.norm(n)
    e1 = np.array([-math.sin(a), math.cos(a), 0.0])
    e1 -= (e1 @ wo) * wo
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(wo, e1)
    chi = math.atan2(float(n @ e2), float(n @ e1))
    assert q / i == pytest.approx(dop * math.cos(2 * chi), abs=2e-4)
    assert u / i == pytest.approx(dop * math.sin(2 * chi), abs=2e-4)
    if phi == 0.0:
        assert abs(u) / i < 1e-6
    assert ledger_gap(res) < 1e-12


AL_550 = (0.958, 6.69)      # aluminium at 550 nm (Rakic 1995, Appl. Opt. 34, 4755): n, k


def metal_power(theta, n, k):
    """A metal's Rs, Rp and the ellipsometric phase Delta of rp/rs, in two textbook forms independent of the
    tracer's: Rs and Rp by Heavens' a, b parameters (Optical Properties of Thin Solid Films, 1955, eqs. 4.47-
    4.50: 2a^2 = sqrt((n^2-k^2-s^2)^2 + 4 n^2 k^2) + (n^2-k^2-s^2), 2b^2 = ... - (...)), Delta from Azzam &
    Bashara's rho = rp/rs = (s t - sqrt(eps - s^2)) / (s t + sqrt(eps - s^2)), s = sin theta, t = tan theta."""
    s2, c = math.sin(theta) ** 2, math.cos(theta)
    t = n * n - k * k - s2
    r = math.sqrt(t * t + 4 * n * n * k * k)
    a, b = math.sqrt((r + t) / 2), math.sqrt((r - t) / 2)
    Rs = ((a - c) ** 2 + b * b) / ((a + c) ** 2 + b * b)
    st = math.sin(theta) * math.tan(theta)
    Rp = Rs * ((a - st) ** 2 + b * b) / ((a + st) ** 2 + b * b)
    w = np.sqrt(complex(n, k) ** 2 - s2)
    rho = (st - w) / (st + w)
    return Rs, Rp, float(np.angle(rho))


def metal_fold(theta: float, polarized: bool, n: int) -> str:
    """A polarizer at 45 deg to the plane of incidence (x, z), then an aluminium fold mirror tilted by theta
    about y, and the reflected beam's one-pixel detector."""
    els = f"""COATING alu METAL {AL_550[0]!r} EXTINCTION {AL_550[1]!r}
SURFACE
  PLANE Z 20 RECT 5 5
OBJECT pol
  INTERFACE POLARIZER 45
SURFACE
  PLANE Z 0 RECT 20 20
OBJECT fold
  INTERFACE COATING alu AIR AIR
  ROTATE Y {theta!r}
""" + (_det("det", "PLANE X 30 RECT 60 60") if 30 <= theta < 67.5 else
       _det("det", "PLANE Z 30 RECT 5 5", f"  SHIFT {30 * math.tan(math.radians(2 * theta))!r} 0 0\n")
       if theta < 30 else _det("det", "PLANE Z -30 RECT 60 60"))
    text = bench(els, n=n)
    if not polarized:
        text = text.replace("POLARIZATION\n", "").replace("INTERFACE POLARIZER 45", "INTERFACE TRANSMIT AIR AIR")
    return text


@pytest.mark.parametrize("theta", [10.0, 45.0, 60.0, 80.0])
def test_metal_mirror_fresnel_with_complex_index(tmp_path, theta):
    """COATING alu METAL n EXTINCTION k on a fold mirror: light linearly polarized at 45 deg to the plane of incidence
    (I = 1/2 after the polarizer) is reflected with the weight R = (Rs + Rp)/2 (reflection is its only outcome
    besides absorption: the weight is multiplied, no random choice, so exactly) and comes back elliptical: |Q| / I = (Rs - Rp)/(Rs + Rp), |V| / I = 2 sqrt(Rs Rp) |sin Delta| / (Rs + Rp), fully
    polarized (metal_power: textbook forms, not the tracer's, which give R = ((n-1)^2 + k^2) / ((n+1)^2 + k^2)
    = 0.9211 at normal incidence).  The ledger closes: what is not reflected is absorbed.  Traced without POLARIZATION (no polarizer), unpolarized light is reflected with
    the same (Rs + Rp)/2: the metal's reflectance depends on the angle in a scalar trace too."""
    nr = 20000
    n, k = AL_550
    assert metal_power(0.0, n, k)[:2] == pytest.approx((((n - 1) ** 2 + k * k) / ((n + 1) ** 2 + k * k),) * 2,
                                                       rel=1e-12)
    Rs, Rp, delta = metal_power(math.radians(theta), *AL_550)
    R = 0.5 * (Rs + Rp)
    res = trace_text(tmp_path, metal_fold(theta, True, nr), records=False)
    i, q, u, v = det_stokes(res)
    assert i == pytest.approx(0.5 * R, rel=1e-12)
    assert abs(q) / i == pytest.approx((Rs - Rp) / (Rs + Rp), abs=1e-9)
    assert abs(v) / i == pytest.approx(2 * math.sqrt(Rs * Rp) * abs(math.sin(delta)) / (Rs + Rp), abs=1e-9)
    assert math.sqrt(q * q + u * u + v * v) / i == pytest.approx(1.0, abs=1e-9)
    assert ledger_gap(res) < 1e-12
    res = trace_text(tmp_path, metal_fold(theta, False, nr), records=False)
    assert res.stokes is None
    flux = float(res.images["det"][0].sum())
    assert flux == pytest.approx(R, rel=1e-12)
    assert ledger_gap(res) < 1e-12


# ------------------------------------------------------------------------------------------------ 6SV
SIXS = Path(__file__).resolve().parent / "data" / "sixs_rayleigh.csv"


def sixs_cases() -> list:
    """data/sixs_rayleigh.csv: 6SV 1.1's vector Rayleigh reflectance (make_sixs_rayleigh.py regenerates it)."""
    return [tuple(float(x) for x in r.split(",")) for r in SIXS.read_text().splitlines()[1:]]


@pytest.mark.parametrize("sza,vza,vaz,wl,tau,i6,q6,u6", sixs_cases())
def test_rayleigh_atmosphere_against_6sv(tmp_path, sza, vza, vaz, wl, tau, i6, q6, u6):
    """A Rayleigh atmosphere (no gas, no aerosol, depolarization 0.0279) over a black ground against 6SV 1.1's
    successive-orders vector code (Kotchenova et al. 2006), run on its own optical depth at 440, 550 and 670 nm:
    the top-of-atmosphere reflectance pi L / (mu_s E0) and its Q and U.  6SV's Q has the opposite sign of the
    Coulson-Dave-Sekera tables' (its "direction of the plane of polarization" is 90 deg where Q < 0: the electric
    vector normal to the meridian plane) and its U equals ours (a frame rotated by 90 deg from the tables':
    Q and U both change sign, and the tables' U is minus ours); fixed once here, at three geometries with U up to
    0.56 I.  I within 1 % plus 3 standard errors (6SV's own accuracy for Rayleigh is a few tenths of a percent),
    the degree of polarization within 0.01."""
    mu0, mu = math.cos(math.radians(sza)), math.cos(math.radians(vza))
    n = N_RAYS if tau > 0.1 else 2 * N_RAYS         # a thin atmosphere scatters less: more rays, same precision
    text = layer_script(0.0, mu0, mu, vaz - 180.0, True, n).replace("(0.5 / 1000 m)", f"({tau!r} / 1000 m)")
    assert "DEPOL 0 TOWARD" in text
    text = text.replace("DEPOL 0 TOWARD", "DEPOL 0.0279 TOWARD")
    res = trace_text(tmp_path, text, records=False)
    (i, q, u, v), (si, sq, su, sv) = eye_stokes(res, mu0, mu)
    i, q, u, si, sq, su = (x / mu0 for x in (i, q, u, si, sq, su))     # pi L / E0 -> pi L / (mu0 E0)
    q = -q                                                              # 6SV's sign of Q (docstring)
    assert si < 0.004 * i6
    assert abs(i - i6) <= 0.01 * i6 + 3 * si, (i, si, i6)
    assert abs(q - q6) <= 0.01 * i6 + 3 * sq, (q, sq, q6)
    assert abs(u - u6) <= 0.01 * i6 + 3 * su, (u, su, u6)
    assert abs(math.hypot(q, u) / i - math.hypot(q6, u6) / i6) <= 0.01
    assert v == 0.0
    assert ledger_gap(res) < 1e-12


def test_polarized_coating_by_jones_calculus(tmp_path):
    """COATING bs POLARIZED RS RP TS TP RETARDANCE TRETARDANCE on a beam splitter tilted by 30 deg (plane of
    incidence x, z; s = y), lit by light polarized at 45 deg to it (I = 1/2 after the polarizer).  By hand in
    Jones calculus, with the convention of docs/language.md (rs = sqrt Rs, rp = -sqrt(Rp) exp(i delta_r) on
    reflection, an ideal mirror's rp = -rs; ts = sqrt Ts, tp = sqrt(Tp) exp(i delta_t) on transmission), the field
    (1, 1)/sqrt 2 in (s, p) leaves as (rs, rp)/sqrt 2 or (ts, tp)/sqrt 2, whose frame-free invariants are
    |V| / I = 2 |Im(conj(a1) a2)| / I and the degree of linear polarization sqrt(Q^2 + U^2) / I: exact to rounding
    (every ray of the beam carries the same state).  A ray is reflected with probability (Rs + Rp)/2, transmitted
    with (Ts + Tp)/2, absorbed otherwise: the fluxes within 5 binomial sigmas, the ledger closed."""
    Rs, Rp, Ts, Tp, dr, dt = 0.9, 0.6, 0.05, 0.3, math.radians(30), math.radians(50)
    els = f"""COATING bs POLARIZED RS {Rs} RP {Rp} TS {Ts} TP {Tp} RETARDANCE 30 DEG TRETARDANCE 50 DEG
SURFACE
  PLANE Z 20 RECT 5 5
OBJECT pol
  INTERFACE POLARIZER 45
SURFACE
  PLANE Z 0 RECT 20 20
OBJECT face
  INTERFACE COATING bs AIR AIR
  ROTATE Y 30
""" + _det("rdet", "PLANE X 30 RECT 60 60") + _det("tdet", "PLANE Z -10 RECT 40 40")
    n = 20000
    res = trace_text(tmp_path, bench(els, n=n), records=False)
    for name, a1, a2, p in (("rdet", math.sqrt(Rs), -math.sqrt(Rp) * complex(math.cos(dr), math.sin(dr)),
                             0.5 * (Rs + Rp)),
                            ("tdet", math.sqrt(Ts), math.sqrt(Tp) * complex(math.cos(dt), math.sin(dt)),
                             0.5 * (Ts + Tp))):
        i, q, u, v = det_stokes(res, name)
        I = abs(a1) ** 2 + abs(a2) ** 2
        Q = abs(a1) ** 2 - abs(a2) ** 2
        z = complex(a1).conjugate() * a2
        assert abs(i - 0.5 * p) <= 5 * 0.5 * math.sqrt(p * (1 - p) / n), (name, i, 0.5 * p)
        assert abs(v) / i == pytest.approx(2 * abs(z.imag) / I, abs=1e-9), name
        assert math.hypot(q, u) / i == pytest.approx(math.hypot(Q, 2 * z.real) / I, abs=1e-9), name
        assert math.sqrt(q * q + u * u + v * v) / i == pytest.approx(1.0, abs=1e-9), name
    assert ledger_gap(res) < 1e-12


@pytest.mark.parametrize("line,message", [
    ("COATING alu METAL 0.958", "EXTINCTION"),          # METAL n without EXTINCTION k
    ("COATING bad POLARIZED RS 0.6 RP 0.3 TS 0.3 0.5",
     "3:1: error: coating bad: Rs + Ts = 0.6 + 0.5 = 1.1 > 1 on line 2 (550 nm)"),
])
def test_coating_mistakes(tmp_path, capsys, line, message):
    """A METAL without its extinction, or a POLARIZED coating with Rs + Ts > 1: an error at the line (with the
    polarization and the wavelength), exit 2, no traceback."""
    from irtlang.cli import main

    f = Path(tmp_path) / "c.inr"
    f.write_text(f"UNITS MM\nWAVELENGTHS 450 550 NM\n{line}\n")
    code = main(["check", str(f)])
    err = capsys.readouterr().err
    assert code == 2 and "c.inr:3:" in err and message in err and "Traceback" not in err, err
