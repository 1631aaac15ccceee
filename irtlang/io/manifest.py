"""The run folder's manifest.json: provenance and every file a run wrote."""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
from pathlib import Path

from .._version import __version__
from .atomic import write_text


class RunFolder:
    def __init__(self, root: Path, script: str, script_sha256: str, seed: int = 0, data_tier: str = "none"):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.files: list[dict] = []
        self.info = {"irtlang_version": __version__, "script": script, "script_sha256": script_sha256,
                     "seed": seed, "data_tier": data_tier, "rays_traced": 0,
                     "started_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}

    def output(self, rel: str, create: bool = True) -> Path:
        """Where an output named in the script goes (relative paths are relative to the run folder); create: make
        its folder ('frames/x.npy', 'rays/y.h5'), which a lookup of an existing file does not need."""
        p = Path(rel)
        p = p if p.is_absolute() else self.root / p
        if create:
            p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def record(self, path: Path, kind: str) -> None:
        path = Path(path)
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        try:
            name = str(path.relative_to(self.root))
        except ValueError:
            name = str(path)
        self.files = [f for f in self.files if f["path"] != name]
        self.files.append({"path": name, "kind": kind, "bytes": path.stat().st_size, "sha256": digest})

    def write_manifest(self, status: str, **extra) -> Path:
        data = dict(self.info, status=status,
                    finished_utc=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                    files=self.files, **extra)
        p = self.root / "manifest.json"
        write_text(p, json.dumps(data, indent=2, default=str) + "\n")
        return p
