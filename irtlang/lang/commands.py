"""The command table: each command's signature (irtlang.lang.spec), handler and reference entry.

``TABLE`` maps the command's keyword to a ``CommandDef``.  Kinds that have plugins (surfaces, scatter
models, sources) take their signatures from the plugin registries, so a new kind needs no change here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from . import ast as A
from ..core.diagnostics import Span, did_you_mean, error
from .expr import evaluate, format_value
from .spec import (MAX_REPEAT, Axis, Choice, Clause, Form, Name, Param, Path, PL, Ref, Rest, V, Variants, Vs,
                   match_keyword, nonneg, positive, unit_interval)
from ..core.units import ANGLE, INV_LENGTH, LENGTH, LENGTH_UNITS, NONE, POWER, TIME, Quantity
from ..model import scene as M
from .state import State, StopScript, _SurfaceBlock
from ..plugins.bsdfs import REGISTRY as BSDFS
from ..plugins.sources import REGISTRY as SOURCES, of_role
from ..plugins.surfaces import REGISTRY as SURFACES


@dataclass(frozen=True)
class CommandDef:
    head: str
    form: Form | None
    handler: Callable
    section: str
    summary: str


TABLE: dict[str, CommandDef] = {}


def command(head: str, form: Form | None, section: str, summary: str):
    def deco(fn):
        TABLE[head] = CommandDef(head, form, fn, section, summary)
        return fn
    return deco


def usages(head: str) -> list[str]:
    c = TABLE[head]
    return c.form.usages(head) if c.form is not None else [head]


# ==================================================================== 2. variables, control, files
@command("CALL", Form((Name("macro"), Rest("args"))), "control", "run a MACRO with arguments")
def _call(it, b, st):
    it.call(b["macro"], b["args"], b.span, b.span_of("macro"))


@command("DEFAULT", Form((Name("name"), Rest("value"))), "control",
         "give a variable a value unless it has one already (irt run FILE --set name=value)")
def _default(it, b, st):
    if it.is_variable(b["name"]):
        return
    items = b["value"]
    if len(items) != 1:
        raise error(b.span, f"DEFAULT {b['name']} needs one value (an expression in parentheses for more)",
                    f"DEFAULT {b['name']} (expression)")
    it.assign(b["name"], evaluate(items[0], it.env), b.span)


@command("INCLUDE", Form((Path("file"),)), "control", "run another script here (path relative to this file)")
def _include(it, b, st):
    it.include(b["file"], b.span_of("file"))


@command("PRINT", Form((Rest("items"),)), "control", "print strings ({expr} interpolated) and values")
def _print(it, b, st):
    it.print(_message(it, b["items"]))


def _message(it, items) -> str:
    """PRINT and ERROR: strings ({expr} interpolated) and values in the script's units, joined by spaces."""
    parts = []
    for item in items:
        v = evaluate(item, it.env)
        parts.append(v if isinstance(v, str) else format_value(v, it.env) if v.dim in (None, NONE)
                     else v.describe(it.state.units))
    return " ".join(parts)


@command("MACRO", None, "control", "MACRO name [param ...] ... END MACRO: a named block with parameters")
def _macro(it, b, st):  # MACRO blocks are built by the parser; reaching here means no END MACRO followed
    raise error(st.span, "MACRO without END MACRO")


@command("STOP", Form(), "control", "end the script here")
def _stop(it, b, st):
    raise StopScript()


@command("ERROR", Form((Rest("items"),)), "control",
         "report an error here with the message ({expr} interpolated) and end the script")
def _error_cmd(it, b, st):
    from ..core.diagnostics import Diagnostic

    it.diags.add(Diagnostic(b.span, _message(it, b["items"]) or "ERROR"))
    raise StopScript()


# ==================================================================== 3. system
@command("SYSTEM", Form((Choice("what", ("NEW",)),)), "system", "SYSTEM NEW forgets every definition")
def _system(it, b, st):
    it.state = State()


@command("RESET", Form(), "system", "forget sources, rays and results; keep geometry")
def _reset(it, b, st):
    it.state.sources.clear()
    it.state.pending_grid = None
    it.step("RESET", {}, b.span, with_scene=False)


@command("EPOCH", Form((Path("utc"),), (Clause("PLUS", (V("dt", TIME),), doc="a time added to the date"),)),
         "system", "a date and time (UTC): sets the Sun's position and the Earth's sidereal angle as variables")
def _epoch(it, b, st):
    """EPOCH '2008-03-18T18:19' [PLUS 3 H] (or a file name holding one EPOCH_TAG) sets EPOCH_UTC and EPOCH_TAG
    (strings), EPOCH_TIME (a time since 2000-01-01 12:00 UTC), GAST (Greenwich apparent
    sidereal time), SUN_RA, SUN_DEC, SUBSOLAR_LAT, SUBSOLAR_LON (angles) and SUN_DIST (a length), from the
    solar ephemeris of irtlang.earth.ephemeris (Meeus; 0.01 deg, years 1800-2200).  The frame of SUN_RA and
    SUN_DEC is the equatorial frame of date (x to the equinox, z to the pole); an Earth-fixed frame turns from
    it by GAST about z."""
    import datetime as _dt

    from ..earth.ephemeris import AU_M, YEAR_MAX, YEAR_MIN, sun_position

    import re

    text = b["utc"].strip()
    try:
        t = _dt.datetime.fromisoformat(text.replace("Z", "").replace(" UTC", ""))
    except ValueError:
        # a text holding an EPOCH_TAG, such as a frame's file name: 'frames/20080318T1819_550nm.npy'
        tags = re.findall(r"(?<!\d)(\d{8}T\d{4})(?!\d)", text.replace("\\", "/").rsplit("/", 1)[-1])
        t = _dt.datetime.strptime(tags[-1], "%Y%m%dT%H%M") if len(tags) == 1 else None
        if t is None:
            raise error(b.span_of("utc"), f"EPOCH '{text}' is not a date and time" + (
                        f" (its name holds {len(tags)} EPOCH_TAGs)" if tags else ""),
                        "write it as ISO 8601 UTC: '2008-03-18T18:19' or '2008-03-18 18:19:00', or give a file "
                        "name holding one EPOCH_TAG (YYYYMMDDTHHMM), as 'frames/20080318T1819_550nm.npy'") from None
    if t.tzinfo is not None:
        t = t.astimezone(_dt.timezone.utc).replace(tzinfo=None)
    if "dt" in b:
        t = t + _dt.timedelta(seconds=float(b["dt"]))
    if not YEAR_MIN <= t.year <= YEAR_MAX:
        raise error(b.span_of("utc") if "dt" not in b else b.span, f"EPOCH {t:%Y-%m-%d %H:%M} is outside the solar "
                    f"ephemeris' range (years {YEAR_MIN}-{YEAR_MAX})", "irtlang's ephemeris is Meeus' low-precision "
                    "series (irtlang.earth.ephemeris), good to 0.01 deg only in that range")
    sp = sun_position(t)
    d = math.pi / 180.0
    it.assign("EPOCH_UTC", t.strftime("%Y-%m-%dT%H:%M:%S"), b.span)
    it.assign("EPOCH_TAG", t.strftime("%Y%m%dT%H%M"), b.span)
    # the time since 2000-01-01 12:00 UTC (no leap seconds): differences of dates as times, (t2 - t1) / 1 H
    it.assign("EPOCH_TIME", Quantity((t - _dt.datetime(2000, 1, 1, 12)).total_seconds(), TIME), b.span)
    for name, v in (("GAST", sp.gast_deg), ("SUN_RA", sp.ra_deg), ("SUN_DEC", sp.dec_deg),
                    ("SUBSOLAR_LAT", sp.subsolar_lat_deg), ("SUBSOLAR_LON", sp.subsolar_lon_deg)):
        it.assign(name, Quantity(v * d, ANGLE), b.span)
    it.assign("SUN_DIST", Quantity(sp.distance_au * AU_M, LENGTH), b.span)


@command("UNITS", Form((Choice("unit", LENGTH_UNITS),)), "system", "the unit of bare lengths (default MM)")
def _units(it, b, st):
    it.state.units = b["unit"]


@command("WAVELENGTHS", Form((Variants("how", {"RANGE": Form((Rest("range"),))},
                                       default=Form((Vs("lines", LENGTH),))),)),
         "system", "the system's wavelength lines")
def _wavelengths(it, b, st):
    if b.variants.get("how") == "RANGE":
        items = b["range"]
        if len(items) != 3:
            raise error(b.span_of("range") if items else b.span,
                        f"WAVELENGTHS RANGE expects 3 values (first last count), got {len(items)}")
        lo_i, hi_i, n_i = items
        unit = n_i.unit if isinstance(n_i, A.Num) and n_i.unit else None
        if isinstance(n_i, A.Num) and n_i.unit:
            n_i = A.Num(n_i.value, None, n_i.text, n_i.span)
        vals = []
        for x in (lo_i, hi_i):
            if unit and isinstance(x, A.Num) and x.unit is None:
                x = A.Num(x.value, unit, x.text, x.span)
            vals.append(it.to_dim(evaluate(x, it.env), LENGTH, x.span))
        nq = it.to_dim(evaluate(n_i, it.env), NONE, n_i.span)
        if nq != int(nq) or nq < 1:
            raise error(n_i.span, f"WAVELENGTHS RANGE count must be a whole number >= 1, got {nq:g}")
        if nq > MAX_REPEAT:
            raise error(n_i.span, f"WAVELENGTHS RANGE count is {nq:g}; at most {MAX_REPEAT} lines")
        n = int(nq)
        if n == 1:
            lines = [vals[0]]
        else:
            lines = [vals[0] + (vals[1] - vals[0]) * i / (n - 1) for i in range(n)]
        span = b.span
    else:
        lines = list(b["lines"])
        span = b.span_of("lines")
    for i, w in enumerate(lines):
        if not 1e-9 <= w <= 1e-3:
            nm = w * 1e9
            raise error(span, f"wavelength {w / it.length_factor():g} {it.state.units.lower()} "
                        f"({nm:g} nm) is outside 1 nm .. 1 mm", "give the unit: WAVELENGTHS 450 550 650 NM")
    nm = tuple(round(w * 1e9, 9) for w in lines)   # 300 nm stays 300, not 300.00000000000006
    if len(set(nm)) != len(nm):  # a line's band would have zero width (spectra rebin to NaN)
        dup = next(x for x in nm if nm.count(x) > 1)
        raise error(span, f"WAVELENGTHS lists {dup:g} nm more than once", "give each line a different wavelength")
    st_ = it.state
    if st_.first_per_line is not None and nm != tuple(st_.wavelengths_nm):
        # values already given (spectra rebinned, tables interpolated) belong to the old lines
        what = "the number of lines" if len(nm) != len(st_.wavelengths_nm) else "the wavelength lines"
        raise error(b.span, f"WAVELENGTHS changes {what} after wavelength-dependent values were "
                    "given", "put WAVELENGTHS first", notes=[(st_.first_per_line, "first wavelength-dependent value")])
    st_.wavelengths_nm = nm
    st_.wavelengths_span = b.span


