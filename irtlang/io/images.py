"""Image files for EXPORT and SPOTS: .npy, .fits, .png, .csv (chosen by extension), written atomically.

The array is float64 (n_lines, ny, nx): index [k, j, i] is line k, row j (j = 0 at the lowest local y),
column i (i = 0 at the lowest local x).  With per-pixel sums of squares, the standard error map goes
alongside: ``NAME.stderr.npy`` for .npy, an ``STDERR`` image extension for .fits.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .atomic import atomic_path, write_text


def write_image(path: Path, img: np.ndarray, *, sum2=None, extent=None, wavelengths_nm=None,
                length_unit: str = "mm", bands=None, focal_length_m: float | None = None, provenance=None,
                object_name: str | None = None, n_traced: int | None = None, psf: bool = False,
                quantity: tuple | None = None, log: bool = False) -> list[Path]:
    """Write an image file; returns the paths written.  extent (x0, x1, y0, y1) in length_unit; bands: the
    filter names of the k images (DETECTOR FILTERS); focal_length_m: adds the field-angle WCS to a FITS file;
    provenance: FITS header cards (irtlang_version, script_sha256, seed, data_tier, rays_traced, epoch_utc).
    `sum2`: the per-source-ray squared sums; the standard error is the tracer's (the same as every printed
    total's) when `n_traced` is given, else sqrt(sum2).  `psf`: a normalized PSF (energy fraction per pixel),
    labelled as such (PNG colour bar, CSV column, FITS BUNIT).  `quantity`: (label, FITS BUNIT, additive) of an image
    that is not a plain flux (EXPORT ... STOKES): its PNG's label, and the sum of its planes if additive (Stokes
    Q, U, V), else the first plane (the degree and angle of polarization).  `log`: a .png on a logarithmic colour
    scale (:func:`log_scale`; the other formats ignore it)."""
    path = Path(path)
    ext = path.suffix.lower()
    img = np.asarray(img, np.float64)
    if sum2 is not None and n_traced:
        from ..core.stats import standard_error

        stderr = np.asarray(standard_error(img, np.asarray(sum2, np.float64), int(n_traced)), np.float64)
    else:
        stderr = np.sqrt(np.asarray(sum2, np.float64)) if sum2 is not None else None
    written = [path]
    if ext == ".npy":
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:
                np.save(fh, img)
        if stderr is not None:
            sp = path.with_name(path.stem + ".stderr.npy")
            with atomic_path(sp) as tmp:
                with open(tmp, "wb") as fh:
                    np.save(fh, stderr)
            written.append(sp)
    elif ext in (".fits", ".fit"):
        parts = fits_parts(img, stderr, extent, wavelengths_nm, length_unit, bands=bands,
                           focal_length_m=focal_length_m, provenance=provenance, object_name=object_name,
                           bunit=quantity[1] if quantity else "" if psf else "W")
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:
                buf = None
                for part in parts:
                    if isinstance(part, bytes):
                        fh.write(part)
                    else:
                        buf = part.write(fh, buf)
    elif ext == ".png":
        if quantity:       # a flux-like quantity (Stokes Q, U, V) sums over the planes, a map shows its first
            _png(path, img if quantity[2] else img[:1], extent, length_unit, label=quantity[0])
        else:
            _png(path, img, extent, length_unit, label="normalized PSF (energy fraction per pixel)" if psf
                 else "flux per pixel (W)", log=log)
    elif ext == ".csv":
        buf = io.StringIO()
        buf.write("line,wavelength_nm,row,col," + (quantity[0].split(" (")[0].replace(" ", "_") if quantity
                                                   else "psf_fraction" if psf else "flux_W")
                  + (",stderr_W" if stderr is not None else "") + "\n")
        L, ny, nx = img.shape
        for k in range(L):
            lam = wavelengths_nm[k] if wavelengths_nm is not None else float("nan")
            for j in range(ny):
                for i in range(nx):
                    row = f"{k},{lam:.6g},{j},{i},{img[k, j, i]!r}"
                    if stderr is not None:
                        row += f",{stderr[k, j, i]!r}"
                    buf.write(row + "\n")
        write_text(path, buf.getvalue())
    else:
        raise ValueError(f"unknown image extension {ext}")
    return written


def _card(key: str, value, comment: str = "") -> bytes:
    if isinstance(value, bool):
        v = f"{'T' if value else 'F':>20}"
    elif isinstance(value, (int, np.integer)):
        v = f"{int(value):>20}"
    elif isinstance(value, (float, np.floating)):
        v = f"{repr(float(value)).upper():>20}"   # the shortest text that reads back to the same double
    else:
        text = "".join(c if 32 <= ord(c) < 127 else "?" for c in str(value))[:68].replace("'", "''")[:68]
        v = f"'{text:<8}'"
    s = f"{key:<8}= {v}" + (f" / {comment}" if comment else "")
    return s[:80].ljust(80).encode("ascii")


def _block(cards: list[bytes]) -> bytes:
    data = b"".join(cards) + b"END".ljust(80)
    return data + b" " * (-len(data) % 2880)


def _data(a: np.ndarray) -> list:
    """An image's data units: its planes (big-endian when written, one at a time) and the padding."""
    a = np.asarray(a)
    return [_BigEndian(p) for p in (a if a.ndim >= 3 else [a])] + [b"\0" * (-(a.size * 8) % 2880)]


