"""Reader and reference writer of irtlang ray files, HDF5 schema version 1 (docs/rayfile.md).

The format belongs to irtlang's file stage (SAVE RAYS writes it, LOAD RAYS reads it); the analysis package
re-exports it as ``analysis.rayfile``.  Bad files raise :class:`irtlang.core.checks.AnalysisError`."""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._version import __version__ as _irtlang_version
from ..core.checks import AnalysisError
from .atomic import atomic_path as _atomic_path

__all__ = ["SCHEMA", "SCHEMA_VERSION", "FLAGS", "Detector", "RayFile", "read_rays", "write_rays_v1"]

SCHEMA = "irtlang-rays"
SCHEMA_VERSION = 1
#: Bits of ``/rays/flags``.
FLAGS = {"scattered": 1 << 0, "transmitted": 1 << 1, "reflected": 1 << 2, "halted": 1 << 3, "escaped": 1 << 4,
         "lost": 1 << 5}
_ROOT_ATTRS = {"schema": str, "schema_version": int, "irtlang_version": str, "script_sha256": str, "seed": int,
               "length_unit": str, "flux_unit": str, "data_tier": str, "rays_traced": int, "created_utc": str}
# column: (trailing shape, dtype)
_RAY_COLUMNS = {
    "position": ((3,), np.float64), "direction": ((3,), np.float64), "flux": ((), np.float64),
    "line": ((), np.int32), "source": ((), np.int32), "object": ((), np.int32), "events": ((), np.int32),
    "flags": ((), np.uint32), "history": ((None,), np.int32),
}


def _check_column(name, arr, n, where):
    """Raise AnalysisError unless ray column ``name`` has n rows and its documented trailing shape."""
    tail = _RAY_COLUMNS[name][0]
    ok = arr.ndim == 1 + len(tail) and arr.shape[0] == n and all(
        t is None or t == size for t, size in zip(tail, arr.shape[1:]))
    if not ok:
        want = "".join(f", {'H' if t is None else t}" for t in tail)
        raise AnalysisError(f"{where}/rays/{name} has shape {arr.shape}, expected ({n}{want})")


@dataclass
class Detector:
    """One detector of a ray file: ``sum`` and ``sum2`` (L, ny, nx) in W and W^2 (index [line, row, col], row 0 at
    the lowest local y); ``x_range``, ``y_range`` and ``pixel_size`` in ``length_unit``."""

    name: str
    sum: np.ndarray
    sum2: np.ndarray
    x_range: np.ndarray
    y_range: np.ndarray
    pixel_size: np.ndarray

    def stderr(self):
        """Standard error of each pixel sum, ``sqrt(sum2)`` (independent rays, Poisson counts), W."""
        return np.sqrt(self.sum2)


@dataclass
class RayFile:
    """Contents of a schema-1 ray file. ``attrs``: the root attributes; ray columns are None when the file holds
    no ``/rays`` group; ``detectors`` maps names to :class:`Detector`."""

    attrs: dict
    wavelengths_nm: np.ndarray
    objects: list
    position: np.ndarray | None = None
    direction: np.ndarray | None = None
    flux: np.ndarray | None = None
    line: np.ndarray | None = None
    source: np.ndarray | None = None
    object: np.ndarray | None = None
    events: np.ndarray | None = None
    flags: np.ndarray | None = None
    history: np.ndarray | None = None
    detectors: dict = field(default_factory=dict)
    #: optional (written by irtlang since the path report): the event at each history entry (0 none, 1 reflect,
    #: 2 transmit, 3 scatter, 4 absorb, 5 volume scattering), each ray's start point in its source's frame
    #: (length_unit) and the trace's energy ledger {"rows", "values" (rows, 5, L), "sum_sq" (rows, L)}
    event_kinds: np.ndarray | None = None
    start: np.ndarray | None = None
    ledger: dict | None = None
    #: optional: each object's frame (K, 4, 3): origin (length_unit), local x, local y, normal (world)
    object_frames: np.ndarray | None = None

    @property
    def n_rays(self):
        """Number of ray records (0 without a ``/rays`` group)."""
        return 0 if self.flux is None else int(self.flux.shape[0])

    def has_flag(self, name):
        """Boolean mask of the rays whose ``flags`` carry the named bit (see ``FLAGS``)."""
        if self.flags is None:
            raise AnalysisError("this ray file holds no ray records")
        try:
            return (self.flags & FLAGS[name]) != 0
        except KeyError:
            raise AnalysisError(f"unknown flag {name!r}; known: {', '.join(FLAGS)}") from None


def _attr(value):
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.generic):
        return value.item()
    return value