@command("SEED", Form((V("seed", integer=True, check=lambda x: nonneg(x) or (
    "must be below 2^63 (a 63-bit seed)" if x >= 2 ** 63 else None)),)), "system", "the random seed of the run")
def _seed(it, b, st):
    it.state.seed = b["seed"]


# ==================================================================== 4. materials and models
def _index_check(x):
    return None if x > 0 else "must be > 0"


_VOLUME = (
    Clause("ABSORB", (PL("absorb", INV_LENGTH, check=nonneg),), doc="absorption coefficient (Beer's law)"),
    Clause("VOLUME", (), doc="a scattering volume: needs EXTINCTION, takes ALBEDO, PHASE, G, DEPOL, RAYS, TOWARD"),
    Clause("EXTINCTION", (PL("extinction", INV_LENGTH, check=nonneg),), doc="extinction coefficient of the volume"),
    Clause("ALBEDO", (PL("albedo", check=unit_interval),), doc="single-scattering albedo (default 1)"),
    Clause("PHASE", (Choice("phase", ("RAYLEIGH", "HG")),), doc="phase function (default RAYLEIGH)"),
    Clause("G", (PL("g", check=lambda x: None if -1 < x < 1 else "must be in (-1, 1)"),), doc="HG asymmetry"),
    Clause("DEPOL", (V("depol", check=lambda x: None if 0 <= x < 1 else "must be in [0, 1)"),),
           doc="Rayleigh depolarization factor (default 0.0279)"),
    Clause("RAYS", (V("rays", integer=True, check=positive),), doc="rays sent TOWARD the target per event"),
    Clause("TOWARD", (Name("toward"),), doc="next-event rays from each volume scattering toward an object"),
)


@command("MEDIUM", Form((Name("name"), Variants("kind", {
    "INDEX": Form((PL("index", check=_index_check),), _VOLUME),
    "SELLMEIER": Form((Vs("coefficients", n=6),), _VOLUME),
    "TABLE": Form((Path("file"),), _VOLUME),
}))), "materials", "a medium: INDEX per line, SELLMEIER or TABLE; ABSORB; VOLUME scattering")
def _medium(it, b, st):
    from ..io.tables import read_table

    name, kind = b["name"], b.variants["kind"]
    it.fail("medium", name)
    lam_um = [w * 1e-3 for w in it.state.wavelengths_nm]
    params = {}
    absorb = b["absorb"].values if "absorb" in b else (0.0,) * it.n_lines()
    if kind == "INDEX":
        n = b["index"].values
    elif kind == "SELLMEIER":
        B1, B2, B3, C1, C2, C3 = b["coefficients"]
        n = []
        for l in lam_um:
            l2 = l * l
            n2 = 1 + B1 * l2 / (l2 - C1) + B2 * l2 / (l2 - C2) + B3 * l2 / (l2 - C3)
            if n2 <= 0:
                raise error(b.span_of("coefficients"), f"SELLMEIER gives n^2 = {n2:g} <= 0 at {l * 1e3:g} nm")
            n.append(math.sqrt(n2))
        n = tuple(n)
        params = dict(zip(("B1", "B2", "B3", "C1", "C2", "C3"), b["coefficients"]))
    else:
        path = it.input_path(b["file"], b.span_of("file"))
        tab = read_table(path, b.span_of("file"), min_cols=2, max_cols=3, what="wavelength_nm, n[, k]")
        n = tuple(tab.interp(1, it.state.wavelengths_nm, b.span_of("file")))
        if tab.ncols == 3 and "absorb" not in b:
            k = tab.interp(2, it.state.wavelengths_nm, b.span_of("file"))
            absorb = tuple(4 * math.pi * kk / (w * 1e-9) for kk, w in zip(k, it.state.wavelengths_nm))
        params = {"file": str(path)}
        it.n_lines()
    vol_keys = ("extinction", "albedo", "phase", "g", "depol", "rays", "toward")
    if "volume" in b:
        if "extinction" not in b:
            raise error(b.spans["kw:VOLUME"], "a VOLUME medium needs EXTINCTION (per unit length)",
                        "e.g. EXTINCTION (0.0971 / 1 km) for an optical depth of 0.0971 per km")
        L = it.n_lines()
        phase = b.get("phase", "RAYLEIGH")
        if phase == "HG" and "g" not in b:
            raise error(b.span_of("phase"), "PHASE HG needs G (the asymmetry parameter)")
        if phase == "RAYLEIGH" and "g" in b:
            raise error(b.spans["kw:G"], "G applies to PHASE HG, not RAYLEIGH")
        params["volume"] = {"extinction": b["extinction"].values,
                            "albedo": b["albedo"].values if "albedo" in b else (1.0,) * L,
                            "phase": phase, "g": b["g"].values if "g" in b else (0.0,) * L,
                            "depol": b.get("depol", 0.0279), "rays": b.get("rays", 1),
                            "toward": b["toward"].upper() if "toward" in b else None}
    else:
        for key in vol_keys:
            if key in b:
                raise error(b.spans.get("kw:" + key.upper(), b.span), f"{key.upper()} belongs to a VOLUME medium",
                            "add VOLUME to make the medium scatter")
    it.define("medium", name.upper(), M.Medium(name, kind.lower(), tuple(n), tuple(absorb), M.frozen_params(params), b.span), b.span)


@command("COATING", Form((Name("name"), Variants("kind", {
    "REFLECT": Form((PL("reflect", check=unit_interval),), (Clause("TRANSMIT", (PL("transmit", check=unit_interval),)),)),
    "TRANSMIT": Form((PL("transmit", check=unit_interval),), (Clause("REFLECT", (PL("reflect", check=unit_interval),)),)),
    "FRESNEL": Form(),
    "METAL": Form((PL("n", check=positive),), (Clause("EXTINCTION", (PL("k", check=nonneg),), required=True,
                                                       doc="the extinction coefficient k: the index is n + i k"),)),
    "POLARIZED": Form((), (
        Clause("RS", (PL("rs", check=unit_interval),), required=True, doc="reflectance for s (TE) light"),
        Clause("RP", (PL("rp", check=unit_interval),), required=True, doc="reflectance for p (TM) light"),
        Clause("TS", (PL("ts", check=unit_interval),), doc="transmittance for s light (default 0)"),
        Clause("TP", (PL("tp", check=unit_interval),), doc="transmittance for p light (default 0)"),
        Clause("RETARDANCE", (PL("delta_r", ANGLE),),
               doc="on reflection: the phase of rp over rs beyond an ideal mirror's (default 0)"),
        Clause("TRETARDANCE", (PL("delta_t", ANGLE),), doc="on transmission: the phase of tp over ts (default 0)"))),
}))), "materials", "a coating: R and T per line (A = 1 - R - T), FRESNEL, METAL n EXTINCTION k (a complex index "
                   "n + i k), or POLARIZED RS rs RP rp [TS ts TP tp] [RETARDANCE d] [TRETARDANCE d]")
def _coating(it, b, st):
    name, kind = b["name"], b.variants["kind"]
    it.fail("coating", name)
    if kind == "FRESNEL":
        c = M.Coating(name, "fresnel", (), (), b.span)
    elif kind == "METAL":
        c = M.Coating(name, "metal", tuple(b["n"].values), tuple(b["k"].values), b.span)
    elif kind == "POLARIZED":
        n = it.n_lines()
        per = {}
        for k in ("rs", "rp", "ts", "tp", "delta_r", "delta_t"):
            v = tuple(float(x) for x in b[k].values) if k in b else (0.0,)
            per[k] = v * n if len(v) == 1 else v
        for pol in "sp":
            r, t = per["r" + pol], per["t" + pol]
            for i in range(n):
                if r[i] + t[i] > 1.0 + 1e-12:
                    raise error(b.span, f"coating {name}: R{pol} + T{pol} = {r[i]:g} + {t[i]:g} = {r[i] + t[i]:g} > 1 "
                                f"on line {i + 1} ({it.state.wavelengths_nm[i]:g} nm)", "R + T + A = 1 for each polarization")
        half = lambda a, b_, sign: tuple(0.5 * (x + sign * y) for x, y in zip(a, b_))  # noqa: E731
        c = M.Coating(name, "rt", half(per["rs"], per["rp"], 1), half(per["ts"], per["tp"], 1), b.span,
                      polarized=(half(per["rs"], per["rp"], -1), half(per["ts"], per["tp"], -1), per["delta_r"],
                                 per["delta_t"]))
    else:
        n = it.n_lines()
        r = b["reflect"].values if "reflect" in b else (0.0,) * n
        t = b["transmit"].values if "transmit" in b else (0.0,) * n
        for i, (x, y) in enumerate(zip(r, t)):
            if x + y > 1.0 + 1e-12:
                raise error(b.span, f"coating {name}: R + T = {x:g} + {y:g} = {x + y:g} > 1 on line {i + 1} "
                            f"({it.state.wavelengths_nm[i]:g} nm)", "R + T + A = 1 with A >= 0")
        c = M.Coating(name, "rt", tuple(r), tuple(t), b.span)
    it.define("coating", name.upper(), c, b.span)