class _BigEndian:
    """One plane of a cube, converted to big-endian when it is written (no copy of the whole cube)."""

    def __init__(self, plane):
        self.plane = np.asarray(plane)

    def __bytes__(self) -> bytes:
        return np.ascontiguousarray(self.plane, dtype=">f8").tobytes()

    def write(self, fh, buf=None):
        """Write the plane through `buf` (a big-endian scratch plane, reused from the last call when it fits)."""
        if buf is None or buf.shape != self.plane.shape:
            buf = np.empty(self.plane.shape, ">f8")
        np.copyto(buf, self.plane)
        fh.write(buf.data)
        return buf


def _wcs_cards(shape, extent, wavelengths_nm, length_unit, bands, focal_length_m) -> list[bytes]:
    """The WCS: detector-plane x, y (length_unit) and the spectral axis (WAVE in nm for evenly spaced lines,
    else the line or band index with WAVEnnnn / FILTnnnn cards); with a focal length, the alternate WCS 'A'
    of field angles (a gnomonic projection: tan(angle) = position / focal length, OFLN/OFLT offsets in deg)."""
    L, ny, nx = shape
    cards = [_card("WCSAXES", 3), _card("WCSNAME", "DETECTOR PLANE")]
    axis3 = []
    lam = None if wavelengths_nm is None else np.asarray(wavelengths_nm, float)
    if lam is not None and len(lam) == L and (L == 1 or np.allclose(np.diff(lam), lam[1] - lam[0], rtol=1e-9,
                                                                     atol=0)):
        axis3 = [("CTYPE3", "WAVE", "vacuum wavelength of the line"), ("CUNIT3", "nm", ""),
                 ("CRPIX3", 1.0, ""), ("CRVAL3", float(lam[0]), ""),
                 ("CDELT3", float(lam[1] - lam[0]) if L > 1 else 1.0, "")]
    elif bands is not None:
        axis3 = [("CTYPE3", "BAND", "filter band index: FILTnnnn names the band"), ("CRPIX3", 1.0, ""),
                 ("CRVAL3", 1.0, ""), ("CDELT3", 1.0, "")]
    else:
        axis3 = [("CTYPE3", "LINE", "wavelength line index: WAVEnnnn in nm"), ("CRPIX3", 1.0, ""),
                 ("CRVAL3", 1.0, ""), ("CDELT3", 1.0, "")]
    if extent is not None:
        x0, x1, y0, y1 = map(float, extent)
        dx, dy = (x1 - x0) / nx, (y1 - y0) / ny
        cx, cy = x0 + dx / 2, y0 + dy / 2
        unit = [] if " " in length_unit else [length_unit]   # no CUNIT for direction cosines
        cards += [_card("CTYPE1", "DETX", "detector-plane local x")] + [_card("CUNIT1", u) for u in unit] + [
                  _card("CRPIX1", 1.0), _card("CRVAL1", cx, "pixel 1 centre"), _card("CDELT1", dx),
                  _card("CTYPE2", "DETY", "detector-plane local y")] + [_card("CUNIT2", u) for u in unit] + [
                  _card("CRPIX2", 1.0), _card("CRVAL2", cy, "pixel 1 centre"), _card("CDELT2", dy)]
    cards += [_card(k, v, c) for k, v, c in axis3]
    if extent is not None:
        cards += [_card("PIXSIZEX", dx, f"pixel width, {length_unit}"),
                  _card("PIXSIZEY", dy, f"pixel height, {length_unit}")]
        if focal_length_m and length_unit == "mm":
            F = focal_length_m * 1e3
            deg = 180.0 / np.pi
            cards += [_card("WCSNAMEA", "FIELD ANGLE"), _card("FOCALLEN", F, "focal length, mm"),
                      _card("CTYPE1A", "OFLN-TAN", "field angle x (offset longitude)"), _card("CUNIT1A", "deg"),
                      _card("CRPIX1A", 1.0 - cx / dx, "the optical axis (x = 0)"), _card("CRVAL1A", 0.0),
                      _card("CDELT1A", deg * dx / F),
                      _card("CTYPE2A", "OFLT-TAN", "field angle y (offset latitude)"), _card("CUNIT2A", "deg"),
                      _card("CRPIX2A", 1.0 - cy / dy, "the optical axis (y = 0)"), _card("CRVAL2A", 0.0),
                      _card("CDELT2A", deg * dy / F)]
            cards += [_card(k + "A", v, c) for k, v, c in axis3]
    return cards