def read_rays(path):
    """Read an irtlang ray file (HDF5, schema ``irtlang-rays`` version 1; see docs/rayfile.md).

    Signature: ``read_rays(path) -> RayFile``.

    Checks the ``schema`` and ``schema_version`` root attributes first and refuses any other schema or version
    with an AnalysisError naming both versions; then checks every documented attribute, dataset shape and the
    consistency of the ray columns (one length N), the line indices and the detector cubes (L lines).
    """
    import h5py

    path = Path(path)
    try:
        fh = h5py.File(path, "r")
    except OSError as exc:
        raise AnalysisError(f"{path}: not a readable HDF5 file ({exc})") from None
    with fh:
        attrs = {k: _attr(v) for k, v in fh.attrs.items()}
        schema, version = attrs.get("schema"), attrs.get("schema_version")
        if schema != SCHEMA:
            raise AnalysisError(f"{path}: schema is {schema!r}, expected {SCHEMA!r} (version {SCHEMA_VERSION})")
        if version != SCHEMA_VERSION:
            raise AnalysisError(f"{path}: ray-file schema version {version!r} is not supported; this reader reads "
                                f"version {SCHEMA_VERSION} only")
        missing = [k for k in _ROOT_ATTRS if k not in attrs]
        if missing:
            raise AnalysisError(f"{path}: missing root attribute(s) {', '.join(missing)}")
        for name in ("wavelengths_nm", "objects"):
            if name not in fh:
                raise AnalysisError(f"{path}: missing dataset /{name}")
        wl = np.asarray(fh["wavelengths_nm"][()], dtype=np.float64).reshape(-1)
        objects = [o.decode("utf-8") if isinstance(o, bytes) else str(o) for o in fh["objects"][()]]
        out = RayFile(attrs=attrs, wavelengths_nm=wl, objects=objects)
        if "rays" in fh:
            n = None
            for col, (_, dtype) in _RAY_COLUMNS.items():
                if col not in fh["rays"]:
                    raise AnalysisError(f"{path}: missing dataset /rays/{col}")
                arr = np.asarray(fh["rays"][col][()], dtype=dtype)
                n = arr.shape[0] if n is None else n
                _check_column(col, arr, n, f"{path}: ")
                setattr(out, col, arr)
            if out.line.size and (out.line.min() < 0 or out.line.max() >= wl.size):
                raise AnalysisError(f"{path}: /rays/line indexes beyond the {wl.size} wavelength lines")
            for col, dtype, shape in (("event_kinds", np.int8, out.history.shape), ("start", np.float64, (n, 2))):
                if col in fh["rays"]:
                    arr = np.asarray(fh["rays"][col][()], dtype=dtype)
                    if arr.shape != shape:
                        raise AnalysisError(f"{path}: /rays/{col} has shape {arr.shape}, expected {shape}")
                    setattr(out, col, arr)
        if "object_frames" in fh:
            fr = np.asarray(fh["object_frames"][()], np.float64)
            if fr.shape != (len(objects), 4, 3):
                raise AnalysisError(f"{path}: /object_frames has shape {fr.shape}, expected ({len(objects)}, 4, 3)")
            out.object_frames = fr
        if "ledger" in fh:
            g = fh["ledger"]
            rows = [o.decode("utf-8") if isinstance(o, bytes) else str(o) for o in g["rows"][()]]
            vals, sq = np.asarray(g["values"][()], np.float64), np.asarray(g["sum_sq"][()], np.float64)
            if vals.shape != (len(rows), 5, wl.size) or sq.shape != (len(rows), wl.size):
                raise AnalysisError(f"{path}: /ledger/values {vals.shape} and /ledger/sum_sq {sq.shape} do not match "
                                    f"{len(rows)} rows and {wl.size} lines")
            out.ledger = {"rows": rows, "values": vals, "sum_sq": sq}
        for name, grp in fh.get("detectors", {}).items():
            s, s2 = np.asarray(grp["sum"][()], np.float64), np.asarray(grp["sum2"][()], np.float64)
            if s.ndim != 3 or s.shape[0] != wl.size or s2.shape != s.shape:
                raise AnalysisError(f"{path}: detector {name!r} has sum {s.shape} and sum2 {s2.shape}; "
                                    f"expected (L={wl.size}, ny, nx) for both")
            try:
                ranges = [np.asarray(grp.attrs[k], np.float64).reshape(2) for k in ("x_range", "y_range",
                                                                                     "pixel_size")]
            except (KeyError, ValueError):
                raise AnalysisError(f"{path}: detector {name!r} lacks x_range, y_range or pixel_size "
                                    "(2-vectors)") from None
            out.detectors[name] = Detector(name, s, s2, *ranges)
    return out