@command("SPECTRUM", Form((Variants("kind", {
    "OF": Form((Ref("object", "object"), Path("file", optional=True)), (
        Clause("STOKES", (), doc="a polarized trace's I, Q, U, V per line from the object's one-pixel DETECTOR"),)),
}, default=Form((Name("name"), Variants("source", {
    "SOLAR": Form((), (Clause("TSI", (V("tsi", (-2, 0, 0, 1, 0), check=positive),), doc="total solar irradiance at 1 AU"),)),
    "TABLE": Form((Path("file"),)),
    "BLACKBODY": Form((V("temperature", (0, 0, 0, 0, 1),  # beyond 1e6 K the Planck law overflows a float
                         check=lambda t: None if 0 < t <= 1e6 else "must be in (0, 1e6] K"),)),
}))))),), "materials", "define a spectrum (SOLAR, TABLE, BLACKBODY); SPECTRUM OF obj: flux per line")
def _spectrum(it, b, st):
    if b.variants["kind"] == "OF":
        it.assign("SPECTRUM_FLUX", Quantity(0.0, POWER), b.span)      # set by the run; 0 under irt check
        it.assign("SPECTRUM_FLUX_SE", Quantity(0.0, POWER), b.span)
        it.step("SPECTRUM_OF", {"object": b["object"], "file": b.get("file"), "stokes": "stokes" in b}, b.span)
        return
    from ..io.spectra import make_spectrum

    name = b["name"]
    it.fail("spectrum", name)
    sp = make_spectrum(it, b, name, b.variants["source"])
    it.define("spectrum", name.upper(), sp, b.span)


def _model_form() -> Form:
    return Form((Name("name"), Variants("kind", {k: m.FORM for k, m in BSDFS.items()})))


@command("MODEL", _model_form(), "materials", "a scatter model (BSDF): " + ", ".join(BSDFS))
def _model(it, b, st):
    name, kind = b["name"], b.variants["kind"]
    it.fail("model", name)
    params = BSDFS[kind].build(b, it)
    it.define("model", name.upper(), M.ScatterModel(name, kind, M.frozen_params(params), b.span), b.span)


MAP_DATASETS = ("LANDCOVER", "LAND_MASK", "CLOUD_FRACTION", "SNOW_FRACTION", "SEA_ICE_FRACTION", "ELEVATION",
                "CLOUD_LOW", "CLOUD_MIDDLE", "CLOUD_HIGH", "AEROSOL_TYPE")


@command("MAP", Form((Name("name"), Variants("kind", {"LATLON": Form((Variants("from", {
    "DEFAULT": Form((Choice("dataset", MAP_DATASETS),),
                    (Clause("AT", (V("at", TIME),), doc="the cloud maps that many hours after the generator's start"),)),
    "MERRA2": Form((Path("files"), Name("variable")))}, default=Form((Path("file"),))),))}))),
         "materials", "a global latitude-longitude grid from a file, a built-in dataset or MERRA-2 files")
def _map(it, b, st):
    """MAP name LATLON DEFAULT dataset [AT t]: a default-tier dataset; AT takes the generated cloud maps (CLOUD_LOW,
    CLOUD_MIDDLE, CLOUD_HIGH, CLOUD_FRACTION) t after the generator's start (they drift and renew hour by hour:
    docs/earth.md).  MAP name LATLON MERRA2 'files' VARIABLE: the MERRA-2 field (e.g. CLDLOW of the hourly
    M2T1NXRAD files; 'files' may hold * and ?) at the current EPOCH, quantized to the ten cloud levels of the
    default tier (irtlang.earth.products.merra2_cloud_map)."""
    name = b["name"]
    it.fail("map", name)
    how = b.variants["from"]
    if how == "DEFAULT":
        m = M.MapDef(name, "LATLON", None, b["dataset"], b.span)
        if "at" in b:
            from ..earth.data import DatasetUnavailable, hourly_cloud_path

            try:
                p = hourly_cloud_path(b["dataset"], float(b["at"]) / 3600.0)
            except DatasetUnavailable as e:
                raise error(b.span_of("dataset"), f"MAP {name} LATLON DEFAULT {b['dataset']} AT: {e}",
                            "only CLOUD_LOW, CLOUD_MIDDLE, CLOUD_HIGH and CLOUD_FRACTION change with time") from None
            m = M.MapDef(name, "LATLON", str(p), None, b.span)
    elif how == "MERRA2":
        when = it.lookup("EPOCH_UTC")
        if when is None:
            raise error(b.span, "MAP ... MERRA2 needs the date: no EPOCH has been set",
                        "write EPOCH '2008-03-18T18:19' (or EPOCH ... PLUS t) before the MAP line")
        files = _merra2_files(it, b["files"], b.span_of("files"))
        from ..earth.products import ProductError, merra2_cloud_map

        try:
            p = merra2_cloud_map(files, b["variable"], str(when))
        except (ProductError, OSError) as e:
            raise error(b.span_of("files"), f"MAP {name} LATLON MERRA2: {e}") from None
        m = M.MapDef(name, "LATLON", str(p), None, b.span)
    else:
        from ..io.maps import check_latlon_file

        path = it.input_path(b["file"], b.span_of("file"))
        check_latlon_file(path, b.span_of("file"))
        m = M.MapDef(name, "LATLON", str(path), None, b.span)
    it.define("map", name.upper(), m, b.span)


def _merra2_files(it, pattern: str, span) -> list:
    """The files a MERRA2 pattern names (relative to the script's folder; * and ? allowed)."""
    import glob
    from pathlib import Path as _P

    base = it.include_stack[-1].parent if it.include_stack else it.base_dir
    pat = pattern if _P(pattern).is_absolute() else str(_P(base) / pattern)
    found = sorted(_P(f) for f in glob.glob(pat) if _P(f).is_file())
    if not found:
        raise error(span, f"no MERRA-2 file matches '{pattern}' (looked in {_P(pat).parent})",
                    "give the M2T1NXRAD files of the run's days, e.g. 'merra/MERRA2_300.tavg1_2d_rad_Nx.200803*.nc4'")
    return found


# ==================================================================== 5. geometry
@command("SURFACE", Form(), "geometry", "start a geometry block (closed by OBJECT name)")
def _surface(it, b, st):
    if it.state.block is not None:
        prev = it.state.block.span
        it.state.block = _SurfaceBlock(b.span)
        raise error(b.span, "SURFACE inside an open SURFACE block", "close the previous block with OBJECT name",
                    notes=[(prev, "the open block")])
    it.state.block = _SurfaceBlock(b.span)
    it.state.current = None


def _surface_cmd(kind):
    mod = SURFACES[kind]

    def handler(it, b, st):
        if it.state.block is None:
            raise error(b.head_span, f"{kind} must be inside a SURFACE block", "write SURFACE on the line before")
        it.state.block.surfaces.append(mod.build(b, it))
    TABLE[kind] = CommandDef(kind, mod.FORM, handler, "geometry", (mod.__doc__ or "").strip().splitlines()[0])


for _k in SURFACES:
    _surface_cmd(_k)


@command("OBJECT", Form((Name("name"),)), "geometry", "close a SURFACE block: the object, now current")
def _object(it, b, st):
    name = b["name"]
    blk = it.state.block
    if blk is None:
        raise error(b.head_span, "OBJECT without SURFACE", "start the geometry with SURFACE")
    it.state.block = None
    if blk.failed:  # a surface of the block failed: the object is not defined, without another error
        raise it.follow_on(b.span, f"object {name} was not defined because one of its surfaces failed")
    if not blk.surfaces:
        raise error(b.span, f"object {name} has no surface", "put PLANE, CONIC, SPHERE, ... between SURFACE and OBJECT")
    it.fail("object", name)
    obj = M.SceneObject(name, tuple(blk.surfaces), M.IDENTITY, group=it.current_group(), span=b.span)
    it.define("object", name.upper(), obj, b.span, unique=True)
    it.state.current = name.upper()


def _upper(name):
    return name.upper() if name is not None else None


def _current(it, b) -> M.SceneObject:
    key = it.state.current
    if key is None:
        raise error(b.head_span, f"{b.head} has no current object to modify",
                    "modifiers apply to the object of the last SURFACE ... OBJECT name; put it after OBJECT")
    if key not in it.state.objects:  # the current object's definition failed: skip its modifiers
        raise it.follow_on(b.head_span, f"{b.head} has no object to modify: the last OBJECT failed")
    return it.state.objects[key]


def _update(it, obj, **kw):
    it.state.objects[obj.name.upper()] = M.replace(obj, **kw)


@command("INTERFACE", Form((Variants("kind", {
    "COATING": Form((Ref("coating", "coating"), Ref("back", "medium"), Ref("front", "medium"))),
    "REFLECT": Form(),
    "ABSORB": Form(),
    "TRANSMIT": Form((Ref("back", "medium"), Ref("front", "medium"))),
    "POLARIZER": Form((V("angle", ANGLE), Ref("back", "medium", optional=True), Ref("front", "medium", optional=True))),
    "RETARDER": Form((V("angle", ANGLE), V("retardance", ANGLE), Ref("back", "medium", optional=True),
                      Ref("front", "medium", optional=True))),
}),)), "geometry", "the current object's optical interface")
def _interface(it, b, st):
    obj = _current(it, b)
    kind = b.variants["kind"].lower()
    back = b.get("back", "AIR")
    front = b.get("front", back if kind in ("polarizer", "retarder") else "AIR")
    itf = M.Interface(kind, b.get("coating"), back, front, b.span, b.get("angle", 0.0), b.get("retardance", 0.0))
    if obj.where is not None and not _clear_where(itf):
        raise error(b.span, f"object {obj.name} has OPAQUE WHERE: its INTERFACE must stay TRANSMIT with one medium "
                    "on both sides (clear where it is absent)", "INTERFACE TRANSMIT m m")
    _update(it, obj, interface=itf)


@command("SCATTER", Form((Variants("how", {
    "MODEL": Form((Ref("model", "model"),)),
    "MAP": Form((Ref("map", "map"),), (Clause("MODELS", (Param("models", "refs", None, ns="model"),), required=True),)),
}),), (Clause("RAYS", (V("rays", integer=True, check=positive),)), Clause("TOWARD", (Name("toward"),)))),
    "geometry", "scatter at the current object with a model, or per map class")
