"""Helpers for the stress tests (tests/stress/test_stress_*.py): run whole scripts through `irt run` under a
wall-clock guard and check everything they wrote.

`Runner` keeps one worker process (tests/stress/_stress_worker.py) that runs script after script, so the
kernel is loaded once per session.  Every script gets `CASE_TIMEOUT` seconds; a script that does not finish
in time is a hang: the worker is killed (and restarted for the next script) and the test fails.

`check_run` asserts what every stress case must satisfy, whatever its rays do:
* the run ends with exit code 0 and no internal error, and its manifest says "complete";
* no NaN or inf anywhere: not in what it printed, not in the ledger, the SPECTRUM OF and EXPORT files
  (.csv, .npy, .fits), not in the ray records (SAVE RAYS), whose directions are unit vectors;
* the ledger closes: the sum of absorbed_W over all rows equals EMITTED's incident_W to 1e-12 relative (plus
  64 grains of 4.9e-324 W, which matters only for subnormal fluxes), and a run that emits nothing books
  exactly nothing anywhere;
* no object row is negative, and no flux is LOST to a numerical failure (unless the case allows it).
"""
from __future__ import annotations

import csv
import json
import math
import os
import queue
import re
import subprocess
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / "examples_scripts" / "data"
CASE_TIMEOUT = 120.0      # seconds for one warm script (generous: a loaded machine, big LEVEL runs)
WARMUP_TIMEOUT = 900.0    # the first script may compile the kernel (~40 s on an idle machine, more on a busy one)
TERMINAL_ROWS = ("EMITTED", "ESCAPED", "HALTED", "LOST", "IMPORTANCE")
NONFINITE = re.compile(r"(?<![\w.])[-+]?(nan|inf)(?!\w)", re.I)
# IEEE doubles below 2.2e-308 (subnormals) are multiples of 4.9e-324: each booking in the ledger rounds to that
# absolute grain, so for subnormal fluxes (FLUX TOTAL 1e-310 W) the ledger closes to a few dozen grains, not to
# 1e-12 relative; for every normal flux this floor is far below 1e-12 relative and changes nothing
SUBNORMAL_FLOOR = 64 * 5e-324


def fmt(x: float) -> str:
    """A number written so that the script reads back the same double."""
    return repr(float(x))


def outputs(*detectors: str, spectra: tuple = ()) -> str:
    """Script lines that write every kind of output: the ledger, the ray records, and for each detector its
    spectrum and its image (.npy and .fits)."""
    lines = ["STATS LEDGER 'ledger.csv'", "SAVE RAYS 'rays.h5'"]
    for d in detectors:
        lines += [f"SPECTRUM OF {d} 'spec_{d}.csv'", f"EXPORT {d} 'img_{d}.npy'", f"EXPORT {d} 'img_{d}.fits'"]
    for o in spectra:
        lines.append(f"SPECTRUM OF {o} 'spec_{o}.csv'")
    return "\n".join(lines) + "\n"


def ray(p, d) -> str:
    """One source of one ray (per wavelength line) starting exactly at p with direction d: a 1 x 1 GRID RECT
    whose ranges are the single point itself (its cell centre is x_min + (x_max - x_min) / 2 = x exactly)."""
    x, y, z = (fmt(v) for v in p)
    return f"GRID RECT Z {z} {x} {x} {y} {y} 1 1\nSOURCE DIRECTION {' '.join(fmt(v) for v in d)}\n"


def head(units: str = "MM", lines: str = "500 600 NM", seed: int = 3) -> str:
    return f"SYSTEM NEW\nUNITS {units}\nWAVELENGTHS {lines}\nSEED {seed}\n"


def records(r) -> dict:
    """The ray records the script saved with SAVE RAYS 'rays.h5': name -> array (history as object indices)."""
    import h5py

    with h5py.File(r.folder / "rays.h5", "r") as f:
        out = {k: f["rays"][k][()] for k in f["rays"]}
        out["objects"] = [o.decode() if isinstance(o, bytes) else str(o) for o in f["objects"][()]]
    return out


def hits_per_source(rec: dict, obj: str) -> np.ndarray:
    """How many times the path of each source ray met object `obj` (from the saved history, so at most the
    history's length), one entry per record; with one ray per source and line, records and rays coincide."""
    k = [o.upper() for o in rec["objects"]].index(obj.upper())
    return (rec["history"] == k).sum(axis=1)