def write_rays_v1(path, *, wavelengths_nm, objects=(), position=None, direction=None, flux=None, line=None,
                  source=None, object=None, events=None, flags=None, history=None, detectors=None,
                  length_unit="mm", seed=0, script_sha256="", data_tier="none", rays_traced=0,
                  irtlang_version=None, created_utc=None, event_kinds=None, start=None, ledger=None,
                  object_frames=None):
    """Reference writer of a schema-1 ray file, atomic (temporary file in the same folder, then ``os.replace``).

    Signature: ``write_rays_v1(path, *, wavelengths_nm, objects=(), position=None, direction=None, flux=None,
    line=None, source=None, object=None, events=None, flags=None, history=None, detectors=None,
    length_unit="mm", seed=0, script_sha256="", data_tier="none", rays_traced=0, irtlang_version=None,
    created_utc=None) -> Path``.

    Ray columns are written when ``position`` is given (then ``direction`` and ``flux`` are required; ``line``,
    ``source``, ``events``, ``flags`` default to 0, ``object`` to -1 and ``history`` to one column of -1).
    ``detectors``: ``{name: {"sum": (L, ny, nx), "sum2": ..., "x_range": (2,), "y_range": (2,),
    "pixel_size": (2,)}}`` (``sum2`` defaults to zeros). Optional: ``event_kinds`` (N, H) int8, ``start`` (N, 2)
    and ``ledger`` {"rows", "values", "sum_sq"}. Units as in docs/rayfile.md.
    """
    import h5py

    wl = np.asarray(wavelengths_nm, dtype=np.float64).reshape(-1)
    if irtlang_version is None:
        irtlang_version = _irtlang_version
    attrs = {"schema": SCHEMA, "schema_version": SCHEMA_VERSION, "irtlang_version": str(irtlang_version),
             "script_sha256": str(script_sha256), "seed": int(seed), "length_unit": str(length_unit),
             "flux_unit": "W", "data_tier": str(data_tier), "rays_traced": int(rays_traced),
             "created_utc": created_utc or _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}
    columns = None
    if position is not None:
        pos = np.asarray(position, dtype=np.float64)
        n = pos.shape[0] if pos.ndim else 0
        if direction is None or flux is None:
            raise AnalysisError("write_rays_v1: position needs direction and flux")

        given = {"position": pos, "direction": direction, "flux": flux, "line": line, "source": source,
                 "object": object, "events": events, "flags": flags, "history": history}
        defaults = {"object": -1, "history": -1}
        columns = {}
        for name, value in given.items():
            dtype = _RAY_COLUMNS[name][1]
            if value is None:
                columns[name] = np.full((n, 1) if name == "history" else (n,), defaults.get(name, 0), dtype=dtype)
            else:
                columns[name] = np.asarray(value, dtype=dtype)
                _check_column(name, columns[name], n, "write_rays_v1: ")
    folder = Path(path).parent if str(Path(path).parent) else Path(".")
    if not folder.is_dir():
        raise AnalysisError(f"cannot write {path}: folder {folder} does not exist")
    with _atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as fh:
            fh.attrs.update(attrs)
            fh.create_dataset("wavelengths_nm", data=wl)
            fh.create_dataset("objects", data=list(objects), dtype=h5py.string_dtype())
            if columns is not None:
                grp = fh.create_group("rays")
                for name, arr in columns.items():
                    grp.create_dataset(name, data=arr)
                if event_kinds is not None:
                    grp.create_dataset("event_kinds", data=np.asarray(event_kinds, np.int8).reshape(columns["history"].shape))
                if start is not None:
                    grp.create_dataset("start", data=np.asarray(start, np.float64).reshape(-1, 2))
            if object_frames is not None:
                fh.create_dataset("object_frames", data=np.asarray(object_frames, np.float64).reshape(-1, 4, 3))
            if ledger is not None:
                g = fh.create_group("ledger")
                g.create_dataset("rows", data=list(ledger["rows"]), dtype=h5py.string_dtype())
                g.create_dataset("values", data=np.asarray(ledger["values"], np.float64))
                g.create_dataset("sum_sq", data=np.asarray(ledger["sum_sq"], np.float64))
            for name, det in (detectors or {}).items():
                grp = fh.create_group(f"detectors/{name}")
                s = np.asarray(det["sum"], dtype=np.float64)
                grp.create_dataset("sum", data=s)
                grp.create_dataset("sum2", data=np.asarray(det.get("sum2", np.zeros_like(s)), dtype=np.float64))
                for key in ("x_range", "y_range", "pixel_size"):
                    grp.attrs[key] = np.asarray(det[key], dtype=np.float64).reshape(2)
    return Path(path)