def _scatter(it, b, st):
    obj = _current(it, b)
    if b.variants["how"] == "MODEL":
        model = it.state.models[b["model"]]
        mod = BSDFS[model.kind]
        itf = obj.interface
        if mod.transmits(model.params) and itf is not None and itf.kind in ("reflect", "absorb"):
            raise error(b.span_of("model"), f"model {model.name} transmits, but object {obj.name} is opaque "
                        f"(INTERFACE {itf.kind.upper()})", "give the object INTERFACE TRANSMIT or a model that only reflects")
        spec = M.ScatterSpec(b["model"], None, (), b.get("rays", 1), _upper(b.get("toward")), b.span)
    else:
        spec = M.ScatterSpec(None, b["map"], tuple(b["models"]), b.get("rays", 1), _upper(b.get("toward")), b.span)
    if spec.toward is not None and spec.toward == obj.name.upper():
        raise error(b.span, f"object {obj.name} cannot scatter TOWARD itself")
    _update(it, obj, scatter=obj.scatter + (spec,))


def _clear_where(itf) -> bool:
    """Whether an interface lets an OPAQUE WHERE object be clear air where it is absent: TRANSMIT, one medium."""
    return itf is not None and itf.kind == "transmit" and itf.coating is None and itf.back == itf.front


@command("OPAQUE", Form((Choice("what", ("WHERE",)), Ref("map", "map")),
                        (Clause("FROM", (V("lo"),), required=True, doc="lowest map value where it is opaque"),
                         Clause("TO", (V("hi"),), required=True, doc="map value from which it is clear again"))),
         "geometry", "the current object is there only where a map's value lies in [lo, hi): opaque there (its "
                     "scatter models apply, the rest is absorbed), clear elsewhere (relief: a ground per height)")
def _opaque(it, b, st):
    obj = _current(it, b)
    if not _clear_where(obj.interface):
        raise error(b.span, f"OPAQUE WHERE needs object {obj.name} to be clear where it is absent: give it INTERFACE "
                    "TRANSMIT with one medium on both sides first",
                    "INTERFACE TRANSMIT m m, then OPAQUE WHERE ... FROM lo TO hi")
    if not b["lo"] < b["hi"]:
        raise error(b.span_of("hi"), f"OPAQUE WHERE ... FROM lo TO hi needs lo < hi, got {b['lo']:g} and {b['hi']:g}")
    if obj.where is not None:
        raise error(b.head_span, f"object {obj.name} already has an OPAQUE WHERE", "give an object one range of one map")
    _update(it, obj, where=(b["map"], float(b["lo"]), float(b["hi"]), b.span))


@command("SHIFT", Form((Variants("how", {"X": Form((V("d", LENGTH),)), "Y": Form((V("d", LENGTH),)),
                                          "Z": Form((V("d", LENGTH),))}, default=Form((Vs("d", LENGTH, n=3),))),)),
         "geometry", "translate the current object (SHIFT x y z, or SHIFT X|Y|Z d)")
def _shift(it, b, st):
    obj = _current(it, b)
    how = b.variants["how"]
    d = tuple(b["d"]) if how is None else tuple(b["d"] if a == how else 0.0 for a in "XYZ")
    _update(it, obj, transform=obj.transform.shifted(d))


@command("ROTATE", Form((Axis(), V("angle", ANGLE)), (Clause("ABOUT", (Vs("about", LENGTH, n=3),)),)),
         "geometry", "rotate the current object about an axis (right-handed)")
def _rotate(it, b, st):
    obj = _current(it, b)
    _update(it, obj, transform=obj.transform.rotated(b["axis"], b["angle"], tuple(b.get("about", (0.0, 0.0, 0.0)))))


@command("DETECTOR", Form((Choice("what", ("PIXELS",)), V("nx", integer=True), V("ny", integer=True, optional=True)),
                          (Clause("QE", (PL("qe", check=unit_interval),), doc="quantum efficiency per line"),
                           Clause("FILTERS", (Param("filters", "refs", None, ns="spectrum"),),
                                  doc="one image per filter: each line's flux times the filter's transmission "
                                      "(SPECTRUM names)"),
                           Clause("START", (V("x_min", LENGTH), V("x_max", LENGTH), V("y_min", LENGTH),
                                            V("y_max", LENGTH)),
                                  doc="bin by where the rays that arrive started (their source's own frame), over "
                                      "this window: the image of an adjoint (detector-side) trace"),
                           Clause("ON", (Ref("on", "object"),),
                                  doc="the named object's detector instead of the current object's: a detector "
                                      "changed between traces (its old grid is replaced)"))),
         "geometry", "the current object records an image of nx x ny pixels [QE per line] [FILTERS: one per filter] "
                     "[START: of the rays' start points] [ON obj: that object's instead]")
def _detector(it, b, st):
    obj = it.state.objects[b["on"]] if "on" in b else _current(it, b)
    nx = b["nx"]
    ny = b.get("ny", nx)
    for lab, v in (("nx", nx), ("ny", ny)):
        if v < 1:
            raise error(b.span_of(lab), f"a detector needs at least 1 pixel, got {v}")
    ap = [s.aperture for s in obj.surfaces if s.aperture is not None]
    if "x_min" not in b:     # START gives the pixel grid its window: any object may then record
        if not ap and not any(s.kind in ("PLANE", "CONIC") for s in obj.surfaces):
            raise error(b.span, f"object {obj.name} has no flat aperture to tile with pixels",
                        "a DETECTOR needs a PLANE or CONIC with RECT, DISK, ANNULUS or ELLIPSE (or a START window)")
        if not ap:
            raise error(b.span, f"object {obj.name} has no aperture: the pixel grid needs its bounding rectangle",
                        "add RECT hx hy (or DISK r) to the surface")
    qe = b["qe"].values if "qe" in b else None
    filters = None
    if "filters" in b:
        filters = []
        for key in b["filters"]:
            sp = it.state.spectra[key]
            t = tuple(float(v) for v in it.spectrum_on_lines(key, b.span_of("filters")))
            if any(v < 0 for v in t):
                raise error(b.span_of("filters"), f"filter {sp.name} has a negative transmission")
            filters.append((sp.name, t))
        filters = tuple(filters)
    start = None
    if "x_min" in b:
        start = (b["x_min"], b["x_max"], b["y_min"], b["y_max"])
        for lo, hi in (("x_min", "x_max"), ("y_min", "y_max")):
            if not b[lo] < b[hi]:
                raise error(b.span_of(hi), f"DETECTOR START needs {lo} < {hi}, got {lo} = "
                            f"{Quantity(b[lo], LENGTH).describe(it.state.units)} and {hi} = "
                            f"{Quantity(b[hi], LENGTH).describe(it.state.units)}",
                            "START x_min x_max y_min y_max: the window of start points, in the source's own frame")
    _update(it, obj, detector=M.Detector(nx, ny, b.span, qe, filters, start))


@command("GROUP", Form((Name("name"),)), "geometry", "objects up to END GROUP live in the group's own frame")
def _group(it, b, st):
    name = b["name"]
    if it.state.block is not None:
        raise error(b.span, "GROUP inside an open SURFACE block", "close it with OBJECT name first")
    g = M.Group(name, it.current_group(), span=b.span)
    it.define("group", name.upper(), g, b.span, unique=True)
    it.state.group_stack.append(name.upper())
    it.state.current = None


@command("END GROUP", None, "geometry", "close a GROUP")
def _end_group(it, b, st):
    if it.state.block is not None:
        raise error(st.span, "END GROUP inside an open SURFACE block", "close it with OBJECT name first")
    if not it.state.group_stack:
        raise error(st.span, "END GROUP without its opener: no GROUP is open")
    it.state.group_stack.pop()
    it.state.current = None


@command("PLACE", Form((Ref("group", "group"),), (
    Clause("AT", (Vs("at", LENGTH, n=3),), required=True), Clause("AIM", (Vs("aim", LENGTH, n=3),)),
    Clause("UP", (Vs("up", NONE, n=3),)))), "geometry", "place a whole GROUP: AT a point, +Z toward AIM, +Y toward UP")
def _place(it, b, st):
    key = b["group"]
    g = it.state.groups[key]
    if key in it.state.group_stack:
        raise error(b.span_of("group"), f"GROUP {g.name} cannot be placed inside itself")
    if g.placed is not None and it.state.placed_trace.get(key) == it.state.traces:
        raise error(b.span, f"GROUP {g.name} is already placed", notes=[(g.placed, "placed here")],
                    hint="a group may be placed again only after a TRACE (it moves between traces)")
    it.state.placed_trace[key] = it.state.traces
    at = tuple(b["at"])
    R = M.IDENTITY.R
    if "aim" in b:
        R = _aim_frame(at, tuple(b["aim"]), tuple(b.get("up", (0.0, 1.0, 0.0))), b)
    elif "up" in b:
        raise error(b.span_of("up"), "UP needs AIM")
    parent = it.current_group()
    # a group placed inside another one becomes its child: refuse cycles
    p = parent
    while p is not None:
        if p == key:
            raise error(b.span, f"GROUP {g.name} cannot be placed inside itself")
        p = it.state.groups[p].parent
    it.state.groups[key] = M.replace(g, parent=parent if parent is not None else g.parent,
                                     placement=M.Transform(R, at), placed=b.span)


def _aim_frame(at, aim, up, b):
    z = [a - p for a, p in zip(aim, at)]
    nz = math.sqrt(sum(c * c for c in z))
    if nz == 0:
        raise error(b.span_of("aim"), "AIM is the same point as AT")
    z = [c / nz for c in z]
    d = sum(u * c for u, c in zip(up, z))
    y = [u - d * c for u, c in zip(up, z)]
    ny = math.sqrt(sum(c * c for c in y))
    if ny < 1e-12:
        raise error(b.span_of("up") if "up" in b else b.span, "UP is parallel to the AIM direction",
                    "give an UP vector that is not along the line of sight")
    y = [c / ny for c in y]
    x = [y[1] * z[2] - y[2] * z[1], y[2] * z[0] - y[0] * z[2], y[0] * z[1] - y[1] * z[0]]
    # columns are the group's x, y, z axes in the parent frame
    return (x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2])


