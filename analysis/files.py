"""Loading images, cubes and tables from files for the command line: .npy, .csv/.txt, FITS (when astropy is
installed) and irtlang ray files (``FILE.h5[:DETECTOR[:LINE]]``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._common import AnalysisError

__all__ = ["load_array", "load_image", "load_cube"]

_RAY_SUFFIXES = (".h5", ".hdf5", ".hdf")
_FITS_SUFFIXES = (".fits", ".fit", ".fts")


def _split_spec(spec):
    """``FILE.h5:DET:LINE`` -> (Path, detector or None, line or None); other paths -> (Path, None, None)."""
    text = str(spec)
    for suffix in _RAY_SUFFIXES:
        pos = text.lower().find(suffix + ":")
        if pos >= 0:
            head, rest = text[:pos + len(suffix)], text[pos + len(suffix) + 1:].split(":")
            if len(rest) > 2:
                raise AnalysisError(f"{spec}: expected FILE.h5[:DETECTOR[:LINE]]")
            line = None
            if len(rest) == 2:
                try:
                    line = int(rest[1])
                except ValueError:
                    raise AnalysisError(f"{spec}: the line index must be an integer") from None
            return Path(head), rest[0] or None, line
    return Path(text), None, None


def _detector(path, name):
    from .rayfile import read_rays

    rf = read_rays(path)
    if not rf.detectors:
        raise AnalysisError(f"{path}: the ray file holds no detector image")
    if name is None:
        if len(rf.detectors) > 1:
            raise AnalysisError(f"{path}: several detectors ({', '.join(rf.detectors)}); name one as FILE.h5:NAME")
        name = next(iter(rf.detectors))
    if name not in rf.detectors:
        raise AnalysisError(f"{path}: no detector {name!r}; present: {', '.join(rf.detectors)}")
    return rf, rf.detectors[name]


def load_array(spec):
    """Array from a file: ``.npy`` (no pickles), ``.csv``/``.txt`` (comma or whitespace separated, ``#``
    comments), FITS (primary or first image HDU; needs astropy), or a ray file ``FILE.h5[:DETECTOR[:LINE]]``
    (the detector's ``sum`` cube (L, ny, nx), or one line of it).

    Signature: ``load_array(spec) -> ndarray``.
    """
    path, det, line = _split_spec(spec)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise AnalysisError(f"{path}: no such file")
    try:
        if suffix in _RAY_SUFFIXES:
            _, d = _detector(path, det)
            if line is None:
                return d.sum
            if not 0 <= line < d.sum.shape[0]:
                raise AnalysisError(f"{spec}: line {line} outside 0..{d.sum.shape[0] - 1}")
            return d.sum[line]
        if suffix == ".npy":
            return np.load(path, allow_pickle=False)
        if suffix in (".csv", ".txt"):
            text = path.read_text()
            delimiter = "," if "," in text else None
            return np.loadtxt(path, delimiter=delimiter, ndmin=1)
        if suffix in _FITS_SUFFIXES:
            try:
                from astropy.io import fits
            except ImportError:
                raise AnalysisError(f"{path}: reading FITS needs astropy, which is not installed") from None
            with fits.open(path) as hdul:
                for hdu in hdul:
                    if hdu.data is not None:
                        return np.asarray(hdu.data, dtype=np.float64)
            raise AnalysisError(f"{path}: the FITS file holds no image")
    except AnalysisError:
        raise
    except (OSError, ValueError, EOFError) as exc:
        raise AnalysisError(f"{path}: cannot read ({exc})") from None
    raise AnalysisError(f"{path}: unknown file type {suffix!r} (use .npy, .csv, .txt, .fits or .h5)")


def load_image(spec):
    """2-D image from a file (see :func:`load_array`); a cube (L, H, W) from a ray file is summed over lines, and a
    one-line cube (1, H, W), as irtlang's EXPORT writes for one wavelength line, is that line.

    Signature: ``load_image(spec) -> (H, W) float array``.
    """
    arr = np.asarray(load_array(spec), dtype=np.float64)
    if arr.ndim == 3 and _split_spec(spec)[0].suffix.lower() in _RAY_SUFFIXES:
        arr = arr.sum(axis=0)
    elif arr.ndim == 3 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 2:
        raise AnalysisError(f"{spec}: expected a 2-D image, got shape {arr.shape}")
    return arr


def load_cube(spec):
    """Image cube (L, H, W) and wavelengths in nm (or None) from a file; a ray file supplies its wavelength table.

    Signature: ``load_cube(spec) -> (cube (L, H, W), wavelengths_nm or None, sum2 or None)``.
    """
    path, det, _ = _split_spec(spec)
    if path.suffix.lower() in _RAY_SUFFIXES:
        rf, d = _detector(path, det)
        return d.sum, rf.wavelengths_nm, d.sum2
    arr = np.asarray(load_array(spec), dtype=np.float64)
    if arr.ndim != 3:
        raise AnalysisError(f"{spec}: expected a cube (L, H, W), got shape {arr.shape}")
    return arr, None, None
