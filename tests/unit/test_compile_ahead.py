"""Compiling ahead (irtlang/ahead.py, irtlang.kernels.reduce.warm, docs/architecture.md "Compile time"): the
kernels a run will use are planned from its checked program, compiled by a background process unless cached or
locked, and the reduction is compiled with the tracer's own argument types.

These are tests of bookkeeping, not of physics: the plan is compared with the kernels a real run packs (the
engine's own choice, recorded), and the helper process's choices with the cache and the locks it is given.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CASS = ROOT / "examples_scripts" / "camera_cassegrain.inr"

# a forward trace whose rays are saved (records and history), a guided camera-side trace, and a forward trace
# of fewer objects after CONSIDER: three traces, the kernels of the three kinds of step
SCRIPT = f"""
mode = 'forward'
sun_rays = 2000
INCLUDE '{CASS}'
SAVE RAYS 'rays.h5' AT fpa
mode = 'camera'
camera_rays = 1
guide_cells = 4
INCLUDE '{CASS}'
mode = 'forward'
CONSIDER ONLY ball primary secondary fpa
INCLUDE '{CASS}'
"""


def _used_keys(monkeypatch, path: Path, out: Path) -> list:
    """The feature keys of every kernel a run of `path` asks for (tracer.kernel_module's argument)."""
    import irtlang
    from irtlang import tracer

    seen = []
    real = tracer.kernel_module

    def spy(features):
        seen.append(features.key())
        return real(features)

    monkeypatch.setattr(tracer, "kernel_module", spy)
    res = irtlang.run(path, out=out)
    assert res.status == "complete", res.status
    return seen


def test_the_plan_names_the_kernels_the_run_uses(tmp_path, monkeypatch):
    from irtlang.ahead import plan
    from irtlang.api import Script, load_check
    from irtlang.compile.pack import pack

    path = tmp_path / "three.inr"
    path.write_text(SCRIPT)
    checked = load_check(Script(path))
    planned = [pack(sc, records=r, history=h).features.key() for sc, r, h, _lv in plan(checked.steps)]
    used = _used_keys(monkeypatch, path, tmp_path / "out")
    assert len(set(used)) >= 2          # the forward trace with records and the camera trace differ
    assert set(planned) == set(used), (planned, used)
    # in the run's order: the first kernel the run needs comes first
    assert planned[0] == used[0]


# a forward trace that keeps records and history (STATS PATHS), then the two commands that trace its source
# again: PST (records off) and SPOTS DIAGRAM ... FIELDS (records on)
RETRACES = """MODEL black LAMBERTIAN 0.1
SURFACE
  TUBE Z 0 10 100 10
OBJECT tube
  SCATTER MODEL black TOWARD det
SURFACE
  PLANE Z 0 RECT 5 5
OBJECT det
  DETECTOR PIXELS 4
LEVEL 3
GRID DISK Z 100 10 RAYS 2000 RANDOM
SOURCE FIELD 20 0
TRACE
STATS PATHS 'paths.csv' TOP 4
PST 'pst.csv' ON det ANGLES 10 30 2
SPOTS DIAGRAM 'spots.png' FIELDS 1 1 deg
"""


def test_retraces_run_on_the_kernel_of_the_trace_they_repeat(tmp_path, monkeypatch):
    """PST and SPOTS DIAGRAM ... FIELDS trace the last TRACE's source again with other records: they run on its
    kernel (pack's floor), so a first run compiles no kernel for them, and the plan (which does not list them)
    misses none.  Without the floor PST asked for a kernel of its own (records off): a second cold compile."""
    from irtlang.ahead import plan
    from irtlang.api import Script, load_check
    from irtlang.compile.pack import pack

    path = tmp_path / "retraces.inr"
    path.write_text(RETRACES)
    checked = load_check(Script(path))
    planned = [pack(sc, records=r, history=h).features.key() for sc, r, h, _lv in plan(checked.steps)]
    used = _used_keys(monkeypatch, path, tmp_path / "out")
    assert len(used) == 1 + 2 + 9          # the TRACE, two PST angles, the 3 x 3 field grid
    assert set(used) == set(planned) and len(planned) == 1, (planned, used)


def test_the_helper_skips_what_is_cached_or_locked_and_compiles_the_rest(tmp_path, monkeypatch):
    """compile_planned with the compile itself replaced by a recorder: the kernel another process holds the
    lock of is left to it, a cached one is left alone, the others are compiled once each, in plan order."""
    from irtlang import ahead, tracer
    from irtlang.compile import specialize

    monkeypatch.setenv("IRT_KERNEL_FEATURES", "")       # the specialized kernels (module files only: no compile)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "nc"))
    path = tmp_path / "three.inr"
    path.write_text(SCRIPT)
    compiled = []
    monkeypatch.setattr(tracer.TraceContext, "run_batch",
                        lambda self, first, n, reuse=False, _compiled=False: compiled.append(self.pk.features.key()))
    monkeypatch.setattr(specialize, "kernel_cached", lambda mod: False)
    monkeypatch.setattr(specialize, "_loaded", {})
    keys = list(dict.fromkeys(_plan_keys(path)))
    assert len(keys) >= 2
    # another process compiles the first (holds its lock): the helper leaves it and compiles the rest
    first = specialize.kernel_module(_features(path, keys[0]))
    with specialize.kernel_lock(first) as held:
        assert held
        done = ahead.compile_planned(path)
    assert done == keys[1:] and compiled == keys[1:]
    # all cached: nothing to do
    compiled.clear()
    monkeypatch.setattr(specialize, "kernel_cached", lambda mod: True)
    assert ahead.compile_planned(path) == [] and compiled == []


def _plan_keys(path):
    from irtlang.ahead import plan
    from irtlang.api import Script, load_check
    from irtlang.compile.pack import pack

    return [pack(sc, records=r, history=h).features.key() for sc, r, h, _ in plan(load_check(Script(path)).steps)]


def _features(path, key):
    from irtlang.ahead import plan
    from irtlang.api import Script, load_check
    from irtlang.compile.pack import pack

    for sc, r, h, _ in plan(load_check(Script(path)).steps):
        f = pack(sc, records=r, history=h).features
        if f.key() == key:
            return f
    raise AssertionError(key)


def test_a_run_starts_the_helper_at_its_first_cold_compile_and_stops_it_at_its_end(tmp_path, monkeypatch):
    import irtlang
    from irtlang import ahead, tracer

    class Proc:
        stopped = False

        def poll(self):
            return None

        def terminate(self):
            Proc.stopped = True

        def wait(self, timeout=None):
            return 0

    calls = []
    monkeypatch.setattr(ahead, "start", lambda *a, **kw: calls.append(a + (kw,)) or Proc())
    monkeypatch.setattr(tracer, "kernel_cached", lambda mod: False)
    monkeypatch.setattr(tracer.TraceContext, "compile", _compile_without_ready_flag)
    path = tmp_path / "three.inr"
    path.write_text(SCRIPT)
    monkeypatch.setenv("IRT_LIMITS", "rays=2e12")
    res = irtlang.run(path, out=tmp_path / "out", set={"sun_rays": 500})
    assert res.status == "complete"
    assert len(calls) == 1                      # once per run, however many kernels it compiles
    assert calls[0][0] == path and "sun_rays=500" in calls[0][1]
    from irtlang.limits import Limits          # and the run's limits, which the helper's check parses back
    assert Limits.from_env(calls[0][-1]["limits"], environ={}).values["rays"] == 2e12
    assert Proc.stopped                         # a helper still running at the end is stopped
    assert tracer.COMPILE_AHEAD == []           # and the hook is gone


def _compile_without_ready_flag(self):
    """TraceContext.compile as it is, but asking every time (the all-features kernel is shared by the scenes
    of the test process, so its ready flag would hide the second kernel)."""
    from irtlang import tracer

    if tracer.COMPILE_AHEAD and not tracer.kernel_cached(self.mod):
        hooks = list(tracer.COMPILE_AHEAD)
        tracer.COMPILE_AHEAD.clear()
        for h in hooks:
            h()
    with tracer.kernel_lock(self.mod):
        self.run_batch(0, 0, _compiled=True)


def test_the_reduction_warms_with_the_tracers_own_signature(tmp_path):
    """reduce.warm() must compile the one signature Accumulator.add calls (else the background compile is
    wasted and the run compiles it again)."""
    import irtlang
    from irtlang.kernels import reduce

    irtlang.run(CASS, out=tmp_path / "out", set={"camera_rays": 1})
    sigs = list(reduce.reduce_batch.signatures)
    assert len(sigs) == 1
    reduce.warm()
    assert list(reduce.reduce_batch.signatures) == sigs


def test_the_background_reduction_compile_fills_an_empty_cache(tmp_path):
    """python -m irtlang.kernels.reduce, as tracer._reduce_ahead starts it: from an empty cache it compiles
    reduce_batch, after which another process loads it (one cache hit, no compile)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "nc"), PYTHONPATH=str(ROOT))
    code = "from irtlang.kernels import reduce; print(reduce.cached())"
    assert subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          check=True).stdout.strip() == "False"
    subprocess.run([sys.executable, "-m", "irtlang.kernels.reduce"], env=env, check=True, timeout=600)
    code = ("from irtlang.kernels import reduce; print(reduce.cached()); reduce.warm(); "
            "s = reduce.reduce_batch.stats; print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "1", "0"], out.stdout + out.stderr


@pytest.mark.parametrize("flag", ["0"])
def test_compile_ahead_can_be_switched_off(monkeypatch, flag, tmp_path):
    from irtlang import ahead

    monkeypatch.setenv("IRT_COMPILE_AHEAD", flag)
    assert ahead.start(tmp_path / "x.inr") is None


def test_irt_warmup_compiles_what_is_missing_and_reports_each_kernel(tmp_path, monkeypatch, capsys):
    """`irt warmup` in one process (--jobs 1), the compile replaced by a recorder that marks the kernel cached:
    every planned kernel compiled once, the report lists each as cached, exit 0; bad input exits 2."""
    from irtlang import cli, tracer
    from irtlang.compile import specialize

    monkeypatch.setenv("IRT_KERNEL_FEATURES", "")
    monkeypatch.setattr(specialize, "_loaded", {})
    cached = set()
    compiled = []

    def fake_run_batch(self, first, n, reuse=False, _compiled=False):
        compiled.append(self.pk.features.key())
        cached.add(self.mod.__name__)

    monkeypatch.setattr(tracer.TraceContext, "run_batch", fake_run_batch)
    monkeypatch.setattr(specialize, "kernel_cached", lambda mod: mod.__name__ in cached)
    path = tmp_path / "three.inr"
    path.write_text(SCRIPT)
    assert cli.main(["warmup", str(path), "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    keys = list(dict.fromkeys(_plan_keys(path)))
    assert compiled == keys
    assert f"compiling {len(keys)} of {len(keys)} trace kernels for {path}, 1 at once" in out.splitlines()[0]
    assert f"{len(keys)} trace kernels for {path}: 0 already compiled, {len(keys)} compiled now" in out
    assert all(f"  {k}: cached" in out for k in keys)
    # again: nothing to compile
    compiled.clear()
    assert cli.main(["warmup", str(path), "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert compiled == [] and f"{len(keys)} already compiled, 0 compiled now" in out and "compiling" not in out
    # a script with an error: its diagnostics, exit 2, nothing compiled
    bad = tmp_path / "bad.inr"
    bad.write_text("TRACE\n")
    assert cli.main(["warmup", str(bad)]) == 2
    assert "bad.inr:1:1: error" in capsys.readouterr().err and compiled == []
    assert cli.main(["warmup", str(path), "--jobs", "0"]) == 2


def test_the_kernels_source_hash_leaves_out_the_reduction():
    """A generated kernel's name hashes the sources it depends on; reduce.py and spline.py (the PSF's spline) are
    not among them (an edit there need not recompile every trace kernel), the template and its imports are."""
    from irtlang.compile.specialize import kernel_sources

    names = {(p.parent.name, p.name) for p in kernel_sources()}
    assert ("kernels", "reduce.py") not in names and ("kernels", "spline.py") not in names
    for must in [("kernels", "trace_kernel.py"), ("kernels", "geometry.py"), ("kernels", "rng.py"),
                 ("kernels", "layout.py"), ("bsdfs", "lambertian.py"), ("surfaces", "__init__.py"),
                 ("sources", "__init__.py")]:
        assert must in names, must
    # what trace_kernel imports from kernels/ is all in the hash
    import ast

    src = next(p for p in kernel_sources() if p.name == "trace_kernel.py").read_text()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
            assert ("kernels", node.module + ".py") in names, node.module


def test_the_helper_checks_with_the_runs_limits(tmp_path, monkeypatch):
    """`irt warmup --limit` reaches its helper processes: their check uses the same limits (a limit the script
    exceeds stops the helper's check, as it stops the run's)."""
    from irtlang import ahead
    from irtlang.core import background
    from irtlang.core.diagnostics import IrtError

    seen = []
    monkeypatch.setattr(background, "start_python", lambda module, args=(), force=False: seen.append(list(args)))
    path = tmp_path / "three.inr"
    path.write_text(SCRIPT)
    ahead.start(path, ["sun_rays=10"], False, force=True, limits=["rays=1e12", "memory=2G"])
    assert seen == [[str(path), "--set", "sun_rays=10", "--limit", "rays=1e12", "--limit", "memory=2G"]]
    with pytest.raises(IrtError, match="rays"):
        ahead.compile_planned(path, limits=["rays=100"])


def test_a_run_that_compiles_says_so_where_progress_is_shown(tmp_path, monkeypatch):
    """The progress display (irt run on a terminal, or --progress) says that the tracer is compiling before a
    trace whose kernel the cache lacks, and says nothing once it is compiled."""
    import io

    from irtlang import tracer
    from irtlang.api import Script, execute
    from irtlang.compile import specialize
    from irtlang.progress import RunProgress

    def run(out):
        stream = io.StringIO()
        execute(Script(CASS), presets=["camera_rays=1"], out=tmp_path / out,
                progress=RunProgress(enabled=True, stream=stream), echo=lambda s: None)
        return stream.getvalue()

    run("warm")                                         # compiled (or loaded) once in this process
    assert tracer.COMPILING not in run("again")
    monkeypatch.setattr(tracer, "kernel_cached", lambda mod: False)
    for m in list(specialize._loaded.values()):
        monkeypatch.setattr(m, "_irt_ready", False, raising=False)
    from irtlang import ahead

    monkeypatch.setattr(ahead, "start", lambda *a, **kw: None)     # (no helper process from this test)
    assert tracer.COMPILING in run("cold")
