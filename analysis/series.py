"""Time series of disk-integrated spectra: a folder of hourly ``SPECTRUM OF obj 'spectra/<YYYYmmddTHHMM>.csv'``
files gathered into one table with the apparent (Lambert-equivalent) albedo of every line at every time."""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._common import AnalysisError, atomic_path, check_finite, positive
from .disk import apparent_albedo, lambert_sphere_flux

__all__ = [
    "SpectraSeries", "SERIES_COLUMNS", "parse_time_tag", "format_time_utc", "read_spectra_series",
    "solar_band_irradiance", "series_apparent_albedo", "lambert_series_flux", "write_series_csv",
    "series_mean_spectrum", "write_mean_csv", "EARTH_FEATURES",
]

SPECTRUM_COLUMNS = ("wavelength_nm", "flux_W", "stderr_W")
SERIES_COLUMNS = ("time_utc", "wavelength_nm", "flux_W", "stderr_W", "apparent_albedo")
_TAG = re.compile(r"\d{8}T\d{4}")


@dataclass(frozen=True)
class SpectraSeries:
    """Spectra of one object over time: ``times`` (UTC, timezone-aware, ascending), ``wavelengths_nm`` (L,)
    ascending, ``flux_W`` and ``stderr_W`` (T, L), and the ``files`` they came from."""

    times: tuple
    wavelengths_nm: np.ndarray
    flux_W: np.ndarray
    stderr_W: np.ndarray
    files: tuple

    def hours_since_midnight(self):
        """Hours of each time after 00:00 UTC of the first time's day (beyond 24 on the following days)."""
        day = self.times[0].replace(hour=0, minute=0, second=0, microsecond=0)
        return np.array([(t - day).total_seconds() / 3600.0 for t in self.times])


def parse_time_tag(name):
    """UTC time of a time tag ``YYYYmmddTHHMM`` (irtlang's ``EPOCH_TAG``), given as the tag, a file name or a path
    (the suffix is dropped).

    Signature: ``parse_time_tag(name) -> datetime (UTC)``.
    """
    stem = Path(str(name)).stem
    if not _TAG.fullmatch(stem):
        raise AnalysisError(f"{Path(str(name)).name}: the file name is not a time tag YYYYmmddTHHMM "
                            "(e.g. 20080318T1819.csv, as EPOCH_TAG writes it)")
    try:
        t = _dt.datetime.strptime(stem, "%Y%m%dT%H%M")
    except ValueError:
        raise AnalysisError(f"{Path(str(name)).name}: {stem} is not a valid date and time (YYYYmmddTHHMM)") from None
    return t.replace(tzinfo=_dt.timezone.utc)


def format_time_utc(t):
    """ISO 8601 UTC text of a time: ``2008-03-18T18:19:00Z``."""
    if t.tzinfo is not None:
        t = t.astimezone(_dt.timezone.utc).replace(tzinfo=None)
    return t.strftime("%Y-%m-%dT%H:%M:%SZ")


def _read_spectrum_csv(path):
    """(wavelengths, flux, stderr) of one ``wavelength_nm,flux_W,stderr_W`` file, sorted by wavelength."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise AnalysisError(f"{path}: not a text CSV file") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise AnalysisError(f"{path}: the file is empty (expected the header {','.join(SPECTRUM_COLUMNS)})")
    header = [h.strip() for h in lines[0].split(",")]
    missing = [c for c in SPECTRUM_COLUMNS if c not in header]
    if missing:
        raise AnalysisError(f"{path}: missing column(s) {', '.join(missing)} (header {lines[0].strip()!r}; "
                            f"expected {','.join(SPECTRUM_COLUMNS)})")
    if len(lines) < 2:
        raise AnalysisError(f"{path}: no data rows below the header")
    cols = [header.index(c) for c in SPECTRUM_COLUMNS]
    rows = []
    for n, ln in enumerate(lines[1:], 2):
        cells = [c.strip() for c in ln.split(",")]
        if len(cells) != len(header):
            raise AnalysisError(f"{path}: data row {n} has {len(cells)} values for {len(header)} columns")
        try:
            rows.append([float(cells[k]) for k in cols])
        except ValueError:
            raise AnalysisError(f"{path}: data row {n} holds a value that is not a number: {ln.strip()!r}") from None
    data = np.asarray(rows, dtype=np.float64)
    check_finite(data, str(path))
    order = np.argsort(data[:, 0], kind="stable")
    data = data[order]
    if np.any(np.diff(data[:, 0]) == 0):
        raise AnalysisError(f"{path}: a wavelength line appears twice")
    return data[:, 0], data[:, 1], data[:, 2]


def read_spectra_series(folder):
    """Read every spectrum CSV of a folder into a :class:`SpectraSeries`.

    Signature: ``read_spectra_series(folder) -> SpectraSeries``.

    Each non-hidden ``*.csv`` file must be named by its UTC time tag ``YYYYmmddTHHMM.csv`` and hold the header
    ``wavelength_nm,flux_W,stderr_W`` (any column order, other columns ignored) with one row per line, as
    ``SPECTRUM OF obj 'file.csv'`` writes it. Other files are ignored. Errors: not a folder, no CSV file, a name
    that is not a time tag, a missing column, a value that is not a finite number, files with different
    wavelength lines.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise AnalysisError(f"{folder}: no such folder" if not folder.exists() else f"{folder}: not a folder")
    files = [p for p in folder.iterdir()
             if p.is_file() and p.suffix.lower() == ".csv" and not p.name.startswith(".")]
    if not files:
        raise AnalysisError(f"{folder}: the folder holds no spectrum file (<YYYYmmddTHHMM>.csv)")
    timed = sorted(((parse_time_tag(p.name), p) for p in files), key=lambda tp: tp[0])
    for (t0, p0), (t1, p1) in zip(timed, timed[1:]):
        if t0 == t1:
            raise AnalysisError(f"{p0.name} and {p1.name} name the same time")
    wl0 = None
    flux, se = [], []
    for _, p in timed:
        wl, f, e = _read_spectrum_csv(p)
        if wl0 is None:
            wl0, first = wl, p
        elif wl.shape != wl0.shape or not np.array_equal(wl, wl0):
            raise AnalysisError(f"{p.name}: its wavelength lines ({_lines_text(wl)} nm) differ from those of "
                                f"{first.name} ({_lines_text(wl0)} nm)")
        flux.append(f)
        se.append(e)
    return SpectraSeries(tuple(t for t, _ in timed), wl0, np.array(flux), np.array(se), tuple(p for _, p in timed))


