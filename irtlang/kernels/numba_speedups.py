"""Faster versions of three of Numba's compile passes, for the trace kernel's first compile.

Measured on the telescope scene's kernel (2 cores, empty cache; docs/architecture.md, "Compile time"), a
cold compile spends most of its time in Numba's own Python passes, not in LLVM, and three of them grow
faster than the code they compile:

* ``ir_utils.copy_propagate`` (run on every parallel loop's body and by ``simplify``) compares its fixed
  point by ``copy.deepcopy`` of the whole dict of copy sets on every iteration, and its initial kill sets
  rebuild each block's assigned names once per copy in the function.  The same equations over Python
  integers used as bit sets (one bit per copy, the kill sets from one mask per variable name) give the same
  sets; they are turned back into sets of (lhs, rhs) once, at the end.  (Until 2026-12-05 the replacement
  kept Python sets, copied instead of deep-copied: the Earth's camera kernel compiled in 66 s with it, 60 s
  with bit sets, where the fixed point had been about a fifth of the compile.)
* ``analysis.compute_live_map`` (every dead-code removal) iterates two fixed points over Python sets of
  variable names, one set per block, each as large as the function's variables.  The same equations over
  Python integers used as bit sets (one bit per variable) give the same sets, much faster.
* ``InlineWorker.inline_ir`` (every ``inline="always"`` call) deep-copies the callee's IR block by block
  with a fresh memo per block, so the callee's whole scope (every variable of the function, after its own
  inlining: thousands) is copied once per block.  One memo per copy copies it once: the copy's blocks share
  one scope, as the original IR's blocks do.

The replacements compute the same thing as the originals (tests/unit/test_numba_speedups.py checks copy
propagation and liveness against Numba's own on the kernel's IR, and a parallel loop of inlined helpers
compiled with all three against plain Python; the kernels compile to bit-identical results), and they are
installed only over the exact source they were checked against (a hash of each original function): another
Numba version, or one installed without its sources, keeps its own passes, correct and slower.  ``IRT_NUMBA_SPEEDUPS=0`` leaves Numba
untouched.  They change how long a compile takes, never what it produces.
"""
from __future__ import annotations

import hashlib
import inspect
import os
import textwrap

#: sha256 (first 16 hex digits) of the original functions' source these replacements were checked against
#: (Numba 0.68.1)
KNOWN = {"copy_propagate": "b607f90ff29db1ce", "init_copy_propagate_data": "5cf4a6ab79e0dee0",
         "InlineWorker.inline_ir": "26fd2b7600c9d929", "compute_live_map": "713c4c094977e93b"}

installed: list[str] = []     # what install() replaced (empty: Numba as it is)
_ORIGINAL: dict = {}


def _hash(fn) -> str:
    try:
        return hashlib.sha256(inspect.getsource(fn).encode()).hexdigest()[:16]
    except (OSError, TypeError):      # no source to check: leave Numba as it is
        return ""


def copy_propagate(blocks, typemap):
    """Numba's ``copy_propagate`` (fixed point of in_b = intersect(out of predecessors), out_b = gen_b |
    (in_b - kill_b), iterated over the blocks in order until a pass changes nothing), computed on bit sets: one
    bit per copy (lhs, rhs) of the function, a Python integer per block.  The kill sets are init_copy_propagate_data's
    (a copy is killed in a block where its lhs or rhs is in extra_kill, or is assigned there by another copy),
    built from one mask per variable name.  Returns the same dicts of sets of (lhs, rhs)."""
    from numba.core import ir_utils
    from numba.core.analysis import compute_cfg_from_blocks

    cfg = compute_cfg_from_blocks(blocks)
    entry = cfg.entry_point()
    gen_copies, extra_kill = ir_utils.get_block_copies(blocks, typemap)
    copies = []
    index = {}
    for label in gen_copies:
        for c in gen_copies[label]:
            if c not in index:
                index[c] = len(copies)
                copies.append(c)
    masks = {}      # variable name -> the copies it takes part in
    for k, (lhs, rhs) in enumerate(copies):
        b = 1 << k
        masks[lhs] = masks.get(lhs, 0) | b
        if rhs != lhs:
            masks[rhs] = masks.get(rhs, 0) | b
    gen = {}
    kill = {}
    for label, gen_set in gen_copies.items():
        g = 0
        for c in gen_set:
            g |= 1 << index[c]
        ek = 0
        for v in extra_kill[label]:
            ek |= masks.get(v, 0)
        assigned = 0
        for lhs in {lhs for lhs, _rhs in gen_set}:
            assigned |= masks.get(lhs, 0)
        gen[label] = g
        kill[label] = ek | (assigned & ~g)
    full = (1 << len(copies)) - 1
    in_b = {label: full for label in blocks}
    in_b[entry] = 0
    out_b = {label: gen[label] | (in_b[label] & ~kill[label]) for label in blocks}
    out_b[entry] = gen[entry]
    preds = {label: [p for p, _d in cfg.predecessors(label)] for label in blocks if label != entry}
    changed = True
    while changed:
        changed = False
        for label in blocks:
            if label == entry:
                continue
            predecs = preds[label]
            x = out_b[predecs[0]]
            for p in predecs:
                x &= out_b[p]
            in_b[label] = x
            o = gen[label] | (x & ~kill[label])
            if o != out_b[label]:
                out_b[label] = o
                changed = True
    return _as_sets(in_b, copies), _as_sets(out_b, copies)