@dataclass
class RunResult:
    name: str
    folder: Path
    finished: bool
    code: int | None = None
    stdout: str = ""
    stderr: str = ""
    seconds: float = 0.0
    timeout: float = CASE_TIMEOUT
    ledger: dict = field(default_factory=dict)

    def row(self, name: str) -> tuple:
        return self.ledger[name.upper()]


class Runner:
    """One `irt run` worker process, restarted after a hang."""

    def __init__(self):
        self.proc = None
        self.lines: queue.Queue | None = None
        self.warm = False

    def _start(self):
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(HERE.parents[1])] + [p for p in [env.get("PYTHONPATH")] if p])
        self.errlog = open(os.devnull, "w")
        self.proc = subprocess.Popen([sys.executable, str(HERE / "_stress_worker.py")], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.errlog, text=True, env=env,
                                     cwd=str(HERE.parents[1]))
        self.lines = queue.Queue()
        q, out = self.lines, self.proc.stdout

        def pump():
            for ln in out:
                q.put(ln)
            q.put(None)

        threading.Thread(target=pump, daemon=True).start()

    def stop(self):
        if self.proc is not None:
            if self.proc.poll() is None:
                self.proc.kill()    # only the worker this Runner started
            self.proc.wait()
            self.errlog.close()
            self.proc = None
        self.warm = False

    def _warm_up(self, folder: Path):
        """A fresh worker traces a trivial scene first, under WARMUP_TIMEOUT: that loads (or compiles) the
        kernel, so the case that follows gets its own CASE_TIMEOUT for itself."""
        self.stop()
        self._start()
        w = Path(folder) / "warmup"
        w.mkdir(parents=True, exist_ok=True)
        (w / "warmup.inr").write_text(head() + "SURFACE\n  PLANE Z 1 RECT 1 1\nOBJECT d\n"
                                      "GRID RECT Z 0 -1 1 -1 1 2 2\nSOURCE DIRECTION 0 0 1\nTRACE\n")
        self.proc.stdin.write(json.dumps({"script": str(w / "warmup.inr"), "out": str(w / "out")}) + "\n")
        self.proc.stdin.flush()
        try:
            ln = self.lines.get(timeout=WARMUP_TIMEOUT)
        except queue.Empty:
            ln = None
        if ln is None or json.loads(ln)["code"] != 0:
            self.stop()
            raise RuntimeError(f"the stress worker could not trace a trivial scene: {ln}")
        self.warm = True

    def run(self, folder: Path, text: str, name: str = "case", timeout: float | None = None) -> RunResult:
        """Write `text` to folder/name.inr and `irt run` it into folder/out; at most `timeout` seconds."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        script = folder / f"{name}.inr"
        script.write_text(text)
        out = folder / "out"
        if self.proc is None or self.proc.poll() is not None or not self.warm:
            self._warm_up(folder)
        limit = timeout if timeout is not None else CASE_TIMEOUT
        self.proc.stdin.write(json.dumps({"script": str(script), "out": str(out)}) + "\n")
        self.proc.stdin.flush()
        try:
            ln = self.lines.get(timeout=limit)
        except queue.Empty:
            self.stop()
            return RunResult(name, out, False, timeout=limit)
        if ln is None:      # the worker died (a crash in compiled code)
            code = self.proc.poll()
            self.stop()
            return RunResult(name, out, True, code=code, stderr=f"the worker process died (exit code {code})")
        self.warm = True
        a = json.loads(ln)
        return RunResult(name, out, True, a["code"], a["stdout"], a["stderr"], a["seconds"], limit)


def read_ledger(path: Path) -> dict:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["object", "incident_W", "reflected_W", "transmitted_W", "scattered_W", "absorbed_W"], rows[0]
    led = {}
    for r in rows[1:]:
        vals = tuple(float(v) for v in r[1:])
        led[r[0].upper()] = vals
    return led


def _check_csv(path: Path):
    text = path.read_text()
    assert not NONFINITE.search(text), f"{path.name} holds a non-finite value:\n{text[:2000]}"
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    for r in rows[1:]:
        for v in r:
            try:
                x = float(v)
            except ValueError:
                continue
            assert math.isfinite(x), (path.name, r)
    return rows


def _check_h5(path: Path, name: str):
    import h5py

    with h5py.File(path, "r") as f:
        def visit(n, o):
            if isinstance(o, h5py.Dataset) and o.dtype.kind in "fiu":
                a = o[()]
                assert np.all(np.isfinite(a)), f"{name}: {path.name}:{n} holds a non-finite value"
        f.visititems(visit)
        if "rays/direction" in f:
            d = f["rays/direction"][()]
            flux = f["rays/flux"][()]
            assert np.all(flux >= 0), f"{name}: a ray record carries negative flux"
            if len(d):
                norm = np.linalg.norm(d, axis=1)
                assert np.all(np.abs(norm - 1.0) < 1e-12), \
                    f"{name}: ray record directions are not unit vectors: {norm[np.abs(norm - 1) >= 1e-12][:5]}"


def _check_fits(path: Path, name: str):
    try:
        from astropy.io import fits
    except ImportError:   # pragma: no cover - astropy is a test extra
        return
    with fits.open(path) as hdul:
        for h in hdul:
            if h.data is not None and getattr(h.data, "dtype", None) is not None and h.data.dtype.kind == "f":
                assert np.all(np.isfinite(h.data)), f"{name}: {path.name} holds a non-finite value"


def check_run(r: RunResult, *, lost_ok: bool = False, closes: bool = True) -> RunResult:
    """Every invariant of a stress case (see the module docstring); returns r with r.ledger filled in."""
    assert r.finished, f"{r.name}: no answer within {r.timeout:.0f} s (a hang)"
    assert r.code == 0, f"{r.name}: exit code {r.code}\n{r.stderr[-4000:]}\n{r.stdout[-2000:]}"
    assert "internal error" not in r.stderr and "Traceback" not in r.stderr, r.stderr[-4000:]
    assert "RuntimeWarning" not in r.stderr, f"{r.name}: {r.stderr[-4000:]}"
    m = NONFINITE.search(r.stdout)
    assert not m, f"{r.name}: printed a non-finite value ({m.group(0)!r}):\n{r.stdout[-4000:]}"
    man = json.loads((r.folder / "manifest.json").read_text())
    assert man["status"] == "complete", man["status"]
    names = {f["path"] for f in man["files"]}
    assert "ledger.csv" in names, f"{r.name}: the script must write STATS LEDGER 'ledger.csv'"
    for f in man["files"]:
        p = r.folder / f["path"]
        ext = p.suffix.lower()
        if ext == ".csv":
            _check_csv(p)
        elif ext == ".npy":
            a = np.load(p)
            assert np.all(np.isfinite(a)), f"{r.name}: {p.name} holds a non-finite value"
            assert np.all(a >= 0), f"{r.name}: {p.name} holds negative flux"
        elif ext in (".h5", ".hdf5"):
            _check_h5(p, r.name)
        elif ext in (".fits", ".fit"):
            _check_fits(p, r.name)
    led = read_ledger(r.folder / "ledger.csv")
    r.ledger = led
    for k, v in led.items():
        assert all(math.isfinite(x) for x in v), (k, v)
        if k not in TERMINAL_ROWS and not k.startswith("MEDIUM "):
            tol = 1e-12 * max(abs(x) for x in v) + SUBNORMAL_FLOOR     # absorbed = w - (what went on)
            assert all(x >= -tol for x in v), f"{r.name}: negative ledger entry in row {k}: {v}"
    assert led["ESCAPED"][4] >= 0 and led["LOST"][4] >= 0
    if not lost_ok:
        assert led["LOST"][4] == 0, f"{r.name}: {led['LOST'][4]} W LOST to numerical failures\n{r.stderr[-2000:]}"
    if closes:
        emitted = led["EMITTED"][0]
        total = math.fsum(v[4] for v in led.values())
        if emitted == 0.0:
            assert all(x == 0.0 for v in led.values() for x in v), f"{r.name}: flux booked from nothing: {led}"
        else:
            assert abs(total - emitted) <= 1e-12 * emitted + SUBNORMAL_FLOOR, \
                f"{r.name}: ledger does not close: absorbed {total!r} vs EMITTED {emitted!r} ({led})"
    return r