def _lines_text(wl):
    s = [f"{x:g}" for x in wl]
    return ", ".join(s if len(s) <= 8 else s[:3] + ["..."] + s[-3:]) + f"; {len(s)} line(s)"


def solar_band_irradiance(wavelengths_nm, *, tsi, sun_distance_au=1.0):
    """Solar irradiance at the body in each wavelength line's band, W/m2.

    Signature: ``solar_band_irradiance(wavelengths_nm, *, tsi, sun_distance_au=1.0) -> (L,) array``.

    ``E_line = S_line(tsi) / D^2`` with ``S_line`` irtlang's own ``irtlang.io.spectra.solar_line_irradiance``: the
    ASTM G173 reference spectrum of ``SPECTRUM sun SOLAR TSI tsi`` scaled to ``tsi`` (W/m2 at 1 AU), its mean
    over the line's band (reaching halfway to the neighbouring lines, the end bands symmetric) times the band
    width, exactly what ``FLUX SPECTRUM sun`` puts on each line. ``sun_distance_au`` D: the body's distance from
    the Sun in AU. The bands must lie within 280-4000 nm.
    """
    from irtlang.io.spectra import solar_line_irradiance

    tsi = positive(tsi, "tsi")
    d = positive(sun_distance_au, "sun_distance_au")
    try:
        s = solar_line_irradiance(np.asarray(wavelengths_nm, dtype=np.float64), tsi)
    except ValueError as exc:
        raise AnalysisError(str(exc)) from None
    return s / d**2


def series_apparent_albedo(flux_W, wavelengths_nm, *, tsi, sun_distance_au, distance_km, phase_deg, radius_km,
                           area_m2):
    """Apparent albedo of disk-integrated fluxes collected by an aperture.

    Signature: ``series_apparent_albedo(flux_W, wavelengths_nm, *, tsi, sun_distance_au, distance_km, phase_deg,
    radius_km, area_m2) -> array like flux_W``.

    ``flux_W`` (..., L): the flux in W through an aperture of ``area_m2`` at ``distance_km`` from a body of
    ``radius_km`` seen at phase angle ``phase_deg``, per line of ``wavelengths_nm``. Returns
    ``flux / (area_m2 * F_L)``, ``F_L = (2/3) E_line (R/d)^2 Phi(a)`` (a Lambert sphere of albedo 1,
    :func:`analysis.disk.lambert_sphere_flux`) with ``E_line`` from :func:`solar_band_irradiance`.
    """
    f = np.asarray(flux_W, dtype=np.float64)
    check_finite(f, "flux_W")
    wl = np.asarray(wavelengths_nm, dtype=np.float64).reshape(-1)
    if f.ndim == 0 or f.shape[-1] != wl.size:
        raise AnalysisError(f"flux_W has shape {f.shape}: its last axis must match the {wl.size} wavelength lines")
    area = positive(area_m2, "area_m2")
    radius, distance = positive(radius_km, "radius_km"), positive(distance_km, "distance_km")
    if distance <= radius:
        raise AnalysisError(f"distance_km ({distance:g}) must exceed radius_km ({radius:g}): the observer is "
                            "outside the body")
    e = solar_band_irradiance(wl, tsi=tsi, sun_distance_au=sun_distance_au)
    return apparent_albedo(f, wl, solar_irradiance=area * e, radius=radius, distance=distance,
                           phase_angle_deg=phase_deg)


