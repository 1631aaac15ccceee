"""Counter-based random numbers: Philox4x32-10 (Salmon, Moraes, Dror & Shaw, SC'11; Random123).

Why counter-based
-----------------
A ray's random numbers are a pure function of ``(seed, ray index, event index, dimension)``: no state is
carried between calls, so results do not depend on the number of threads, the batch size or the order in
which rays are traced (DESIGN.md, "Kernels").

Conventions
-----------
* ``philox4x32(c0, c1, c2, c3, k0, k1)`` is the bare block function: a 128-bit counter (four 32-bit words)
  and a 64-bit key (two words) map to four 32-bit words, exactly as Random123's ``philox4x32_R(10, ctr, key)``
  (checked against its ``kat_vectors`` in ``tests/physics/test_rng.py``). Arguments are integers; only their
  low 32 bits are used. The words come back as ``np.uint32``.
* Integer arguments are reinterpreted as uint64 (a negative int64 seed is its two's complement). From
  Python, numba types ints as int64: pass a seed >= 2**63 as ``np.uint64(seed)``.
* ``uniform2(seed, ray, event, dim)``: key = the 64-bit ``seed`` (low word k0, high word k1); counter =
  (ray & 0xffffffff, ray >> 32, event, dim). The four output words make two 64-bit integers
  ``(w0 << 32 | w1)`` and ``(w2 << 32 | w3)``; each keeps its top 53 bits, m, and becomes ``m * 2**-53``,
  except m = 0, which becomes ``2**-54``. Both doubles are therefore in the *open* interval (0, 1):
  smallest 2**-54, largest 1 - 2**-53. (Safe for ``log(u)``, ``1/u``, ``log(1-u)``.)
* ``uniform4(seed, ray, event, dim)``: the same block read as four doubles of 32-bit resolution,
  ``(w + 0.5) * 2**-32``, all in [2**-33, 1 - 2**-33]. ``uniform2`` and ``uniform4`` with the same
  (seed, ray, event, dim) use the same bits: a caller must not use both for one counter. Convention for
  the tracer: ``event`` counts interactions of a ray, ``dim`` numbers the independent draws inside one
  interaction (0, 1, 2, ...); each call consumes one ``dim``.
* All arithmetic is done on ``np.uint64`` with explicit 32-bit masks (numba promotes mixed signed /
  unsigned 64-bit integer arithmetic to float, so every constant here is a uint64).
"""
import numba
import numpy as np

__all__ = [
    "philox4x32",
    "philox4x32_rounds",
    "uniform2",
    "uniform4",
    "uniform2_array",
    "uniform4_array",
]

_M0 = np.uint64(0xD2511F53)
_M1 = np.uint64(0xCD9E8D57)
_W0 = np.uint64(0x9E3779B9)
_W1 = np.uint64(0xBB67AE85)
_MASK32 = np.uint64(0xFFFFFFFF)
_SH32 = np.uint64(32)
_SH11 = np.uint64(11)
_ZERO = np.uint64(0)
_TWO_M53 = 1.0 / 9007199254740992.0  # 2**-53
_TWO_M54 = 0.5 * _TWO_M53  # 2**-54
_TWO_M32 = 1.0 / 4294967296.0  # 2**-32


@numba.njit(cache=True, fastmath=False)
def philox4x32_rounds(c0, c1, c2, c3, k0, k1, rounds):
    """Philox4x32 with a given number of rounds (Random123 ``philox4x32_R``); words as np.uint64 < 2**32."""
    x0 = np.uint64(c0) & _MASK32
    x1 = np.uint64(c1) & _MASK32
    x2 = np.uint64(c2) & _MASK32
    x3 = np.uint64(c3) & _MASK32
    ka = np.uint64(k0) & _MASK32
    kb = np.uint64(k1) & _MASK32
    for _ in range(rounds):
        p0 = _M0 * x0  # exact: both factors < 2**32
        p1 = _M1 * x2
        hi0 = p0 >> _SH32
        lo0 = p0 & _MASK32
        hi1 = p1 >> _SH32
        lo1 = p1 & _MASK32
        x0 = hi1 ^ x1 ^ ka
        x1 = lo1
        x2 = hi0 ^ x3 ^ kb
        x3 = lo0
        ka = (ka + _W0) & _MASK32
        kb = (kb + _W1) & _MASK32
    return x0, x1, x2, x3


@numba.njit(cache=True, fastmath=False)
def philox4x32(c0, c1, c2, c3, k0, k1):
    """Philox4x32-10 block: counter (c0..c3), key (k0, k1) -> four np.uint32 words."""
    x0, x1, x2, x3 = philox4x32_rounds(c0, c1, c2, c3, k0, k1, 10)
    return np.uint32(x0), np.uint32(x1), np.uint32(x2), np.uint32(x3)


@numba.njit(cache=True, fastmath=False)
def _block(seed, ray, event, dim):
    s = np.uint64(seed)
    r = np.uint64(ray)
    return philox4x32_rounds(r & _MASK32, r >> _SH32, np.uint64(event) & _MASK32,
                             np.uint64(dim) & _MASK32, s & _MASK32, s >> _SH32, 10)


@numba.njit(cache=True, fastmath=False)
def _to_open53(hi, lo):
    m = ((hi << _SH32) | lo) >> _SH11
    if m == _ZERO:
        return _TWO_M54
    return np.float64(m) * _TWO_M53


@numba.njit(cache=True, fastmath=False)
def uniform2(seed, ray, event, dim):
    """Two independent doubles in the open interval (0, 1), 53-bit, for (seed, ray, event, dim)."""
    x0, x1, x2, x3 = _block(seed, ray, event, dim)
    return _to_open53(x0, x1), _to_open53(x2, x3)


@numba.njit(cache=True, fastmath=False)
def uniform4(seed, ray, event, dim):
    """Four independent doubles in (0, 1) with 32-bit resolution, for (seed, ray, event, dim)."""
    x0, x1, x2, x3 = _block(seed, ray, event, dim)
    return ((np.float64(x0) + 0.5) * _TWO_M32, (np.float64(x1) + 0.5) * _TWO_M32,
            (np.float64(x2) + 0.5) * _TWO_M32, (np.float64(x3) + 0.5) * _TWO_M32)


@numba.njit(cache=True, fastmath=False)
def uniform2_array(seed, ray0, n, event, dim):
    """(n, 2) array: row i = uniform2(seed, ray0 + i, event, dim). For tests and vectorised setup."""
    out = np.empty((n, 2), dtype=np.float64)
    for i in range(n):
        a, b = uniform2(seed, ray0 + i, event, dim)
        out[i, 0] = a
        out[i, 1] = b
    return out


@numba.njit(cache=True, fastmath=False)
def uniform4_array(seed, ray0, n, event, dim):
    """(n, 4) array: row i = uniform4(seed, ray0 + i, event, dim)."""
    out = np.empty((n, 4), dtype=np.float64)
    for i in range(n):
        a, b, c, d = uniform4(seed, ray0 + i, event, dim)
        out[i, 0] = a
        out[i, 1] = b
        out[i, 2] = c
        out[i, 3] = d
    return out
