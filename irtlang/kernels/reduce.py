"""The reduction of a trace batch's chunk tallies into the run's ledger and images.

It takes no feature flag, so it lives here and not in the kernel template (``trace_kernel``), which
``irtlang.compile.specialize`` copies once per feature set: compiled once per machine and shared by every
specialized kernel, a new feature combination does not compile it again (docs/architecture.md, "Compile time").
"""
import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _group_add(gt, gv, ng, t, v):
    """reduce_batch's running sums of one deposit group: v added to image element t's.  Returns (gt, gv, ng)."""
    for g in range(ng):
        if gt[g] == t:
            gv[g] += v
            return gt, gv, ng
    if ng == gt.shape[0]:
        gt2 = np.empty(2 * ng + 8, np.int64)
        gv2 = np.empty(2 * ng + 8)
        gt2[:ng] = gt[:ng]
        gv2[:ng] = gv[:ng]
        gt = gt2
        gv = gv2
    gt[ng] = t
    gv[ng] = v
    return gt, gv, ng + 1


@numba.njit(cache=True)
def reduce_batch(led, inc_sq, dep_idx, dep_w, dep_d, dep_n, ledger, ledger_sq, img, img_sq, d_lo, d_npix, i_off, d_nb, d_fm,
                 d_fm_off):
    """Add a batch's chunk tallies in chunk order (deterministic for any thread count).  A deposit's index is
    d_lo[d] + line * npix + pixel; a detector with filters (d_nb[d] = B > 0) adds w T[line, b] to each filter
    image b (its (L, B) matrix at d_fm[d_fm_off[d]:]), else the deposit goes to the line's own image.  The
    squares are dep_d's: a source ray's deposit, or a stratified pair's difference (camera DIRECTIONS, a
    paired SPECTRAL).  A pair whose deposits lie on several lines is one group, its later deposits' indices
    stored as -(index + 1): the square is then of the group's sum in each image it reaches (in a filter image
    the pair's difference a T(line_a) - b T(line_b), not a^2 T^2 + b^2 T^2)."""
    nd = d_lo.shape[0]
    L = led.shape[3]
    gt = np.empty(8, np.int64)
    gv = np.empty(8)
    ng = 0
    for c in range(led.shape[0]):
        ledger += led[c]
        ledger_sq += inc_sq[c]
        nq = dep_n[c]
        for q in range(nq):
            k = dep_idx[c, q]
            if k < 0:
                k = -k - 1
                grouped = True
            else:
                grouped = q + 1 < nq and dep_idx[c, q + 1] < 0
                ng = 0
            w = dep_w[c, q]
            e = dep_d[c, q]
            d = nd - 1
            while d > 0 and k < d_lo[d]:
                d -= 1
            rel = k - d_lo[d]
            B = d_nb[d]
            if B == 0:
                img[i_off[d] + rel] += w
                if grouped:
                    gt, gv, ng = _group_add(gt, gv, ng, i_off[d] + rel, e)
                else:
                    img_sq[i_off[d] + rel] += e * e
            else:
                # a polarized trace's deposits run over (Stokes component, line): component k's filter
                # images follow component k - 1's
                npx = d_npix[d]
                cl = rel // npx
                comp = cl // L
                line = cl - comp * L
                pix = rel - cl * npx
                base = d_fm_off[d] + line * B
                for b in range(B):
                    fb = d_fm[base + b]
                    if fb != 0.0:
                        wb = w * fb
                        eb = e * fb
                        img[i_off[d] + (comp * B + b) * npx + pix] += wb
                        if grouped:
                            gt, gv, ng = _group_add(gt, gv, ng, i_off[d] + (comp * B + b) * npx + pix, eb)
                        else:
                            img_sq[i_off[d] + (comp * B + b) * npx + pix] += eb * eb
            if grouped and not (q + 1 < nq and dep_idx[c, q + 1] < 0):
                for g in range(ng):
                    img_sq[gt[g]] += gv[g] * gv[g]


def warm() -> None:
    """Compile reduce_batch (or load it from Numba's cache) for the argument types the tracer passes
    (``irtlang.tracer.Accumulator.add``: C-contiguous float64 and int64 arrays of these ranks), on a batch of no
    deposits.  tests/unit/test_compile_ahead.py checks that it makes the tracer's one signature."""
    i = np.int64
    reduce_batch(np.zeros((1, 1, 5, 1)), np.zeros((1, 1, 1)), np.zeros((1, 1), i), np.zeros((1, 1)),
                 np.zeros((1, 1)), np.zeros(1, i), np.zeros((1, 5, 1)), np.zeros((1, 1)), np.zeros(1), np.zeros(1),
                 np.zeros(1, i), np.zeros(1, i), np.zeros(1, i), np.zeros(1, i), np.zeros(1), np.zeros(1, i))


def cached() -> bool:
    """Whether Numba's cache holds compiled code of reduce_batch for this source (its index read as Numba
    reads it: an index left by an older source counts as empty).  True where that cannot be told."""
    try:
        return bool(reduce_batch._cache._cache_file._load_index())
    except Exception:       # Numba's internals changed: assume cached (nothing is compiled ahead)
        return True


def main() -> None:
    """``python -m irtlang.kernels.reduce``: compile reduce_batch into the cache unless another process is
    doing it or has done it (irtlang.tracer starts this in the background beside a first kernel compile)."""
    import os

    try:
        import fcntl
    except ImportError:
        fcntl = None
    lock = os.path.join(reduce_batch._cache.cache_path, "reduce_warm.lock")
    os.makedirs(os.path.dirname(lock), exist_ok=True)
    with open(lock, "a") as f:
        if fcntl is not None:
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                return          # another process is compiling it
        if not cached():
            warm()


if __name__ == "__main__":
    main()