def _as_sets(bits: dict, copies: list) -> dict:
    """label -> bit set, as label -> set of the copies (lhs, rhs) whose bits are set."""
    import numpy as np

    nbytes = (len(copies) + 7) // 8
    out = {}
    for label, x in bits.items():
        if x == 0:
            out[label] = set()
            continue
        on = np.flatnonzero(np.unpackbits(np.frombuffer(x.to_bytes(nbytes, "little"), np.uint8), bitorder="little"))
        out[label] = {copies[k] for k in on.tolist()}
    return out


def compute_live_map(cfg, blocks, var_use_map, var_def_map):
    """Numba's ``compute_live_map``: the variables live at the entry of each block, from the least fixed
    points of reaching names (forward) and liveness (backward), computed on bit sets."""
    index: dict = {}
    names: list = []

    def bits(vs):
        b = 0
        for v in vs:
            k = index.get(v)
            if k is None:
                k = index[v] = len(names)
                names.append(v)
            b |= 1 << k
        return b

    topo = cfg.topo_order()
    use = {off: bits(var_use_map[off]) for off in blocks}
    defs = {off: bits(var_def_map[off]) for off in blocks}
    succ = {off: [s for s, _d in cfg.successors(off)] for off in topo}
    pred = {off: [p for p, _d in cfg.predecessors(off)] for off in topo}
    reach = {off: 0 for off in blocks}
    for off in topo:
        reach.setdefault(off, 0)
        for s in succ[off]:
            reach.setdefault(s, 0)
    changed = True
    while changed:
        changed = False
        for off in topo:
            r = reach[off] | defs.get(off, 0) | use.get(off, 0)
            if r != reach[off]:
                reach[off] = r
                changed = True
            for s in succ[off]:
                if reach[s] | r != reach[s]:
                    reach[s] |= r
                    changed = True
    live = {off: use[off] for off in blocks}
    changed = True
    while changed:
        changed = False
        for off in reversed(topo):
            lv = live.get(off, 0)
            for p in pred[off]:
                new = live.get(p, 0) | (lv & reach[p] & ~defs.get(p, 0))
                if new != live.get(p, 0):
                    live[p] = new
                    changed = True
    out = {}
    for off in blocks:
        b = live[off]
        vs = set()
        while b:
            low = b & -b
            vs.add(names[low.bit_length() - 1])
            b ^= low
        out[off] = vs
    return out


_OLD_COPY = """            for block_label, block in the_ir.blocks.items():
                new_block = copy.deepcopy(the_ir.blocks[block_label])
"""
_NEW_COPY = """            memo = {}
            for block_label, block in the_ir.blocks.items():
                new_block = copy.deepcopy(the_ir.blocks[block_label], memo)
"""


def _inline_ir_one_memo(original):
    """``InlineWorker.inline_ir`` with its nested ``copy_ir`` sharing one deep-copy memo over the blocks."""
    from numba.core import inline_closurecall

    src = textwrap.dedent(inspect.getsource(original))
    old = textwrap.indent(textwrap.dedent(_OLD_COPY), " " * 8)
    new = textwrap.indent(textwrap.dedent(_NEW_COPY), " " * 8)
    if src.count(old) != 1:
        return None
    ns = dict(vars(inline_closurecall))
    exec(compile(src.replace(old, new), inline_closurecall.__file__, "exec"), ns)
    fn = ns[original.__name__]
    fn.__qualname__ = original.__qualname__
    fn.__module__ = original.__module__
    return fn


def install() -> list:
    """Put the replacements in place (once; where the originals are the checked ones).  Returns their names."""
    if installed or os.environ.get("IRT_NUMBA_SPEEDUPS", "1") == "0":
        return installed
    from numba.core import analysis, inline_closurecall, ir_utils
    from numba.parfors import parfor

    if (_hash(ir_utils.copy_propagate) == KNOWN["copy_propagate"]
            and _hash(ir_utils.init_copy_propagate_data) == KNOWN["init_copy_propagate_data"]
            and parfor.copy_propagate is ir_utils.copy_propagate):
        # (init_copy_propagate_data's hash too: copy_propagate computes its kill sets, and nothing else calls it)
        _ORIGINAL["copy_propagate"] = ir_utils.copy_propagate
        ir_utils.copy_propagate = copy_propagate
        parfor.copy_propagate = copy_propagate
        installed.append("copy_propagate")
    if _hash(analysis.compute_live_map) == KNOWN["compute_live_map"]:
        _ORIGINAL["compute_live_map"] = analysis.compute_live_map
        for mod in (analysis, ir_utils, parfor):
            if getattr(mod, "compute_live_map", None) is _ORIGINAL["compute_live_map"]:
                mod.compute_live_map = compute_live_map
        installed.append("compute_live_map")
    worker = inline_closurecall.InlineWorker
    if _hash(worker.inline_ir) == KNOWN["InlineWorker.inline_ir"]:
        fn = _inline_ir_one_memo(worker.inline_ir)
        if fn is not None:
            _ORIGINAL["inline_ir"] = worker.inline_ir
            worker.inline_ir = fn
            installed.append("inline_ir")
    return installed
