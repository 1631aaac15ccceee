"""ROSSLI ISO f_iso... VOL f_vol... GEO f_geo...

The MODIS BRDF model (RossThick volumetric and LiSparse-Reciprocal geometric kernels):
R(ts, tv, phi) = f_iso + f_vol K_vol + f_geo K_geo, clamped to be non-negative; BRDF = R / pi.

| parameter | unit | meaning |
|---|---|---|
| ISO | 1, per line | isotropic kernel weight |
| VOL | 1, per line | RossThick weight |
| GEO | 1, per line | LiSparse-R weight |
"""
from ...lang.spec import Clause, Form, PL

KIND = "ROSSLI"
FORM = Form((), (Clause("ISO", (PL("iso"),), required=True), Clause("VOL", (PL("vol"),), required=True),
                 Clause("GEO", (PL("geo"),), required=True)))
EXAMPLE = "MODEL grass ROSSLI ISO 0.03 VOL 0.02 GEO 0.005"
TRANSMITS = False


def build(b, ctx) -> dict:
    return {"iso": b["iso"].values, "vol": b["vol"].values, "geo": b["geo"].values}


def transmits(params) -> bool:
    return False