# ==================================================================== 7. sources
def _source_cmd(head):
    kinds = of_role(head)

    def handler(it, b, st):
        kind = b.variants["kind"]
        mod = kinds[kind]
        params = mod.build(b, it)
        full = f"{head} {kind}"
        if mod.ROLE == "grid":
            if it.state.pending_grid is not None:
                raise error(b.span, "this GRID follows another GRID that has no SOURCE direction",
                            "give each GRID a SOURCE DIRECTION, POSITION or FIELD",
                            notes=[(it.state.pending_grid[2], "the GRID without a direction")])
            it.state.pending_grid = (full, params, b.span, it.current_group())
        elif mod.ROLE == "direction":
            g = it.state.pending_grid
            if g is None:
                if it.state.source_failed:   # the GRID (or a source) before it failed: no follow-on error
                    raise it.follow_on(b.head_span, f"{full} has no GRID: the GRID before it failed")
                raise error(b.head_span, f"{full} needs a GRID before it", "GRID RECT ... or GRID DISK ... first")
            it.state.pending_grid = None
            it.state.sources.append(M.Source(f"{g[0]}+{kind}", M.frozen_params({"grid": g[1], "direction": params}),
                                             g[3], M.Flux("total", 1.0), g[2].to(b.span)))
        else:
            it.state.sources.append(M.Source(full, M.frozen_params(params), it.current_group(), M.Flux("total", 1.0), b.span))
    TABLE[head] = CommandDef(head, Form((Variants("kind", {k: m.FORM for k, m in kinds.items()}),)), handler,
                             "sources", {"GRID": "ray start points", "SOURCE": "directions for the last GRID",
                                         "EMITTING": "a Lambertian emitter"}[head])


for _h in ("GRID", "SOURCE", "EMITTING"):
    _source_cmd(_h)


@command("FLUX", Form((Variants("how", {"TOTAL": Form((V("flux", POWER, check=nonneg),)),
                                         "SPECTRUM": Form((Ref("spectrum", "spectrum"),))}),)),
         "sources", "the flux of the last source: TOTAL in W, or SPECTRUM name")
def _flux(it, b, st):
    if it.state.pending_grid is not None:
        raise error(b.span, "FLUX follows a GRID that has no SOURCE direction yet", "put SOURCE ... before FLUX")
    if not it.state.sources:
        if it.state.source_failed:
            raise it.follow_on(b.head_span, "FLUX has no source to apply to: the source before it failed")
        raise error(b.head_span, "FLUX has no source to apply to", "define a source first (GRID + SOURCE, or EMITTING)")
    f = (M.Flux("total", b["flux"], None, b.span) if b.variants["how"] == "TOTAL"
         else M.Flux("spectrum", None, b["spectrum"], b.span))
    it.state.sources[-1] = M.replace(it.state.sources[-1], flux=f)


# ==================================================================== 8. trace
@command("POLARIZATION", Form((Choice("state", ("ON", "OFF"), optional=True),)), "trace",
         "rays carry Stokes vectors (I, Q, U, V): polarizing interfaces and scattering, Stokes images")
def _polarization(it, b, st):
    it.state.polarization = b.get("state", "ON") == "ON"


@command("LEVEL", Form((V("level", integer=True, check=positive),)), "trace", "at most this many interactions per ray")
def _level(it, b, st):
    it.state.level = b["level"]


@command("HALT", Form((V("halt", check=lambda x: None if 0 <= x < 1 else "must be in [0, 1)"),), (
    Clause("IMPORTANCE", (V("cut", check=lambda x: None if 0 <= x <= 1 else "must be in [0, 1]"),),
           doc="rays sent TOWARD a target play roulette below c times a white Lambertian surface's ray"),)), "trace",
         "below this share of its starting flux a ray plays Russian roulette [IMPORTANCE c: rays toward targets too]")
def _halt(it, b, st):
    it.state.halt = b["halt"]
    if "cut" in b:
        it.state.importance_cut = b["cut"]


def _square(x):
    r = math.isqrt(int(x)) if x >= 1 else 0
    return None if r * r == x else "must be a square (1, 4, 9, 16, ...): s x s stratified rays per pixel"


def _hero_lines(v):
    return None if v >= 1 and v == int(v) else "must be a whole number of lines, 1 or more (1: off)"


def _guide_cells(x):
    return None if x == 0 or 4 <= x <= 64 else "must be 4 to 64 (0: off)"


def _guide_near(x):
    return None if 0 <= x <= 0.5 else "must be a share from 0 to 0.5"


@command("TRACE", Form((), (Clause("UNTIL", (Choice("what", ("ERROR",)), V("error", check=lambda x: None if 0 < x < 1 else "must be between 0 and 100%"),
                                            Choice("on", ("ON",)), Ref("target", "object"))),
                            Clause("CAMERA", (Ref("camera", "object"),),
                                   doc="camera-side (adjoint) image on this object's DETECTOR (docs/tracer.md)"),
                            Clause("AIM", (Ref("aim", "object"),),
                                   doc="the object camera rays aim at (the first optical element seen from it)"),
                            Clause("RAYS", (V("per_pixel", integer=True, check=_square),),
                                   doc="camera rays per pixel and line: s x s stratified (default 1)"),
                            Clause("SPECTRAL", (V("spectral", integer=True, check=positive),),
                                   doc="k lines per camera ray position, drawn from the images' weights (default: every line)"),
                            Clause("DIRECTIONS", (V("directions", integer=True, check=positive),),
                                   doc="2 m^2 rays per camera ray position, a pair in each of m x m strata of the aim "
                                       "cone (standard errors from the pairs)"),
                            Clause("CORRELATED", (), doc="every line of a camera ray position draws the same random "
                                                         "numbers: a spectrum's shape is sharper than each line"),
                            Clause("HERO", (V("hero", integer=True, check=_hero_lines),),
                                   doc="hero wavelengths: each camera ray carries the K traced lines of its line's "
                                       "block (K consecutive lines; with DIRECTIONS), or with SPECTRAL k a "
                                       "line from each of K strata of the bands' weights, every line gaining from "
                                       "every ray"),
                            Clause("GUIDE", (V("guide", integer=True, check=_guide_cells),),
                                   doc="draw camera rays' directions from g x g cells of the aim cone, as a pilot "
                                       "trace through the instrument found them leaving it (unbiased; 0: off)"),
                            Clause("NEAR", (V("guide_near", check=_guide_near),),
                                   doc="GUIDE's share of the rays spread over the cells next to those the pilot saw "
                                       "light leave, itself included (default 0.05)"),
                            Clause("WINDOW", (V("i0", integer=True, check=nonneg), V("i1", integer=True, check=positive),
                                              V("j0", integer=True, check=nonneg), V("j1", integer=True, check=positive)),
                                   doc="only pixel columns i0..i1-1 and rows j0..j1-1 (from 0)"),
                            Clause("FILTER", (Ref("cam_filter", "spectrum"),),
                                   doc="only that filter's image of the camera's DETECTOR FILTERS, every line drawn "
                                       "from its band"),
                            Clause("STOKES", (), doc="under POLARIZATION: I, Q, U and V images, from six traces "
                                                     "behind ideal analyzers on the detector (6 x the time)"))),
         "trace", "trace every source defined since the last TRACE [CAMERA obj AIM obj: a camera-side image]")
