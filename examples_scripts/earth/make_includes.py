"""Regenerate the include files of examples_scripts/earth.inr: python examples_scripts/earth/make_includes.py

They hold the Earth model's MODEL, MEDIUM and MAP lines on the script's 295 wavelength lines (300-2500 nm,
WAVELENGTHS RANGE 300 2500 295 NM), written by irtlang.earth.models.write_earth_includes (docs/earth.md says
where every number comes from).  tests/physics/test_earth_run.py checks that the shipped files are what this
script writes.
"""
from pathlib import Path

import numpy as np

from irtlang.earth.models import write_earth_includes

LINES_NM = np.linspace(300.0, 2500.0, 295)     # = WAVELENGTHS RANGE 300 2500 295 NM

if __name__ == "__main__":
    for name, path in write_earth_includes(Path(__file__).resolve().parent, LINES_NM, clamp=True).items():
        print(f"wrote {path}")
