"""Image files for EXPORT and SPOTS: .npy, .fits, .png, .csv (chosen by extension), written atomically.

The array is float64 (n_lines, ny, nx): index [k, j, i] is line k, row j (j = 0 at the lowest local y),
column i (i = 0 at the lowest local x).  With per-pixel sums of squares, the standard error map goes
alongside: ``NAME.stderr.npy`` for .npy, an ``STDERR`` image extension for .fits.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .atomic import atomic_path, write_bytes, write_text


def write_image(path: Path, img: np.ndarray, *, sum2=None, extent=None, wavelengths_nm=None,
                length_unit: str = "mm", n_traced: int | None = None, psf: bool = False) -> list[Path]:
    """`sum2`: the per-source-ray squared sums; the standard error is the tracer's (the same as every printed
    total's) when `n_traced` is given, else sqrt(sum2).  `psf`: a normalized PSF (energy fraction per pixel),
    labelled as such (PNG colour bar, CSV column, FITS BUNIT)."""
    path = Path(path)
    ext = path.suffix.lower()
    img = np.asarray(img, np.float64)
    if sum2 is not None and n_traced:
        from ..tracer import standard_error

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
        write_bytes(path, fits_bytes(img, stderr, extent, wavelengths_nm, length_unit, bunit="" if psf else "W"))
    elif ext == ".png":
        _png(path, img, extent, length_unit, label="normalized PSF (energy fraction per pixel)" if psf
             else "flux per pixel (W)")
    elif ext == ".csv":
        buf = io.StringIO()
        buf.write("line,wavelength_nm,row,col," + ("psf_fraction" if psf else "flux_W")
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
        v = f"{float(value):>20.12E}"
    else:
        v = f"'{str(value):<8}'"
    s = f"{key:<8}= {v}" + (f" / {comment}" if comment else "")
    return s[:80].ljust(80).encode("ascii")


def _block(cards: list[bytes]) -> bytes:
    data = b"".join(cards) + b"END".ljust(80)
    return data + b" " * (-len(data) % 2880)


def _data(a: np.ndarray) -> bytes:
    raw = a.astype(">f8").tobytes()
    return raw + b"\0" * (-len(raw) % 2880)


def fits_bytes(img, stderr, extent, wavelengths_nm, length_unit, bunit: str = "W") -> bytes:
    """A FITS file (primary image, optional STDERR extension) by the FITS 4.0 standard, no dependencies."""
    L, ny, nx = img.shape
    cards = [_card("SIMPLE", True), _card("BITPIX", -64), _card("NAXIS", 3), _card("NAXIS1", nx),
             _card("NAXIS2", ny), _card("NAXIS3", L), _card("EXTEND", True), _card("BUNIT", bunit),
             _card("ORIGIN", "irtlang")]
    if extent is not None:
        x0, x1, y0, y1 = extent
        cards += [_card("CTYPE1", "LOCAL_X"), _card("CUNIT1", length_unit), _card("CRPIX1", 1.0),
                  _card("CRVAL1", x0 + (x1 - x0) / nx / 2), _card("CDELT1", (x1 - x0) / nx),
                  _card("CTYPE2", "LOCAL_Y"), _card("CUNIT2", length_unit), _card("CRPIX2", 1.0),
                  _card("CRVAL2", y0 + (y1 - y0) / ny / 2), _card("CDELT2", (y1 - y0) / ny),
                  _card("PIXSIZEX", (x1 - x0) / nx, f"pixel width, {length_unit}"),
                  _card("PIXSIZEY", (y1 - y0) / ny, f"pixel height, {length_unit}")]
    if wavelengths_nm is not None:
        for k, lam in enumerate(wavelengths_nm[:999]):
            cards.append(_card(f"WAVE{k + 1:04d}"[:8], float(lam), "nm, line k+1"))
    out = _block(cards) + _data(img)
    if stderr is not None:
        ext = [_card("XTENSION", "IMAGE"), _card("BITPIX", -64), _card("NAXIS", 3), _card("NAXIS1", nx),
               _card("NAXIS2", ny), _card("NAXIS3", L), _card("PCOUNT", 0), _card("GCOUNT", 1),
               _card("EXTNAME", "STDERR"), _card("BUNIT", "W")]
        out += _block(ext) + _data(stderr)
    return out


def _png(path: Path, img, extent, length_unit, label: str = "flux per pixel (W)") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    total = img.sum(axis=0)
    fig, ax = plt.subplots(figsize=(5, 4.2), dpi=120)
    kw = {}
    if extent is not None:   # the detector's local x, y (or the WINDOW's axes), equal scales
        kw["extent"] = extent
        ax.set_xlabel(f"x ({length_unit})")
        ax.set_ylabel(f"y ({length_unit})")
    else:
        ax.set_xlabel("column (pixel)")
        ax.set_ylabel("row (pixel)")
    im = ax.imshow(total, origin="lower", cmap="inferno", aspect="equal", **kw)
    fig.colorbar(im, ax=ax, label=label)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