def _trace(it, b, st):
    s = it.state
    if s.pending_grid is not None:
        raise error(b.span, "a GRID has no SOURCE direction", notes=[(s.pending_grid[2], "this GRID")])
    if not s.sources:
        if s.source_failed:
            raise it.follow_on(b.span, "TRACE has no source: its source's definition failed")
        raise error(b.span, "TRACE has no source", "define GRID + SOURCE, or EMITTING ..., before TRACE")
    if s.block is not None:
        raise error(b.span, "TRACE inside an open SURFACE block", "close it with OBJECT name first")
    names = [o.name for o in s.objects.values()]
    for src in s.sources:
        t = src.params.get("toward")
        if t is not None and t.upper() not in s.objects:
            raise error(src.span, f"TOWARD target '{t}' is not an object", did_you_mean(t, names))
    for med in s.media.values():
        t = med.params.get("volume", {}).get("toward") if med.params else None
        if t is not None and t not in s.objects:
            raise error(med.span, f"MEDIUM {med.name} ... TOWARD '{t}' is not an object", did_you_mean(t, names))
    for obj in s.objects.values():
        for sc in obj.scatter:
            if sc.toward is not None and sc.toward not in s.objects:
                raise error(sc.span, f"SCATTER ... TOWARD '{sc.toward}' is not an object", did_you_mean(sc.toward, names))
    _check_scene(it, b)
    _warn_consider(it, b)
    camera = None
    if ("camera" in b or "aim" in b or "per_pixel" in b or "i0" in b or "spectral" in b or "cam_filter" in b
            or "stokes" in b or "directions" in b or "correlated" in b or "guide" in b or "hero" in b):
        if "camera" not in b or "aim" not in b:
            raise error(b.span, "a camera-side TRACE needs both CAMERA obj and AIM obj",
                        "TRACE CAMERA fpa AIM secondary [RAYS n] [SPECTRAL k] [DIRECTIONS m | GUIDE g] [CORRELATED] "
                        "[HERO K] [WINDOW i0 i1 j0 j1] [FILTER f] [STOKES]")
        if "stokes" in b and not s.polarization:
            raise error(b.span_of("stokes"), "TRACE CAMERA ... STOKES needs a polarized trace",
                        "put POLARIZATION before the TRACE")
        if "error" in b:
            raise error(b.span, "TRACE CAMERA cannot be combined with UNTIL ERROR", "give RAYS n per pixel instead")
        cam = s.objects[b["camera"]]
        if cam.detector is None or cam.detector.start is not None:
            raise error(b.span, f"TRACE CAMERA {cam.name}: the camera needs a DETECTOR PIXELS grid (without START)",
                        "give the focal-plane object DETECTOR PIXELS nx ny", notes=[(cam.span, "the camera object")])
        lights = [src for src in s.sources if src.kind == "EMITTING SPHERE"]
        if len(lights) != 1 or len(s.sources) != 1:
            raise error(b.span, f"TRACE CAMERA needs exactly one source, an EMITTING SPHERE (its light); "
                        f"{len(s.sources)} source(s) defined", "define only EMITTING SPHERE ... (and its FLUX) before it")
        win = (b["i0"], b["i1"], b["j0"], b["j1"]) if "i0" in b else None
        if win is not None and not (win[0] < win[1] <= cam.detector.nx and win[2] < win[3] <= cam.detector.ny):
            raise error(b.span, f"WINDOW {win[0]} {win[1]} {win[2]} {win[3]} is not inside the detector's "
                        f"{cam.detector.nx} x {cam.detector.ny} pixels", "columns i0 < i1 <= nx, rows j0 < j1 <= ny")
        ap = cam.surfaces[0].aperture if cam.surfaces else None
        if ap is not None and (ap.kind == "ANNULUS" or (ap.kind in ("DISK", "ELLIPSE")
                                                        and cam.detector.nx * cam.detector.ny > 1)):
            raise error(b.span_of("camera"), f"TRACE CAMERA {cam.name}: a camera's detector is a RECT of pixels, or one "
                        f"pixel on a DISK or ELLIPSE ({cam.name} has {ap.kind}"
                        + (f" and {cam.detector.nx} x {cam.detector.ny} pixels)" if ap.kind != "ANNULUS" else ")"),
                        "give the camera's PLANE a RECT aperture, or its DETECTOR PIXELS 1",
                        notes=[(cam.span, "the camera object")])
        filters = [f for f, _ in cam.detector.filters] if cam.detector.filters else []
        if "correlated" in b and (filters or "spectral" in b):
            # a band image sums lines whose errors are then correlated: its per-pixel standard errors would
            # assume them independent
            raise error(b.span_of("correlated"), "TRACE CAMERA ... CORRELATED needs a camera that traces every line "
                        "into its own image: no SPECTRAL, and a DETECTOR without FILTERS",
                        "CORRELATED is for spectra (SPECTRUM OF the camera); band images: SPECTRAL k without it",
                        notes=[(cam.span, "the camera object")])
        if "guide_near" in b and "guide" not in b:
            raise error(b.span_of("guide_near"), "TRACE CAMERA ... NEAR is a share of GUIDE's tables",
                        "give GUIDE g (4 to 64) before it: TRACE CAMERA fpa AIM secondary GUIDE 64 NEAR 0.15")
        if b.get("guide", 0) > 0 and "directions" in b:
            raise error(b.span_of("guide"), "TRACE CAMERA ... GUIDE cannot be combined with DIRECTIONS",
                        "DIRECTIONS m stratifies the aim cone for spectra; GUIDE g draws band images' rays where they "
                        "leave the instrument: give one of them")
        if b.get("hero", 0) > 1:
            # hero wavelengths (irtlang/kernels/trace_kernel.py, docs/tracer.md "Hero wavelengths"): a spectrum
            # (every line traced into its own image, DIRECTIONS pairs for the errors) or band images (SPECTRAL k:
            # each ray carries a line of each stratum of its block; the errors from the pairs of each stratum
            # with k even, else from the rays, each ray's lines summed per image before squaring)
            why = ("with SPECTRAL, the spectral strata give the errors: no DIRECTIONS"
                   if "spectral" in b and "directions" in b else
                   "it needs DIRECTIONS m (its standard errors come from the pairs)"
                   if "directions" not in b and "spectral" not in b else
                   "its lines must be traced into their own images (a DETECTOR without FILTERS), or drawn with "
                   "SPECTRAL k" if filters and "spectral" not in b else
                   "CORRELATED shares the random numbers it takes apart" if "correlated" in b else
                   "STOKES and POLARIZATION carry a Stokes vector per ray, not per line" if s.polarization else
                   "a VOLUME medium's free paths are not sampled per line" if any(
                       (m.params or {}).get("volume") for m in s.media.values()) else None)
            if why is not None:
                raise error(b.span_of("hero"), f"TRACE CAMERA ... HERO: {why}",
                            "HERO K: for a spectrum TRACE CAMERA pupil AIM obj DIRECTIONS m HERO K (a DETECTOR "
                            "without FILTERS), for band images TRACE CAMERA fpa AIM obj SPECTRAL k HERO K; "
                            "no CORRELATED, POLARIZATION or VOLUME media",
                            notes=[(cam.span, "the camera object")])
        only = None
        if "cam_filter" in b:
            names = [f.upper() for f in filters]
            if b["cam_filter"] not in names:
                raise error(b.span_of("cam_filter"), f"TRACE CAMERA ... FILTER: the camera {cam.name} has no filter "
                            f"{it.state.spectra[b['cam_filter']].name}" + (f" (its filters: {', '.join(filters)})"
                                                                           if filters else " (its DETECTOR has no FILTERS)"),
                            "name one of the camera DETECTOR's FILTERS", notes=[(cam.span, "the camera object")])
            only = filters[names.index(b["cam_filter"])]
            filters = [only]
        camera = {"camera": b["camera"], "aim": b["aim"], "sub": math.isqrt(int(b.get("per_pixel", 1))),
                  "window": win, "spectral": int(b.get("spectral", 0)), "filter": only, "stokes": "stokes" in b,
                  "directions": int(b.get("directions", 0)), "correlated": "correlated" in b,
                  "guide": int(b.get("guide", 0)), "hero": int(b.get("hero", 0))}
        if "guide_near" in b:
            camera["guide_near"] = float(b["guide_near"])
        # the light's band irradiance at 1 AU (W/m2) per image of the camera, for I/F; set by the run, 0 here
        for fname in (filters or [""]):
            it.assign("CAMERA_SUN" + (f"_{fname}" if fname else ""), Quantity(0.0, NONE), b.span)
    it.step("TRACE", {"level": s.level, "halt": s.halt, "until_error": b.get("error"), "until_target": b.get("target"),
                      "camera": camera}, b.span)
    s.sources.clear()
    s.source_failed = False
    s.traces += 1


def _check_scene(it, b) -> None:
    """Cross-references that can only be checked once the scene is complete."""
    s = it.state
    for obj in s.objects.values():
        for sc in obj.scatter:
            if sc.map is not None:
                m = s.maps[sc.map]
                if m.path is not None:
                    from ..io.maps import class_count

                    n = class_count(m.path)
                    if n is not None and n > len(sc.models):
                        raise error(sc.span, f"map {m.name} has {n} classes but MODELS names {len(sc.models)}",
                                    "name one model per class index 0 .. n-1")
                    if n is None and len(sc.models) == 1:      # a fraction map: the check irt run makes (pack)
                        import numpy as np
                        from pathlib import Path as _P

                        from ..io.maps import load_latlon

                        g = load_latlon(_P(m.path))
                        if np.nanmin(g) < 0 or np.nanmax(g) > 1:
                            raise error(sc.span, f"map {m.name} is used as a fraction map (one model) but holds "
                                        f"values outside [0, 1] ({np.nanmin(g):g} .. {np.nanmax(g):g})",
                                        "give a class map one model per class, or scale the fractions to [0, 1]")
        # a transmitting model on an opaque object (SCATTER checks this only against an INTERFACE given
        # before it; here: INTERFACE after SCATTER, no INTERFACE (absorbing), and SCATTER MAP ... MODELS)
        opaque = obj.interface is None or obj.interface.kind in ("reflect", "absorb") or obj.where is not None
        for sc in obj.scatter if opaque else ():
            for mname in ((sc.model,) if sc.model is not None else sc.models):
                model = s.models[mname]
                if BSDFS[model.kind].transmits(model.params):
                    kind = ("INTERFACE " + obj.interface.kind.upper() if obj.where is None and obj.interface is not None
                            else "OPAQUE WHERE, where it is present" if obj.where is not None
                            else "INTERFACE ABSORB, the default")
                    raise error(sc.span, f"model {model.name} transmits, but object {obj.name} is opaque "
                                f"({kind})", "give the object INTERFACE TRANSMIT or a model that only reflects"
                                if obj.where is None else "an OPAQUE WHERE object takes models that only reflect")
        itf = obj.interface
        if itf is not None and itf.kind == "coating" and s.coatings[itf.coating].kind == "fresnel":
            pass


@command("SAVE", Form((Choice("what", ("RAYS",)), Path("file")), (Clause("AT", (Ref("at", "object"),)),)),
         "trace", "save ray records (HDF5, docs/rayfile.md)")
def _save(it, b, st):
    it.step("SAVE_RAYS", {"file": b["file"], "at": b.get("at")}, b.span)


@command("LOAD", Form((Choice("what", ("RAYS",)), Path("file"))), "trace", "load ray records saved by SAVE RAYS")
def _load(it, b, st):
    saved = it.saved_output(b["file"])   # written by an earlier SAVE RAYS of this run: read from the run folder
    if saved is not None:
        it.step("LOAD_RAYS", {"file": saved, "in_run_folder": True}, b.span)
        return
    path = it.input_path(b["file"], b.span_of("file"))
    try:   # the file's object names become names the analysis commands accept (CONSIDER ONLY det, HIT(M2))
        import h5py

        with h5py.File(path, "r") as fh:
            names = [o.decode("utf-8") if isinstance(o, bytes) else str(o) for o in fh["objects"][()]]
        it.loaded_objects = getattr(it, "loaded_objects", set()) | {n.upper() for n in names}
    except (OSError, KeyError):
        pass    # not a ray file: LOAD RAYS reports it when it runs
    it.step("LOAD_RAYS", {"file": str(path)}, b.span)


# ==================================================================== 9. selection and analysis
@command("CONSIDER", Form((Variants("how", {"ONLY": Form((Param("objects", "refs", None, ns="object"),)),
                                             "ALL": Form()}),)), "analysis", "restrict the scene to some objects")
def _consider(it, b, st):
    # remembered for TRACE, which warns when CONSIDER ONLY leaves objects out of the trace
    it.consider_only = (b.span, b["objects"]) if b.get("objects") else None
    it.step("CONSIDER", {"objects": b.get("objects")}, b.span)


