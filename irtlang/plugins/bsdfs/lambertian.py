"""LAMBERTIAN r [TRANSMIT t]

An ideal diffuser: BRDF = r / pi on the side the ray came from, BTDF = t / pi on the other; A = 1 - r - t.

| parameter | unit | meaning |
|---|---|---|
| r | 1, per line | hemispherical reflectance |
| TRANSMIT t | 1, per line | hemispherical transmittance (default 0) |
"""
from ...lang.diagnostics import error
from ...lang.spec import Clause, Form, PL, unit_interval

KIND = "LAMBERTIAN"
FORM = Form((PL("reflect", check=unit_interval),),
            (Clause("TRANSMIT", (PL("transmit", check=unit_interval),), doc="diffuse transmittance"),))
EXAMPLE = "MODEL paint LAMBERTIAN 0.5 TRANSMIT 0"
TRANSMITS = True


def build(b, ctx) -> dict:
    r = b["reflect"].values
    t = b["transmit"].values if "transmit" in b else (0.0,) * len(r)
    for i, (x, y) in enumerate(zip(r, t)):
        if x + y > 1.0 + 1e-12:
            raise error(b.span, f"LAMBERTIAN reflect + transmit = {x + y:g} > 1 on line {i + 1}")
    return {"reflect": r, "transmit": t}


def transmits(params) -> bool:
    return any(x > 0 for x in params["transmit"])
