"""Import directions (docs/architecture.md, "The import rule"): every module of irtlang belongs to one layer of
LAYERS and imports only modules of its own layer or of layers listed before it; no module imports the
``analysis`` package; the module import graph (imports at module level and inside functions alike, and the
plugin registries' imports by name) has no cycles.  Imports by computed name are allowed only in the few places
listed in DYNAMIC, each of which this test follows.

The test reads the sources with ``ast``: it imports nothing, so it also catches an import that a run would only
reach on a rare path.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# lowest first: a module may import its own layer and the layers above it in this list
LAYERS = [
    ("core", ["irtlang", "irtlang._version", "irtlang.core", "irtlang.data", "irtlang.limits", "irtlang.library"]),
    ("language front end", ["irtlang.lang", "irtlang.lang.ast", "irtlang.lang.parser", "irtlang.lang.expr",
                            "irtlang.lang.spec", "irtlang.lang.diagnostics", "irtlang.lang.units"]),
    ("scene model", ["irtlang.model"]),
    ("kernel math", ["irtlang.kernels", "irtlang.kernels.rng", "irtlang.kernels.sampling", "irtlang.kernels.optics",
                     "irtlang.kernels.geometry", "irtlang.kernels.bvh", "irtlang.kernels.layout"]),
    ("file formats", ["irtlang.io"]),
    ("plugins", ["irtlang.plugins"]),
    ("earth", ["irtlang.earth"]),
    ("interpreter", ["irtlang.lang.state", "irtlang.lang.commands", "irtlang.lang.interp", "irtlang.lang.fmt"]),
    ("trace kernel", ["irtlang.kernels.trace_kernel"]),
    ("compile", ["irtlang.compile"]),
    ("tracer", ["irtlang.tracer"]),
    ("optics", ["irtlang.optics"]),
    ("engine", ["irtlang.engine"]),
    ("drivers", ["irtlang.progress", "irtlang.ahead", "irtlang.api", "irtlang.cluster", "irtlang.repl",
                 "irtlang.cli"]),
    ("analysis", ["analysis"]),
]

# the only calls that import by a computed name, and what they import
DYNAMIC = {
    "irtlang.plugins": "load_registry: the plugin registries (followed: each registry imports its listed modules)",
    "irtlang.core.hooks": "analysis_provider: the one late-stage hook (ANALYZE, irt analyze) -> analysis.cli",
    "irtlang.compile.specialize": "kernel_module: loads a generated copy of irtlang.kernels.trace_kernel",
}
DYNAMIC_EDGES = {"irtlang.compile.specialize": ["irtlang.kernels.trace_kernel"]}   # followed by hand
LATE_HOOK = ("irtlang.core.hooks", "analysis.cli")
# the package's face: `irtlang.run` / `irtlang.check` are the Python API, imported on first attribute access
# (module __getattr__), never at import time; this one edge is exempt from the order and the cycle check
FACADE = ("irtlang", "irtlang.api")
_DYNAMIC_CALLS = {"import_module", "__import__", "spec_from_file_location", "load_registry"}


def _modules() -> dict[str, Path]:
    mods = {}
    for pkg in ("irtlang", "analysis"):
        for p in sorted((ROOT / pkg).rglob("*.py")):
            parts = p.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join(parts)] = p
    return mods


MODS = _modules()


def _layer(mod: str) -> int:
    best, best_len = None, -1
    for i, (_, prefixes) in enumerate(LAYERS):
        for pre in prefixes:
            if (mod == pre or mod.startswith(pre + ".")) and len(pre) > best_len:
                best, best_len = i, len(pre)
    if best is None:
        raise AssertionError(f"module {mod} is in no layer of tests/unit/test_import_layers.py LAYERS: add it "
                             f"there and to docs/architecture.md")
    return best


def _imports(mod: str, path: Path):
    """(target module, line, how) for each import of `mod`; targets limited to irtlang and analysis."""
    tree = ast.parse(path.read_text(), str(path))
    is_pkg = path.name == "__init__.py"
    pkg = mod if is_pkg else mod.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = pkg.split(".")
                parts = parts[:len(parts) - node.level + 1]
                base = ".".join(parts) + ("." + base if base else "")
            targets = [base] + [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in MODS]
        elif isinstance(node, ast.Call):
            name = getattr(node.func, "attr", None) or getattr(node.func, "id", None)
            arg = node.args[0] if node.args else None
            third_party = (isinstance(arg, ast.Constant) and isinstance(arg.value, str)
                           and arg.value.split(".")[0] not in ("irtlang", "analysis"))
            if name == "load_registry":
                # a plugin registry: load_registry(__name__, ["plane", ...]) imports each listed module
                assert len(node.args) == 2 and isinstance(node.args[1], ast.List), \
                    f"{path}:{node.lineno}: load_registry needs a literal list of module names"
                targets = [f"{mod}.{e.value}" for e in node.args[1].elts]
                for t in targets:
                    assert t in MODS, f"{path}:{node.lineno}: registry names a missing module {t}"
            elif name in _DYNAMIC_CALLS and not third_party and mod.split(".")[0] == "irtlang" and mod not in DYNAMIC:
                raise AssertionError(f"{path}:{node.lineno}: {name}(...) imports by a computed name outside "
                                     f"the allowed places {sorted(DYNAMIC)}")
        for t in targets:
            if t.split(".")[0] in ("irtlang", "analysis") and t != mod and (mod, t) != FACADE:
                out.append((t, node.lineno))
    for t in DYNAMIC_EDGES.get(mod, ()):
        out.append((t, 0))
    return out


GRAPH = {m: _imports(m, p) for m, p in MODS.items()}


def test_every_module_has_a_layer():
    for m in MODS:
        _layer(m)


def test_imports_follow_the_layer_order():
    bad = []
    for m, edges in GRAPH.items():
        lm = _layer(m)
        for t, line in edges:
            lt = _layer(t)
            if lt > lm:
                bad.append(f"{MODS[m].relative_to(ROOT)}:{line}: {m} ({LAYERS[lm][0]}) imports {t} "
                           f"({LAYERS[lt][0]}, a later layer)")
    assert not bad, "imports against the layer order (docs/architecture.md):\n" + "\n".join(bad)


def test_irtlang_never_imports_analysis():
    bad = [f"{MODS[m].relative_to(ROOT)}:{line}: {m} imports {t}" for m, edges in GRAPH.items()
           if m.split(".")[0] == "irtlang" for t, line in edges if t.split(".")[0] == "analysis"]
    assert not bad, "\n".join(bad)


def test_the_late_stage_hook_is_the_only_one():
    from irtlang.core import hooks

    assert (hooks.__name__, hooks.ANALYSIS_PROVIDER) == LATE_HOOK
    names = [m for m, p in MODS.items() if m.startswith("irtlang") and '"analysis.' in p.read_text()]
    assert names == ["irtlang.core.hooks"], names


def test_no_import_cycles():
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t, _ in GRAPH.get(m, ()):
            if t not in MODS:
                continue
            if state.get(t) == 1:
                cycles.append(" -> ".join(stack[stack.index(t):] + [t]))
            elif t not in state:
                visit(t)
        stack.pop()
        state[m] = 2

    for m in sorted(MODS):
        if m not in state:
            visit(m)
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


@pytest.mark.parametrize("old,new", [("irtlang.lang.diagnostics", "irtlang.core.diagnostics"),
                                     ("irtlang.lang.units", "irtlang.core.units"),
                                     ("analysis.rayfile", "irtlang.io.rayfile"),
                                     ("analysis.psf", "irtlang.optics.psf_measures")])
def test_moved_modules_keep_their_old_names(old, new):
    import importlib

    a, b = importlib.import_module(old), importlib.import_module(new)
    public = [n for n in getattr(b, "__all__", dir(b)) if not n.startswith("_")]
    assert public
    for n in public:
        if not isinstance(getattr(b, n), type(importlib)):
            assert getattr(a, n) is getattr(b, n), (old, n)


def test_analysis_error_is_one_class():
    import analysis
    from irtlang.core.checks import AnalysisError

    assert analysis.AnalysisError is AnalysisError
