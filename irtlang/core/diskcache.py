"""A content-addressed cache on disk for work that every run of a script repeats: the parse of large include
files (the Earth's model lines, 1.1 MB: 7 s) and the scatter models' packed tables (the Earth's 152 models:
12 s).  Like Numba's cache, it only ever saves time: an entry is found by a SHA-256 of everything its value
depends on (the input and the source code that computes it), so a changed input or a changed irtlang never
reads a stale entry, and an entry that cannot be read is computed again.

Where: ``$IRT_CACHE_DIR``, else ``$XDG_CACHE_HOME/irtlang``, else ``~/.cache/irtlang``; one folder per kind
(``parse/``, ``packs/``).  ``IRT_DISK_CACHE=0`` turns it off.  The folder may be deleted at any time.
Values are pickles written by this installation for itself (the folder is the user's own, like Numba's).
"""
from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import pickle
import tempfile
from pathlib import Path

MAX_BYTES = 256 * 2 ** 20   # per kind: the least recently used entries are removed past this (the Earth's
                            # 152 packed models take 64 MB, its parses 9 MB)


def enabled() -> bool:
    return os.environ.get("IRT_DISK_CACHE", "1") not in ("0", "", "no", "off")


def root() -> Path:
    env = os.environ.get("IRT_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "irtlang"


@functools.lru_cache(maxsize=64)
def code_hash(*files: str) -> str:
    """SHA-256 of the source files that compute a cached value (part of every key)."""
    h = hashlib.sha256()
    for f in files:
        h.update(Path(f).read_bytes())
    return h.hexdigest()


def key(*parts) -> str:
    """The entry's name: a SHA-256 of the parts (bytes, or anything whose repr is exact: str, int, tuples)."""
    h = hashlib.sha256()
    for p in parts:
        b = p if isinstance(p, bytes) else repr(p).encode("utf-8")
        h.update(len(b).to_bytes(8, "little"))
        h.update(b)
    return h.hexdigest()


def _path(kind: str, k: str) -> Path:
    return root() / kind / f"{k}.pkl"


def load(kind: str, k: str):
    """The value stored under key k, or None (absent, unreadable, or the cache turned off)."""
    if not enabled():
        return None
    p = _path(kind, k)
    try:
        with open(p, "rb") as f:
            value = pickle.load(f)
    except Exception:       # absent, truncated by a crash, written by another Python: compute it again
        return None
    with contextlib.suppress(OSError):
        os.utime(p)         # recently used: trimmed last
    return value


def store(kind: str, k: str, value) -> None:
    """Write the value atomically (a temporary file renamed over the entry); a failure is silent."""
    if not enabled():
        return
    p = _path(kind, k)
    with contextlib.suppress(OSError, pickle.PicklingError, TypeError, AttributeError, RecursionError):
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, p)
        finally:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
        _trim(p.parent)


def _trim(folder: Path) -> None:
    """Remove the least recently used entries while the folder holds more than MAX_BYTES."""
    entries = []
    for e in folder.glob("*.pkl"):
        with contextlib.suppress(OSError):
            st = e.stat()
            entries.append((st.st_mtime, st.st_size, e))
    total = sum(sz for _, sz, _ in entries)
    for _, sz, e in sorted(entries, key=lambda t: t[0]):
        if total <= MAX_BYTES:
            break
        with contextlib.suppress(OSError):
            e.unlink()
            total -= sz
