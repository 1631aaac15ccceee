"""HG G g... TAU tau... ALBEDO w... [ORDERS n]

A Henyey-Greenstein slab (clouds, aerosols) with a Pfeiffer-Chapman effective multiple-scattering phase
function of ORDERS terms.  Reflects and transmits.

| parameter | unit | meaning |
|---|---|---|
| G | 1, per line | asymmetry parameter, in (-1, 1) |
| TAU | 1, per line | optical depth (>= 0) |
| ALBEDO | 1, per line | single-scattering albedo, in [0, 1] |
| ORDERS | count | number of scattering orders in the effective phase function (default 4) |
"""
from ...lang.spec import Clause, Form, PL, V, nonneg, positive, unit_interval

KIND = "HG"
FORM = Form((), (Clause("G", (PL("g", check=lambda x: None if -1 < x < 1 else "must be in (-1, 1)"),), required=True),
                 Clause("TAU", (PL("tau", check=nonneg),), required=True),
                 Clause("ALBEDO", (PL("albedo", check=unit_interval),), required=True),
                 Clause("ORDERS", (V("orders", integer=True, check=positive),))))
EXAMPLE = "MODEL cloud HG G 0.85 TAU 10 ALBEDO 0.9999 ORDERS 4"
TRANSMITS = True


def build(b, ctx) -> dict:
    return {"g": b["g"].values, "tau": b["tau"].values, "albedo": b["albedo"].values, "orders": b.get("orders", 4)}


def transmits(params) -> bool:
    return True