def _warn_consider(it, b) -> None:
    """TRACE with CONSIDER ONLY in force traces only those objects (ASAP's meaning): say so, on stderr."""
    import sys

    from .diagnostics import Diagnostic

    span, keys = getattr(it, "consider_only", None) or (None, ())
    left = [o.name for k, o in it.state.objects.items() if k not in keys]
    if span is None or not left:
        return
    kept = ", ".join(it.state.objects[k].name for k in keys if k in it.state.objects)
    d = Diagnostic(b.span, f"CONSIDER ONLY is in force: this TRACE sees only {kept or 'no object'}; "
                   f"{', '.join(left)} take{'s' if len(left) == 1 else ''} no part in it", severity="warning",
                   hint="put CONSIDER ONLY after TRACE to restrict the analysis only, or CONSIDER ALL before TRACE",
                   notes=((span, "CONSIDER ONLY given here"),))
    print(d.render(), file=sys.stderr, flush=True)


SELECT_FUNCS = {"HIT": 1, "LAST": 1, "SCATTERED": 1, "PATH": None, "WAVELENGTH": 2}


@command("SELECT", Form((Rest("predicate"),)), "analysis", "select rays by their history")
def _select(it, b, st):
    items = b["predicate"]
    if not items:
        raise error(b.span, "SELECT needs ALL or a predicate", "SELECT ALL, or SELECT HIT(fpa) AND NOT SCATTERED(vanes)")
    if len(items) == 1 and isinstance(items[0], A.Word) and match_keyword(items[0].name, ["ALL"], items[0].span):
        it.step("SELECT", {"predicate": None}, b.span)
        return
    pred = _predicate(it, items)
    it.step("SELECT", {"predicate": pred}, b.span)


def _predicate(it, items):
    """Items -> ('and'|'or', a, b) | ('not', a) | (FUNC, args) with NOT > AND > OR."""
    pos = [0]

    def peek():
        return items[pos[0]] if pos[0] < len(items) else None

    def op(word):
        x = peek()
        return isinstance(x, A.WordOp) and x.op == word

    def p_or():
        left = p_and()
        while op("OR"):
            pos[0] += 1
            left = ("or", left, p_and())
        return left

    def p_and():
        left = p_not()
        while op("AND"):
            pos[0] += 1
            left = ("and", left, p_not())
        return left

    def p_not():
        if op("NOT"):
            pos[0] += 1
            return ("not", p_not())
        x = peek()
        if x is None:
            raise error(items[-1].span, "SELECT predicate ends too early")
        pos[0] += 1
        return _pred_expr(it, x)

    res = p_or()
    if pos[0] != len(items):
        raise error(items[pos[0]].span, "expected AND or OR between predicates")
    return res


def _pred_expr(it, e):
    if isinstance(e, A.Paren):
        return _pred_expr(it, e.expr)
    if isinstance(e, A.BinOp) and e.op in ("AND", "OR"):
        return (e.op.lower(), _pred_expr(it, e.left), _pred_expr(it, e.right))
    if isinstance(e, A.UnOp) and e.op == "NOT":
        return ("not", _pred_expr(it, e.operand))
    if isinstance(e, A.Call):
        f = e.name.upper()
        if f not in SELECT_FUNCS:
            raise error(e.name_span, f"unknown predicate '{e.name}'", did_you_mean(e.name, SELECT_FUNCS))
        n = SELECT_FUNCS[f]
        if n is not None and len(e.args) != n:
            raise error(e.span, f"{f}() takes {n} argument{'s' if n > 1 else ''}, got {len(e.args)}")
        if f == "WAVELENGTH":
            lo, hi = (it.to_dim(evaluate(a, it.env), LENGTH, a.span) * 1e9 for a in e.args)
            return ("WAVELENGTH", (lo, hi))
        if not e.args:
            raise error(e.span, f"{f}() needs at least one object")
        names = []
        for a in e.args:
            if not isinstance(a, (A.Word, A.Str)):
                raise error(a.span, f"{f}() takes object names")
            nm = a.name if isinstance(a, A.Word) else it.string(a)
            names.append(it.resolve("object", nm, a.span))
        return (f, tuple(names))
    raise error(e.span, "expected a predicate: HIT(o) LAST(o) SCATTERED(o) PATH(a, b, ...) WAVELENGTH(lo, hi)")


@command("STATS", Form((Choice("what", ("LEDGER", "POSITION", "DIRECTION", "PATHS"), optional=True),
                        Path("file", optional=True)),
                       (Clause("TOP", (V("top", integer=True, check=positive),), doc="PATHS: the n leading paths, "
                               "then one 'other' row"),)),
         "analysis", "statistics of the selected rays; LEDGER: the energy ledger per object; PATHS: flux per path")
def _stats(it, b, st):
    what = b.get("what")
    if "top" in b and what != "PATHS":
        raise error(b.spans["kw:TOP"], "TOP applies to STATS PATHS", "STATS PATHS 'paths.csv' TOP 10")
    # results as variables (docs/language.md, section 17); a check run has no rays, so there they hold 0
    if what == "PATHS":
        for var in ("PATHS_TOP_FLUX", "PATHS_TOP_FLUX_SE", "PATHS_SECOND_FLUX", "PATHS_SECOND_FLUX_SE", "PATHS_FLUX"):
            it.assign(var, Quantity(0.0, POWER), b.span)
        it.assign("PATHS_TOP_FRACTION", Quantity(0.0, NONE), b.span)
        it.assign("PATHS_COUNT", Quantity(0.0, NONE), b.span)
        it.assign("PATHS_TOP", "", b.span)
    elif what != "LEDGER":
        it.assign("STATS_FLUX", Quantity(0.0, POWER), b.span)
        it.assign("STATS_FLUX_SE", Quantity(0.0, POWER), b.span)
        it.assign("STATS_RAYS", Quantity(0.0, NONE), b.span)
        if what is not None:
            for a in "XYZ":
                it.assign(f"STATS_{a}", Quantity(0.0, LENGTH if what == "POSITION" else NONE), b.span)
    it.step("STATS", {"what": what, "file": b.get("file"), "top": b.get("top")}, b.span)


@command("APPEND", Form((Path("file"), Rest("items"))), "analysis",
         "append a row of values to a CSV table (a sweep's results from a DO loop); the header names the items")
def _append(it, b, st):
    """APPEND 'sweep.csv' angle STATS_FLUX STATS_FLUX_SE: the first APPEND to a file in a run writes the header
    (each item's text, with its unit: `angle (deg)`, `STATS_FLUX (W)`), every APPEND one row; lengths are in the
    UNITS unit, angles in degrees; strings are quoted when they need it."""
    from .units import DISPLAY, unit_string

    f = b["file"]
    if not f.lower().endswith(".csv"):
        raise error(b.span_of("file"), "APPEND writes .csv tables", "APPEND 'results.csv' x STATS_FLUX")
    items = b["items"]
    if not items:
        raise error(b.span, "APPEND needs at least one value", "APPEND 'results.csv' x STATS_FLUX")
    header, values = [], []
    for item in items:
        sp = item.span
        text = (sp.source.line(sp.line)[sp.col - 1:sp.end_col - 1] if sp.source is not None and sp.end_line == sp.line
                else getattr(item, "name", "value")).strip()
        v = evaluate(item, it.env)
        if isinstance(v, str):
            header.append(text)
            values.append(v)
            continue
        unit = ("" if v.dim in (None, NONE) else it.state.units.lower() if v.dim == LENGTH
                else DISPLAY[v.dim][0] if v.dim in DISPLAY else unit_string(v.dim))
        header.append(f"{text} ({unit})" if unit else text)
        values.append(format_value(v, it.env, ".12g"))
    it.step("APPEND", {"file": f, "header": tuple(header), "values": tuple(values)}, b.span, with_scene=False)


@command("WINDOW", Form((Axis("axis1"), V("min1", LENGTH), V("max1", LENGTH), Axis("axis2"), V("min2", LENGTH),
                         V("max2", LENGTH))), "analysis", "the analysis window: two axes and their ranges")
def _window(it, b, st):
    if b["axis1"] == b["axis2"]:
        raise error(b.span_of("axis2"), "WINDOW needs two different axes")
    for a, lo, hi in (("axis1", "min1", "max1"), ("axis2", "min2", "max2")):
        if b[lo] >= b[hi]:
            raise error(b.span_of(hi), f"WINDOW {b[a]}: the maximum must exceed the minimum")
    it.step("WINDOW", {k: b[k] for k in ("axis1", "min1", "max1", "axis2", "min2", "max2")}, b.span, with_scene=False)


@command("PIXELS", Form((V("nx", integer=True, check=positive), V("ny", integer=True, check=positive, optional=True))),
         "analysis", "the analysis grid (ny defaults to nx)")
def _pixels(it, b, st):
    it.step("PIXELS", {"nx": b["nx"], "ny": b.get("ny", b["nx"])}, b.span, with_scene=False)


@command("SPOTS", Form((Choice("what", ("POSITION", "DIRECTION", "DIAGRAM")), Path("file", optional=True)), (
    Clause("FIELDS", (Vs("fields", ANGLE, n=2),), doc="DIAGRAM: trace the last GRID + SOURCE FIELD again on a 3 x 3 "
           "grid of field angles: 0, +-half field along x and y"),
    Clause("ABOUT", (Choice("about", ("CENTROID", "CHIEF")),), doc="DIAGRAM: intercepts about the centroid "
           "(default) or the chief ray"),
    Clause("THROUGH", (V("through", LENGTH, check=positive), V("steps", integer=True, check=positive)),
           doc="DIAGRAM: through-focus spots from -d to +d about the detector in this many steps"),
    Clause("SCALE", (V("scale", LENGTH, check=positive),), doc="DIAGRAM: half width of every panel"))),
         "analysis", "irradiance map of the selected rays in the window (or their directions); DIAGRAM: spot diagrams")
