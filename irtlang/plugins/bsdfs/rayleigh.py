"""RAYLEIGH TAU tau... [ALBEDO w...] [DEPOL rho]

A single-scattering Rayleigh slab (Ryu et al. 2017, eqs. 7-8): reflectance factors rho_R and rho_T with the
Rayleigh phase function including depolarization; BRDF = rho / pi.  Reflects and transmits.

| parameter | unit | meaning |
|---|---|---|
| TAU | 1, per line | optical depth (>= 0) |
| ALBEDO | 1, per line | single-scattering albedo (default 1) |
| DEPOL | 1 | depolarization factor rho_n (default 0.0279) |
"""
from ...lang.spec import Clause, Form, PL, V, nonneg, unit_interval

KIND = "RAYLEIGH"
FORM = Form((), (Clause("TAU", (PL("tau", check=nonneg),), required=True),
                 Clause("ALBEDO", (PL("albedo", check=unit_interval),)),
                 Clause("DEPOL", (V("depol", check=lambda x: None if 0 <= x < 1 else "must be in [0, 1)"),))))
EXAMPLE = "MODEL air RAYLEIGH TAU 0.097 ALBEDO 1 DEPOL 0.0279"
TRANSMITS = True


def build(b, ctx) -> dict:
    tau = b["tau"].values
    return {"tau": tau, "albedo": b["albedo"].values if "albedo" in b else (1.0,) * len(tau),
            "depol": b.get("depol", 0.0279)}


def transmits(params) -> bool:
    return True
