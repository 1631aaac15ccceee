"""The run folder's manifest.json: provenance and every file a run wrote."""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
from pathlib import Path

from .._version import __version__
from .atomic import write_text


RUNNING = "running"    # the status of a run that has not finished: its files may be missing or stale


class OutsideRunFolder(ValueError):
    """An output that would land outside the run folder (a '..', an absolute path, a link out of the folder)."""


class RunFolder:
    """The run folder.  Creating it writes a manifest with status "running" and no files before anything else,
    so a run killed part way never leaves an earlier run's manifest vouching for files it did not write."""

    def __init__(self, root: Path, script: str, script_sha256: str, seed: int = 0, data_tier: str = "none",
                 *, allow_outside: bool = False):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.allow_outside = allow_outside
        self.files: list[dict] = []
        self.info = {"irtlang_version": __version__, "script": script, "script_sha256": script_sha256,
                     "seed": seed, "data_tier": data_tier, "rays_traced": 0,
                     "started_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}
        self.write_manifest(RUNNING, finished_utc=None)

    def output(self, rel: str, create: bool = True) -> Path:
        """Where an output named in the script goes (relative to the run folder; create: make its folder,
        'frames/x.npy', which a lookup of an existing file does not need).  It must resolve inside the run
        folder (links followed) unless the run allows outside outputs (irt run --allow-outside)."""
        if "\0" in rel:
            raise OutsideRunFolder(f"output name {rel!r} holds a NUL character")
        p = Path(rel)
        p = p if p.is_absolute() else self.root / p
        if not self.allow_outside:
            root = self.root.resolve()
            q = p.resolve()
            if q != root and root not in q.parents:
                raise OutsideRunFolder(f"output '{rel}' would be written outside the run folder {self.root}"
                                       + (f" (at {q})" if not Path(rel).is_absolute() else ""))
        if create:
            p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def record(self, path: Path, kind: str) -> None:
        path = Path(path)
        h = hashlib.sha256()
        with open(path, "rb") as fh:      # in blocks: an image cube can be 600 MB
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        digest = h.hexdigest()
        try:
            name = str(path.relative_to(self.root))
        except ValueError:
            name = str(path)
        self.files = [f for f in self.files if f["path"] != name]
        self.files.append({"path": name, "kind": kind, "bytes": path.stat().st_size, "sha256": digest})

    def write_manifest(self, status: str, **extra) -> Path:
        data = dict(self.info, status=status,
                    finished_utc=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                    files=self.files)
        data.update(extra)
        p = self.root / "manifest.json"
        write_text(p, json.dumps(data, indent=2, default=str) + "\n")
        return p
