"""GLINT WIND speed INDEX n [ALBEDO a]

Ocean sun glint: Cox-Munk isotropic slope distribution (s^2 = 0.003 + 0.00512 U), Nakajima-Tanaka
shadowing and Fresnel reflection for water of index n, plus a water-leaving Lambert term of albedo
ALBEDO minus the glint's total integrated scatter.

| parameter | unit | meaning |
|---|---|---|
| WIND | speed (bare: m/s) | wind speed 12.5 m above the sea |
| INDEX | 1, per line | refractive index of water |
| ALBEDO | 1, per line | total albedo including the water-leaving term (default 0.02) |
"""
from ...lang.spec import Clause, Form, PL, V, nonneg, unit_interval
from ...lang.units import SPEED

KIND = "GLINT"
FORM = Form((), (Clause("WIND", (V("wind", SPEED, check=nonneg),), required=True),
                 Clause("INDEX", (PL("index", check=lambda x: None if x >= 1 else "must be >= 1"),), required=True),
                 Clause("ALBEDO", (PL("albedo", check=unit_interval),))))
EXAMPLE = "MODEL sea GLINT WIND 7 m/s INDEX 1.34 ALBEDO 0.02"
TRANSMITS = False


def build(b, ctx) -> dict:
    n = b["index"].values
    return {"wind": b["wind"], "index": n, "albedo": b["albedo"].values if "albedo" in b else (0.02,) * len(n)}


def transmits(params) -> bool:
    return False
