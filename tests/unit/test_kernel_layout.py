"""The kernel boundary (irtlang/kernels/layout.py): one definition of the packed scene's columns, codes and
structures, used by packing and kernel alike.  Structural guards (no physics):

* the kernel entry takes at most 12 arguments, the layout's structures, and reads every field of each;
* the packer's surface table puts each packed array at the layout's columns;
* no kernel code writes into an array reached through a structure: Numba 0.6x silently drops such writes inside
  a parallel loop (``T.n[c] = x`` or ``a, n = T; n[c] = x`` in the prange: the array keeps its old values), so
  trace_batch takes its output arrays out of the structures before the loop and helpers write only into arrays
  passed to them; calls pass at most 30 arguments (Python passes more as *args, which Numba cannot inline).
  trace_batch binds every structure's fields to locals before its parallel loop, so the loop takes plain arrays:
  a parallel loop over namedtuple arguments ran 20 % slower (the telescope benchmark);
* no kernel or plugin code binds a structure's array to a local name (``par = SRC.par``): the local holds a
  reference that Numba counts with an atomic increment and decrement, and when the local lives across branches
  LLVM's reference-count pruning cannot remove the pair, so it ran on every ray.  _gen's fourteen such locals
  (and the GRID plugins' ``par``, ``pts``) made the telescope trace 7-23 % slower on two threads (the count's
  cache line bounces between the cores); read the field in place (``SRC.par[s, 0]``), whose temporary lives in
  one block and is pruned.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np

from irtlang.kernels import layout

KERNEL = Path(__file__).resolve().parents[2] / "irtlang" / "kernels" / "trace_kernel.py"
STRUCTS = {"settings": layout.Settings, "S": layout.Surfaces, "O": layout.Objects, "SC": layout.Scatter,
           "MD": layout.Media, "D": layout.Detectors, "SRC": layout.Sources, "T": layout.Tallies,
           "REC": layout.Records}


def _tree():
    return ast.parse(KERNEL.read_text())


def test_entry_takes_the_layout_structures():
    fn = next(f for f in _tree().body if isinstance(f, ast.FunctionDef) and f.name == "trace_batch")
    names = [a.arg for a in fn.args.args]
    assert len(names) <= 12
    assert names == list(STRUCTS)
    # every field of every structure is read somewhere in the kernel (by attribute); the surface table's BVH
    # fields by the surface plugins (their hit and normal get the table S)
    trees = [_tree()] + [ast.parse(p.read_text()) for p in (KERNEL.parents[1] / "plugins" / "surfaces").glob("*.py")]
    read = {(n.value.id, n.attr) for tr in trees for n in ast.walk(tr) if isinstance(n, ast.Attribute)
            and isinstance(n.value, ast.Name)}
    for var, cls in STRUCTS.items():
        unread = [f for f in cls._fields if (var, f) not in read]
        assert not unread, f"{cls.__name__} fields never read by the kernel: {unread}"


def test_no_writes_through_a_structure_and_short_calls():
    src = KERNEL.read_text()
    pat = re.compile(r"\b(?:%s)\.\w+\[[^\]\n]*\]\s*(?:[-+*/|]?=)(?!=)" % "|".join(STRUCTS))
    bad = [m.group(0) for m in pat.finditer(src)]
    assert not bad, f"writes through a structure (lost in a parallel loop): {bad}"
    for n in ast.walk(_tree()):
        if isinstance(n, ast.Call):
            assert len(n.args) <= 30, f"line {n.lineno}: a call with {len(n.args)} arguments"
        if isinstance(n, ast.FunctionDef):
            assert len(n.args.args) <= 30, f"{n.name} takes {len(n.args.args)} arguments"
        if isinstance(n, ast.Assign) and isinstance(n.targets[0], ast.Tuple) and isinstance(n.value, ast.Name):
            assert n.value.id not in STRUCTS, \
                f"line {n.lineno}: a structure unpacked as a tuple (its arrays' writes would be lost)"


def test_no_structure_field_bound_to_a_local():
    plugins = KERNEL.parents[1] / "plugins"
    files = sorted(KERNEL.parent.glob("*.py")) + sorted(plugins.glob("*/*.py"))
    bad = []
    for p in files:
        for fn in ast.walk(ast.parse(p.read_text())):
            if not isinstance(fn, ast.FunctionDef) or fn.name == "trace_batch":
                continue    # (trace_batch binds the fields once per batch, before its parallel loop: on purpose)
            structs = {a.arg for a in fn.args.args} & set(STRUCTS)     # the structures this function is given
            for n in ast.walk(fn):
                if (isinstance(n, ast.Assign) and isinstance(n.value, ast.Attribute)
                        and isinstance(n.value.value, ast.Name) and n.value.value.id in structs):
                    bad.append(f"{p.name}:{n.lineno}: {ast.unparse(n)}")
    assert not bad, "a structure's array bound to a local (an atomic reference count per use; read it in " \
                    f"place): {bad}"


def test_surface_table_columns(tmp_path):
    from irtlang.compile.pack import pack
    from irtlang.lang.diagnostics import Source
    from irtlang.lang.interp import Interpreter

    text = ("WAVELENGTHS 500 NM\nSURFACE\n  CONIC Z 5 RADIUS -400 CONIC -1.2 ASPHERE 1e-9 2e-14 ANNULUS 10 40\n"
            "OBJECT m\n  INTERFACE REFLECT\nSURFACE\n  SPHERE 1 2 3 7\nOBJECT b\n  INTERFACE REFLECT\n"
            "SURFACE\n  PLANE Z 50 ANNULUS 5 20\nOBJECT w\n  INTERFACE REFLECT\n"
            "GRID DISK Z 100 1 RAYS 10\nSOURCE DIRECTION 0 0 -1\nTRACE\n")
    it = Interpreter(check_only=True)
    it.run_source(Source(str(tmp_path / "t.inr"), text))
    assert not it.diags, it.diags.items
    pk = pack([s for s in it.steps if s.kind == "TRACE"][0].scene)
    f, si, _ = pk.surface_tables()
    L = layout
    assert f.shape[1] == L.SF_N and si.shape[1] == L.SI_N
    for col, arr, w in ((L.SF_PAR, pk.s_par, L.N_PAR), (L.SF_ASPH, pk.s_asph, L.N_ASPH), (L.SF_AP, pk.s_ap, 2),
                        (L.SF_R, pk.s_R, 9), (L.SF_TH, pk.s_Th, 3), (L.SF_TL, pk.s_Tl, 3), (L.SF_BS, pk.s_bs, 4)):
        assert np.array_equal(f[:, col:col + w], np.asarray(arr).reshape(len(f), w))
    assert np.array_equal(f[:, L.SF_SIZE], pk.s_size)
    for col, arr in ((L.SI_KIND, pk.s_kind), (L.SI_NASPH, pk.s_nasph), (L.SI_APK, pk.s_ap_kind),
                     (L.SI_MESH, pk.s_mesh), (L.SI_OBJ, pk.s_obj)):
        assert np.array_equal(si[:, col], arr)
    assert si[0, L.SI_NASPH] == 2 and si[0, L.SI_APK] == L.AP_ANNULUS
    # the central-hole cull: a plane's annulus has one, an aspheric conic's not (its sag is not monotonic)
    assert f[2, L.SF_HOLE] > 0 and f[0, L.SF_HOLE] == 0
