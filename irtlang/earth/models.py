"""The Earth model as script text: MODEL lines for the atmosphere layers, clouds, aerosols and surfaces, and the
include files an Earth script (examples_scripts/earth.inr) reads.

``write_earth_includes(folder, bands_nm)`` writes

* ``earth_surfaces.inr``: one model per LANDCOVER class (ocean glint, 15 land BRDFs, snow/ice), ``sea_ice`` and
  ``snow`` (irtlang.earth.surfaces);
* ``earth_atmosphere.inr``: ``air_1`` .. ``air_n``, one RAYLEIGH slab per layer, its TAU the Rayleigh optical
  depth (Bodhaine et al. 1999, USSA 1976 pressures; irtlang.earth.atmosphere) plus the gas absorption optical
  depth (irtlang.earth.gas) and its ALBEDO the Rayleigh share tau_R / (tau_R + tau_abs);
* ``earth_clouds.inr``: ``cloud_low``, ``cloud_middle``, ``cloud_high`` HG slabs (irtlang.earth.clouds) with the
  typical microphysics of ``CLOUD_LAYERS``;
* ``earth_aerosols.inr``: ``aer_<type>_<i>`` HG slabs for each of the five Earth aerosol types in each layer
  below 12 km (irtlang.earth.aerosols);
* ``earth_media.inr``: ``MEDIUM air_i INDEX ...``, the LOWTRAN 7 refractive index of each layer;
* ``earth_maps.inr``: the MAP lines of the default-tier datasets (``MAP cover LATLON DEFAULT LANDCOVER`` ...,
  the per-layer cloud maps ``CLOUD_LOW`` ... and the aerosol types ``AEROSOL_TYPE``).

Every value is per wavelength line, in the order of bands_nm: the script's WAVELENGTHS must list the same lines.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from . import aerosols, clouds, gas, surfaces
from .atmosphere import AFGL_ATMOSPHERES, AFGL_SHORT, rayleigh_tau_layers, rayleigh_tau_layers_afgl

# 15 layers, boundaries 0 .. 100 km: the layering used for the seed paper's atmosphere (and in the tests of
# irtlang.earth.atmosphere).
PAPER_LEVELS_KM = (0.0, 0.4, 0.8, 1.0, 1.5, 2.0, 3.0, 3.5, 5.0, 6.0, 10.0, 12.0, 25.0, 35.0, 50.0, 100.0)

# typical microphysics of the three cloud layers: (base km, top km, LWC g/m3, r_e um, IWC g/m3, D_ge um)
CLOUD_LAYERS = {
    "low": (1.0, 1.5, 0.20, 10.0, 0.0, 60.0),       # stratocumulus: tau ~ 16 at 550 nm
    "middle": (3.5, 5.0, 0.06, 12.0, 0.01, 50.0),   # altostratus, mixed phase: tau ~ 8
    "high": (10.0, 12.0, 0.0, 10.0, 0.01, 60.0),    # cirrus: tau ~ 0.8
}


def _fmt(v) -> str:
    return " ".join(f"{x:.6g}" for x in np.atleast_1d(v))


def atmosphere_layer_lines(bands_nm=surfaces.HRI_BANDS_NM, levels_km=PAPER_LEVELS_KM, *, prefix: str = "air",
                           gas_absorption: bool = True, atmosphere: str | None = None, suffix: str = "",
                           **gas_kw) -> list:
    """One `MODEL <prefix>_i<suffix> RAYLEIGH TAU ... ALBEDO ...` per layer (i = 1 at the ground).

    atmosphere: one of the AFGL 1986 profiles (irtlang.earth.atmosphere.AFGL_ATMOSPHERES): its pressures give the
    Rayleigh optical depths and its H2O and O3 profiles share the gas absorption (irtlang.earth.gas, 6SV band model
    per line); None: the US Standard Atmosphere 1976 with the mid-latitude summer gas absorption."""
    bands = list(bands_nm)
    if atmosphere is None:
        tr = rayleigh_tau_layers(levels_km, bands)
        atm = gas.DEFAULT_ATMOSPHERE
    else:
        tr = rayleigh_tau_layers_afgl(levels_km, bands, atmosphere)
        atm = atmosphere
    ta = (gas.layer_absorption(levels_km, bands, atmosphere=atm, **gas_kw)["total"] if gas_absorption
          else np.zeros_like(tr))
    out = []
    for i in range(tr.shape[0]):
        tau = tr[i] + ta[i]
        w = np.where(tau > 0, tr[i] / np.where(tau > 0, tau, 1.0), 1.0)
        out.append(f"MODEL {prefix}_{i + 1}{suffix} RAYLEIGH TAU {_fmt(tau)} ALBEDO {_fmt(np.clip(w, 0.0, 1.0))}")
    return out


BELT_MAP_FILE = "atmosphere_belts.npy"
BELT_MAP_NAME = "atmosphere"


def belt_atmosphere_lines(bands_nm=surfaces.HRI_BANDS_NM, levels_km=PAPER_LEVELS_KM, prefix: str = "air") -> list:
    """The layers of all five AFGL atmospheres, `<prefix>_i_<trop|mls|mlw|sas|saw>`, and the MAP line of the
    belt class map (`MAP atmosphere LATLON 'atmosphere_belts.npy'`, class k = AFGL_ATMOSPHERES[k]); an air shell
    then says `SCATTER MAP atmosphere MODELS air_i_trop air_i_mls air_i_mlw air_i_sas air_i_saw`."""
    out = [f"MAP {BELT_MAP_NAME} LATLON '{BELT_MAP_FILE}'     !! AFGL belts for 18-19 March (docs/earth.md)"]
    for atm in AFGL_ATMOSPHERES:
        out.append(f"!! {atm}")
        out += atmosphere_layer_lines(bands_nm, levels_km, prefix=prefix, atmosphere=atm, suffix=f"_{AFGL_SHORT[atm]}")
    return out


def cloud_lines(bands_nm=surfaces.HRI_BANDS_NM, layers=None, clamp: bool = False, spectral: bool = True) -> list:
    """Per cloud layer: `cloud_<layer>`, an EDDINGTON layer (the delta-Eddington energy partition of a thick
    cloud: its multiple scattering), and `cloud_<layer>_hg`, the seed paper's HG slab with the Pfeiffer-Chapman
    effective phase (a single-scattering slab: for optical depths of 10 it books a third of the light as absorbed;
    tests/physics/test_bsdf_eddington.py compares both with the exact VOLUME medium)."""
    out = []
    for name, (z0, z1, lwc, re, iwc, dge) in (layers or CLOUD_LAYERS).items():
        for suffix, kind in (("", "EDDINGTON"), ("_hg", "HG")):
            out.append(clouds.cloud_model_line(f"cloud_{name}{suffix}", bands_nm, thickness_km=z1 - z0, lwc_g_m3=lwc,
                                               r_eff_um=re, iwc_g_m3=iwc, d_ge_um=dge, clamp=clamp, kind=kind,
                                               spectral=spectral))
    return out


def media_lines(bands_nm=surfaces.HRI_BANDS_NM, levels_km=PAPER_LEVELS_KM, prefix: str = "air",
                month: int = 3) -> list:
    """`MEDIUM air_i INDEX ...` per layer (i = 1 at the ground): the refractive index of dry air, LOWTRAN 7 form
    (irtlang.earth.atmosphere.refractivity_lowtran), at the pressure and temperature of the layer's mid-height
    under the five AFGL 1986 profiles, averaged with the area of their latitude belts in the month (one medium
    per layer: an INTERFACE cannot follow a map; the belts' n - 1 differ by up to 17 % at the ground, where n - 1
    is 3e-4, so the refraction of a ray crossing the atmosphere differs by less than 5e-5 rad), one value per
    line; the space above the last level is VACUUM."""
    from .atmosphere import afgl_pt, belt_area_weights, refractivity_lowtran

    wts = belt_area_weights(month)
    out = []
    for i in range(len(levels_km) - 1):
        zm = 0.5 * (levels_km[i] + levels_km[i + 1])
        nm1 = 0.0
        for atm, w in wts.items():
            t, p = afgl_pt(atm, zm)
            nm1 = nm1 + w * refractivity_lowtran(np.asarray(bands_nm, float), float(p), float(t))
        out.append(f"MEDIUM {prefix}_{i + 1} INDEX " + " ".join(f"{1.0 + v:.9f}" for v in nm1))
    return out


def aerosol_lines(bands_nm=surfaces.HRI_BANDS_NM, levels_km=PAPER_LEVELS_KM, types=aerosols.EARTH_TYPES,
                  top_km: float = 12.0) -> list:
    out = []
    z = [v for v in levels_km if v <= top_km]
    for t in types:
        tau, w, g = aerosols.layer_optics(t, z, bands_nm)
        for i in range(tau.shape[0]):
            out.append(f"MODEL aer_{t.replace(' ', '_')}_{i + 1} HG G {_fmt(g[i])} TAU {_fmt(tau[i])} "
                       f"ALBEDO {_fmt(w[i])} ORDERS 1")
    return out


def _header(what: str, bands_nm) -> list:
    return [f"!! {what} -- written by irtlang.earth.models for the lines {_fmt(bands_nm)} nm",
            f"!! (the script must say: WAVELENGTHS {_fmt(bands_nm)} NM)"]


def write_earth_includes(folder, bands_nm=surfaces.HRI_BANDS_NM, *, clamp: bool = False) -> dict:
    """Write the include files and the AFGL belt map (atmosphere_belts.npy) into folder; returns {name: path}.
    The clouds' optics come from Mie theory at every line (300-2500 nm); clamp only matters for the seven-band
    tables (land BRDFs, water-leaving reflectance), which hold their end values outside 350-950 nm."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    bands = [float(b) for b in bands_nm]
    files = {
        "earth_surfaces.inr": _header("surfaces: LANDCOVER classes 0..16, sea_ice, snow", bands)
        + surfaces.landcover_model_lines(bands),
        "earth_atmosphere.inr": _header("atmosphere: Rayleigh + gas absorption (6SV per line) per layer, ground up, "
                                        "for the five AFGL 1986 atmospheres", bands)
        + [f"!! layer boundaries (km): {_fmt(PAPER_LEVELS_KM)}"] + belt_atmosphere_lines(bands),
        "earth_clouds.inr": _header("clouds: low (liquid), middle (mixed), high (ice)", bands)
        + cloud_lines(bands, clamp=clamp),
        "earth_media.inr": _header("media: air of each layer (LOWTRAN 7 refractive index, AFGL belts' mean), ground up",
                                   bands)
        + media_lines(bands),
        "earth_aerosols.inr": _header("aerosols: OPAC types per layer below 12 km", bands) + aerosol_lines(bands),
    }
    maps = ["MAP cover LATLON DEFAULT LANDCOVER", "MAP land LATLON DEFAULT LAND_MASK",
            "MAP snow LATLON DEFAULT SNOW_FRACTION", "MAP seaice LATLON DEFAULT SEA_ICE_FRACTION",
            "MAP clouds LATLON DEFAULT CLOUD_FRACTION"]
    for layer in ("low", "middle", "high"):
        maps.append(f"MAP cloud_{layer} LATLON DEFAULT CLOUD_{layer.upper()}")
    maps.append("MAP aerosol LATLON DEFAULT AEROSOL_TYPE")
    files["earth_maps.inr"] = ["!! maps of the default data tier (irtlang.earth.data)"] + maps
    out = {}
    from .atmosphere import afgl_belt_map
    from ..io.atomic import atomic_path

    bp = folder / BELT_MAP_FILE
    with atomic_path(bp) as tmp:
        with open(tmp, "wb") as f:
            np.save(f, afgl_belt_map(36))
        os.chmod(tmp, 0o644)
    out[BELT_MAP_FILE] = bp
    # its sidecar: built-in data (the default tier), so a run's manifest names the tier it used
    side = folder / (BELT_MAP_FILE + ".json")
    side.write_text(json.dumps({"tier": "default", "source": "AFGL 1986 profiles by latitude belt for March "
                                "(irtlang.earth.atmosphere.afgl_belt_map)", "proxy": False}, indent=1) + "\n")
    out[BELT_MAP_FILE + ".json"] = side
    for name, lines in files.items():
        p = folder / name
        p.write_text("\n".join(lines) + "\n")
        out[name] = p
    return out
