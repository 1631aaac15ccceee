"""Stray-light analysis of ray records: the path report (STATS PATHS) and its standard errors.

A *path* is the sequence of objects a ray met, with the event at each (reflect, transmit, scatter, absorb), as
the tracer records it in each record's history (``object * 8 + kind``, docs/tracer.md; a volume event is -2).
The history holds the first H events (H = min(LEVEL, 16)); a longer path is reported with its first H events and
the count of the rest, so paths that differ only beyond H share a row.

Standard errors: a source ray may end as several records (``RAYS n`` splits at a scattering, ``TOWARD`` sends
next-event rays), which are not independent.  The records of one source ray share its source, line and start point
(split and next-event rays keep their source ray's start point), so the sums are grouped by that key before
squaring: the standard error of a path's flux is that of a sum of independent per-source-ray contributions, as for
the ledger.  A source whose rays all start at one point (``EMITTING POINT``) gives no such key: its records are
taken as independent, which is exact when nothing splits.
"""
from __future__ import annotations

import numpy as np

from ..core.stats import standard_error

EVENT_NAMES = {1: "reflect", 2: "transmit", 3: "scatter", 4: "absorb"}


def ray_keys(records: dict) -> np.ndarray:
    """An integer per record naming its source ray (see the module docstring)."""
    n = len(records["flux"])
    start = records.get("start")
    if start is None or n == 0:
        return np.arange(n)
    src = np.asarray(records["source"], np.int64)
    line = np.asarray(records["line"], np.int64)
    key = np.empty(n, np.int64)
    tab = np.empty(n, dtype=[("s", "i8"), ("l", "i8"), ("x", "f8"), ("y", "f8")])
    tab["s"], tab["l"], tab["x"], tab["y"] = src, line, start[:, 0], start[:, 1]
    _, inv = np.unique(tab, return_inverse=True)
    key[:] = inv.reshape(-1)
    # a source whose records all share one start point per line: each record on its own
    for s in np.unique(src):
        m = src == s
        if m.sum() > 1 and np.all(start[m] == start[m][0]):
            key[m] = key.max() + 1 + np.arange(int(m.sum()))
    return key


def grouped_se(flux: np.ndarray, keys: np.ndarray, n_traced: int) -> float:
    """Standard error of sum(flux) with the records grouped by source ray (keys)."""
    if len(flux) == 0:
        return 0.0
    _, inv = np.unique(keys, return_inverse=True)
    per_ray = np.bincount(inv.reshape(-1), weights=flux)
    return float(standard_error(flux.sum(), (per_ray * per_ray).sum(), n_traced))


def describe(row: np.ndarray, n_events: int, names) -> tuple[str, str]:
    """(path, events) text of one history row: 'wall > det', 'scatter > absorb'."""
    objs, evs = [], []
    for h in row:
        if h == -1:
            break
        if h == -2:
            objs.append("(volume)")
            evs.append("volume scatter")
            continue
        o, k = int(h) // 8, int(h) % 8
        objs.append(names[o] if 0 <= o < len(names) else f"#{o}")
        evs.append(EVENT_NAMES.get(k, "?"))
    recorded = len(objs)
    if n_events > recorded and recorded == len(row):
        objs.append(f"... (+{n_events - recorded} events)")
        evs.append("...")
    if not objs:
        return "(no interaction)", ""
    return " > ".join(objs), " > ".join(evs)


def path_table(records: dict, mask: np.ndarray, names, n_traced: int, top: int | None = None):
    """The path report of the masked records: (rows, other, total, total_se, n_paths).

    rows: [(path, events, flux, se, count, member mask)], sorted by flux (largest first), at most `top`;
    other: the same tuple for the rest (None when nothing is left out)."""
    hist = np.asarray(records["history"])[mask]
    if hist.ndim != 2 or hist.shape[1] == 0:
        hist = np.full((int(mask.sum()), 1), -1, np.int64)
    ev = np.asarray(records["events"])[mask].astype(np.int64)
    H = hist.shape[1]
    trunc = np.where((ev > H) & (hist[:, -1] != -1), ev, 0)
    key = np.concatenate([hist.astype(np.int64), trunc[:, None]], axis=1)
    flux = np.asarray(records["flux"])[mask]
    keys = ray_keys({k: (np.asarray(v)[mask] if v is not None and k in ("source", "line", "start", "flux")
                         else v) for k, v in records.items() if k in ("source", "line", "start", "flux")})
    idx = np.flatnonzero(mask)
    total = float(flux.sum())
    total_se = grouped_se(flux, keys, n_traced)
    if len(flux) == 0:
        return [], None, 0.0, 0.0, 0
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    sums = np.bincount(inv, weights=flux, minlength=len(uniq))
    order = np.argsort(-sums, kind="stable")
    rows = []
    keep = order if top is None else order[:top]
    for p in keep:
        m = inv == p
        path, events = describe(uniq[p, :H], int(uniq[p, H]) or int(ev[m][0]), names)
        full = np.zeros(len(mask), bool)
        full[idx[m]] = True
        rows.append((path, events, float(sums[p]), grouped_se(flux[m], keys[m], n_traced), int(m.sum()), full))
    other = None
    if top is not None and len(order) > top:
        m = ~np.isin(inv, order[:top])
        full = np.zeros(len(mask), bool)
        full[idx[m]] = True
        other = (f"other ({len(order) - top} paths)", "", float(flux[m].sum()),
                 grouped_se(flux[m], keys[m], n_traced), int(m.sum()), full)
    return rows, other, total, total_se, len(uniq)