def _spots(it, b, st):
    what = b["what"]
    for kw in ("fields", "about", "through", "scale"):
        if kw in b and what != "DIAGRAM":
            raise error(b.spans["kw:" + kw.upper()], f"{kw.upper()} applies to SPOTS DIAGRAM")
    if what == "DIAGRAM":
        f = b.get("file")
        if f is None or not f.lower().endswith(".png"):
            raise error(b.span_of("file") if f else b.span, "SPOTS DIAGRAM writes a .png figure (and a .csv beside it)",
                        "SPOTS DIAGRAM 'spots.png' FIELDS 0.045 0.045 deg")
        if "steps" in b and b["steps"] < 2:
            raise error(b.spans["kw:THROUGH"], "THROUGH needs at least 2 steps")
    # results as variables; a check run has no rays, so there they hold 0
    dim = LENGTH if what != "DIRECTION" else NONE
    for var in ("SPOTS_RMS", "SPOTS_GEO") + (("SPOTS_X", "SPOTS_Y") if what != "DIAGRAM" else ("SPOTS_RMS_AXIS",)):
        it.assign(var, Quantity(0.0, dim), b.span)
    it.assign("SPOTS_FLUX", Quantity(0.0, POWER), b.span)
    it.step("SPOTS", {"what": what, "file": b.get("file"), "fields": b.get("fields"), "about": b.get("about", "CENTROID"),
                      "through": b.get("through"), "steps": b.get("steps"), "scale": b.get("scale")}, b.span)


@command("FOCUS", Form(), "analysis", "best-focus position and shift along the axis, its RMS spot radius, and a "
         "paraxial report (EFL, BFL, f-number, magnification)")
def _focus(it, b, st):
    # FOCUS sets FOCUS_SHIFT and FOCUS_RMS (lengths); a check run has no rays, so there they hold 0
    for var in ("FOCUS_SHIFT", "FOCUS_RMS", "FOCUS_X", "FOCUS_Y", "FOCUS_Z", "FOCUS_EFL", "FOCUS_BFL"):
        it.assign(var, Quantity(0.0, LENGTH), b.span)
    it.assign("FOCUS_FNUM", Quantity(0.0, NONE), b.span)
    it.assign("FOCUS_MAG", Quantity(0.0, NONE), b.span)
    it.step("FOCUS", {}, b.span)


@command("EXPORT", Form((Ref("object", "object"), Path("file")), (
    Clause("DIFFRACTION", (), doc="the detector image convolved with the last PSF's diffraction kernel"),
    Clause("FILTER", (Ref("filter", "spectrum"),), doc="only that filter's image (a DETECTOR with FILTERS)"),
    Clause("SUM", (), doc="the image summed over its wavelength lines: one plane (a forward trace's detector image "
           "or WINDOW grid)"),
    Clause("STOKES", (), doc="a polarized trace's I, Q, U, V images and DOLP, AOLP maps (files name_I.ext, ...)"),
    Clause("LOG", (), doc="a .png picture on a logarithmic colour scale (a ghost or a halo beside its image)"))),
         "analysis", "write the object's image: .fits .png .npy .csv by extension")
def _export(it, b, st):
    f = b["file"]
    ext = f.rsplit(".", 1)[-1].lower() if "." in f else ""
    if ext not in ("fits", "fit", "png", "npy", "csv"):
        raise error(b.span_of("file"), f"EXPORT cannot write '.{ext}' files", "use .fits, .png, .npy or .csv")
    extra = {"diffraction": True} if "diffraction" in b else {}
    if "stokes" in b:
        if "diffraction" in b:
            raise error(b.span, "EXPORT ... STOKES cannot be combined with DIFFRACTION", "export them separately")
        extra["stokes"] = True
    if "sum" in b:
        for other, why in (("stokes", "the Stokes images keep their lines"),
                           ("filter", "a filter's image is already one band")):
            if other in b:
                raise error(b.spans.get("kw:SUM", b.span), f"EXPORT ... SUM cannot be combined with {other.upper()}",
                            why)
        extra["sum"] = True
    if "log" in b:
        if ext != "png":
            raise error(b.span, f"EXPORT ... LOG draws a picture, not a '.{ext}' file",
                        "use a .png file name (the data files keep their values)")
        if "stokes" in b:
            raise error(b.span, "EXPORT ... LOG cannot be combined with STOKES (Q, U and V take both signs)",
                        "export the Stokes images on a linear scale")
        extra["log"] = True
    if "filter" in b:
        obj = it.state.objects.get(b["object"])
        det = obj.detector if obj is not None else None
        names = [n.upper() for n, _ in det.filters] if det is not None and det.filters else []
        if b["filter"] not in names:
            raise error(b.span_of("filter"), f"object {obj.name if obj else b['object']} has no filter "
                        f"{it.state.spectra[b['filter']].name}" + (f" (its filters: {', '.join(n for n, _ in det.filters)})"
                                                                  if names else " (its DETECTOR has no FILTERS)"))
        extra["filter"] = names.index(b["filter"])
        extra["filter_name"] = det.filters[extra["filter"]][0]   # a TRACE CAMERA ... FILTER image holds one filter
    it.step("EXPORT", {"object": b["object"], "file": f, **extra}, b.span)


def _odd_size(x):
    return None if x >= 1 and x % 2 == 1 else "must be an odd whole number >= 1"


@command("PSF", Form((Path("file", optional=True),), (
    Clause("ON", (Ref("object", "object"),), doc="the detector (default: the one DETECTOR object considered)"),
    Clause("PAD", (V("pad", check=lambda x: None if 2 <= x <= 64 else "must be in [2, 64]"),),
           doc="zero-padding factor of the pupil FFT (default 8)"),
    Clause("SIZE", (V("size", integer=True, check=_odd_size),), doc="kernel / file size in pixels (default 65)"))),
         "analysis", "diffraction PSF from the traced wavefront of a GRID RECT (FFT over the pupil)")
def _psf(it, b, st):
    f = b.get("file")
    if f is not None:
        ext = f.rsplit(".", 1)[-1].lower() if "." in f else ""
        if ext not in ("fits", "fit", "png", "npy", "csv"):
            raise error(b.span_of("file"), f"PSF cannot write '.{ext}' files", "use .fits, .png, .npy or .csv")
    # PSF sets these (lengths, PSF_STREHL a number); a check run has no rays, so there they hold 0
    for var in ("PSF_FWHM", "PSF_EE80", "PSF_RING", "PSF_OUTER", "PSF_EFL"):
        it.assign(var, Quantity(0.0, LENGTH), b.span)
    it.assign("PSF_STREHL", Quantity(0.0, NONE), b.span)
    it.step("PSF", {"file": f, "object": b.get("object"), "pad": b.get("pad"), "size": b.get("size")}, b.span)


@command("PST", Form((Path("file", optional=True),), (
    Clause("ON", (Ref("object", "object"),), doc="the detector object (it needs a DETECTOR: its area)"),
    Clause("ANGLES", (V("first", ANGLE), V("last", ANGLE), V("count", integer=True, check=positive)),
           doc="the sweep: first and last off-axis angle and the number of angles"),
    Clause("AXIS", (Choice("axis", ("X", "Y")),), doc="tilt along the grid's local x (default) or y"),
    Clause("FIELD", (V("field", ANGLE, check=nonneg),), doc="the half field of view, shaded on the plot"))),
         "analysis", "point source transmittance: the last TRACE's GRID + SOURCE FIELD swept over off-axis angles")
def _pst(it, b, st):
    f = b.get("file")
    if f is not None and not f.lower().endswith(".csv"):
        raise error(b.span_of("file"), "PST writes a .csv table (and a .png plot beside it)", "PST 'pst.csv' ON fpa ...")
    for need, example in (("object", "ON fpa"), ("first", "ANGLES 0 30 deg 16")):
        if need not in b:
            raise error(b.span, f"PST needs {example.split()[0]}", f"PST 'pst.csv' ON fpa ANGLES 0 30 16")
    it.assign("PST_MAX", Quantity(0.0, NONE), b.span)      # set by the run; 0 under irt check
    it.assign("PST_LAST", Quantity(0.0, NONE), b.span)
    it.assign("PST_LAST_SE", Quantity(0.0, NONE), b.span)
    it.step("PST", {"file": f, "object": b["object"], "first": b["first"], "last": b["last"], "count": b["count"],
                    "axis": b.get("axis"), "field": b.get("field")}, b.span)


ANALYSES = ("RGB", "PSF", "MTF", "ESF", "DEFOCUS", "DESPACE", "DISK", "SPECTRUM", "SERIES", "ANIMATE")
# the options of the analysis subcommands that name files the analysis writes (in the run folder)
ANALYSIS_OUTPUT_OPTIONS = ("--output", "--plot", "--mean-plot", "--mean-output", "--curve-plot")


def analysis_argv(it, what: str, items) -> list:
    """The `irt analyze` argument list of an ANALYZE command: a word is an option (PIXEL_PITCH ->
    --pixel-pitch), a quoted string a file name or text, anything else a value (in the script's units)."""
    argv = [what.lower()]
    for item in items:
        if isinstance(item, A.Word) and not it.is_variable(item.name):
            argv.append("--" + item.name.lower().replace("_", "-"))
        elif isinstance(item, A.Str):
            argv.append(("\0path:" + it.string(item)))
        else:
            v = evaluate(item, it.env)
            argv.append(v if isinstance(v, str) else format_value(v, it.env))
    return argv


def analysis_parser():
    import argparse

    from ..core.hooks import analysis_provider   # the analysis package, reached through the late-stage hook

    class _Parser(argparse.ArgumentParser):
        def error(self, message):  # report, don't exit
            raise ValueError(message)

    p = _Parser(prog="ANALYZE", add_help=False)
    analysis_provider().build_parser(p.add_subparsers(dest="analysis_cmd", parser_class=_Parser))
    return p


@command("ANALYZE", Form((Choice("what", ANALYSES), Rest("args"))), "analysis",
         "run an analysis of the analysis package (irt analyze) on files: ANALYZE PSF 'fpa.npy' PIXEL_PITCH 0.021")
def _analyze(it, b, st):
    argv = analysis_argv(it, b["what"], b["args"])
    try:  # validate the arguments now, as `irt analyze` would
        analysis_parser().parse_args([a.replace("\0path:", "") for a in argv])
    except ValueError as e:
        raise error(b.span, f"ANALYZE {b['what']}: {e}", f"see `irt analyze {b['what'].lower()} --help`") from None
    it.step("ANALYZE", {"argv": tuple(argv), "base": str(it.include_stack[-1].parent if it.include_stack else it.base_dir)},
            b.span, with_scene=False)