def lambert_series_flux(albedo, wavelengths_nm, *, tsi, sun_distance_au, distance_km, phase_deg, radius_km,
                        area_m2):
    """Flux in W through an aperture of ``area_m2`` from a Lambert sphere of ``albedo`` (the inverse of
    :func:`series_apparent_albedo`): ``area_m2 * lambert_sphere_flux(albedo, E_line, R, d, a)``."""
    e = solar_band_irradiance(wavelengths_nm, tsi=tsi, sun_distance_au=sun_distance_au)
    return positive(area_m2, "area_m2") * lambert_sphere_flux(albedo, e, radius_km, distance_km, phase_deg)


def write_series_csv(path, series, albedo):
    """Write ``time_utc,wavelength_nm,flux_W,stderr_W,apparent_albedo`` (one row per time and line, sorted by time
    then wavelength; times as ``2008-03-18T18:19:00Z``; numbers at full precision) atomically. Returns the path.

    Signature: ``write_series_csv(path, series, albedo) -> Path``.
    """
    a = np.asarray(albedo, dtype=np.float64)
    if a.shape != series.flux_W.shape:
        raise AnalysisError(f"albedo has shape {a.shape}, the series {series.flux_W.shape}")
    out = [",".join(SERIES_COLUMNS)]
    for k, t in enumerate(series.times):
        tt = format_time_utc(t)
        for j, lam in enumerate(series.wavelengths_nm):
            out.append(f"{tt},{float(lam)!r},{float(series.flux_W[k, j])!r},{float(series.stderr_W[k, j])!r},"
                       f"{float(a[k, j])!r}")
    return _write_lines(path, out)


def _write_lines(path, lines) -> Path:
    """The lines as a text file, atomically. Returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


# Features of a disk-integrated Earth spectrum (nm), labelled on the mean-spectrum figure: bands as (lo, hi, text),
# single wavelengths as (x, text).  Band limits after the HITRAN band centres and the seed paper's Fig. 9.
EARTH_FEATURES = (
    (300.0, 340.0, "O3 Huggins"), (400.0, "Rayleigh (blue)"), (500.0, 680.0, "O3 Chappuis"),
    (627.0, 633.0, "O2 gamma"), (686.0, 695.0, "O2 B"), (715.0, 735.0, "H2O"), (700.0, "red edge"),
    (759.0, 771.0, "O2 A"), (810.0, 835.0, "H2O"), (890.0, 990.0, "H2O 0.94"), (1100.0, 1170.0, "H2O 1.13"),
    (1260.0, 1275.0, "O2 1.27"), (1320.0, 1500.0, "H2O 1.38"), (1500.0, "ice 1.5"), (1640.0, "window 1.6"),
    (1800.0, 1980.0, "H2O 1.87"), (2000.0, 2080.0, "CO2 2.0"), (2300.0, 2400.0, "CH4 2.3"),
)


def series_mean_spectrum(series, albedo):
    """The mean over time of an apparent-albedo series per line, with the Monte Carlo standard error of that mean
    (the hours' standard errors, independent runs: sqrt(sum se_t^2) / T, each converted to albedo by the hour's
    albedo / flux) and the spread over time (standard deviation of the hourly values, ddof 1; 0 for one hour).

    Signature: ``series_mean_spectrum(series, albedo) -> dict(mean, stderr, spread)``."""
    a = np.asarray(albedo, dtype=np.float64)
    if a.shape != series.flux_W.shape:
        raise AnalysisError(f"albedo has shape {a.shape}, the series {series.flux_W.shape}")
    f = series.flux_W
    scale = np.divide(a, f, out=np.zeros_like(a), where=f != 0)
    se_a = np.abs(scale) * series.stderr_W
    t = a.shape[0]
    return {"mean": a.mean(axis=0), "stderr": np.sqrt(np.sum(se_a ** 2, axis=0)) / t,
            "spread": a.std(axis=0, ddof=1) if t > 1 else np.zeros(a.shape[1])}


def write_mean_csv(path, wavelengths_nm, mean):
    """``wavelength_nm,mean_apparent_albedo,stderr,spread`` per line, atomically. Returns the path."""
    out = ["wavelength_nm,mean_apparent_albedo,stderr,spread"]
    for j, lam in enumerate(np.asarray(wavelengths_nm, dtype=np.float64)):
        out.append(f"{float(lam)!r},{float(mean['mean'][j])!r},{float(mean['stderr'][j])!r},"
                   f"{float(mean['spread'][j])!r}")
    return _write_lines(path, out)