def fits_bytes(img, stderr, extent, wavelengths_nm, length_unit, **kw) -> bytes:
    """A FITS file (primary image, optional STDERR extension) by the FITS 4.0 standard, no dependencies."""
    return b"".join(p if isinstance(p, bytes) else bytes(p)
                    for p in fits_parts(img, stderr, extent, wavelengths_nm, length_unit, **kw))


def fits_parts(img, stderr, extent, wavelengths_nm, length_unit, *, bands=None, focal_length_m=None,
               provenance=None, object_name=None, bunit: str = "W") -> list:
    """`fits_bytes`'s pieces in file order (header blocks as bytes, data as big-endian arrays), to be written one
    after the other: a cube of hundreds of MB is not joined into one bytes object."""
    import datetime as _dt

    L, ny, nx = img.shape
    cards = [_card("SIMPLE", True), _card("BITPIX", -64), _card("NAXIS", 3), _card("NAXIS1", nx),
             _card("NAXIS2", ny), _card("NAXIS3", L), _card("EXTEND", True), _card("BUNIT", bunit, "flux per pixel" if bunit else "normalized PSF"),
             _card("ORIGIN", "irtlang")]
    if object_name:
        cards.append(_card("OBJECT", object_name, "the detector (or SPOTS, PSF)"))
    wcs = _wcs_cards(img.shape, extent, wavelengths_nm, length_unit, bands, focal_length_m)
    cards += wcs
    if wavelengths_nm is not None:
        for k, lam in enumerate(wavelengths_nm[:999]):
            cards.append(_card(f"WAVE{k + 1:04d}"[:8], float(lam), "nm, line k+1"))
    if bands is not None:
        for k, b in enumerate(list(bands)[:999]):
            cards.append(_card(f"FILT{k + 1:04d}"[:8], str(b), "filter of band k+1"))
    pv = dict(provenance or {})
    cards.append(_card("DATE", _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S"), "file written, UTC"))
    if pv.get("epoch_utc"):
        cards.append(_card("DATE-OBS", pv["epoch_utc"], "EPOCH of the frame, UTC"))
    for key, name, comment in (("IRTVER", "irtlang_version", "irtlang version"),
                               ("SCRIPT", "script", "the script run"),
                               ("SCRSHA", "script_sha256", "SHA-256 of the script text"),
                               ("SEED", "seed", "random seed"), ("DATATIER", "data_tier", "Earth data tier"),
                               ("RAYS", "rays_traced", "source rays traced in the run so far")):
        if pv.get(name) is not None:
            v = pv[name]
            if name == "script":
                v = Path(str(v)).name
            cards.append(_card(key, v, comment))
    cards.append(_card("EXTNAME", "FLUX"))
    out = [_block(cards)] + _data(img)
    if stderr is not None:
        ext = [_card("XTENSION", "IMAGE"), _card("BITPIX", -64), _card("NAXIS", 3), _card("NAXIS1", nx),
               _card("NAXIS2", ny), _card("NAXIS3", L), _card("PCOUNT", 0), _card("GCOUNT", 1),
               _card("EXTNAME", "STDERR"), _card("BUNIT", "W", "Monte Carlo standard error per pixel")] + wcs
        out += [_block(ext)] + _data(stderr)
    return out


LOG_DECADES = 8     # EXPORT ... LOG: the colour scale's range below the brightest pixel


def log_scale(total):
    """(picture, norm) of EXPORT ... LOG: a logarithmic colour scale from a decade below the faintest lit pixel
    (so that it is drawn in colour, not in the scale's black; at most LOG_DECADES below the brightest) to the
    brightest, pixels without light NaN (drawn black); (total, None) when no pixel is lit."""
    from matplotlib.colors import LogNorm

    top = float(np.max(total)) if np.size(total) else 0.0
    if not top > 0:
        return total, None
    lo = max(0.1 * float(np.min(total[total > 0])), top * 10.0 ** -LOG_DECADES)
    return np.where(total > 0, total, np.nan), LogNorm(vmin=lo, vmax=top, clip=True)


def _png(path: Path, img, extent, length_unit, label: str = "flux per pixel (W)", log: bool = False) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg     # no pyplot: half a second less per run
    from matplotlib.figure import Figure

    total = img.sum(axis=0)
    norm = None
    if log:
        total, norm = log_scale(total)
    fig = Figure(figsize=(5, 4.2), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    kw = {}
    if extent is not None:   # the detector's local x, y (or the WINDOW's axes), equal scales
        kw["extent"] = extent
        ax.set_xlabel(f"x ({length_unit})")
        ax.set_ylabel(f"y ({length_unit})")
    else:
        ax.set_xlabel("column (pixel)")
        ax.set_ylabel("row (pixel)")
    if norm is not None:
        kw["norm"] = norm
        ax.set_facecolor("black")
    im = ax.imshow(total, origin="lower", cmap="inferno", aspect="equal", **kw)
    fig.colorbar(im, ax=ax, label=label + (", log scale" if norm is not None else ""))
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
