"""Philox4x32-10 against the Random123 known-answer vectors, and statistical sanity of uniform2/uniform4.

KAT source: Random123 ``tests/kat_vectors`` (D. E. Shaw Research), lines ``philox4x32 7`` and
``philox4x32 10``; format ``name rounds ctr[4] key[2] -> out[4]`` (hex uint32).
"""
import numpy as np
import pytest
from scipy import stats

from irtlang.kernels.rng import (philox4x32, philox4x32_rounds, uniform2, uniform2_array, uniform4,
                                 uniform4_array)

KAT = """
philox4x32 7 00000000 00000000 00000000 00000000 00000000 00000000   5f6fb709 0d893f64 4f121f81 4f730a48
philox4x32 7 ffffffff ffffffff ffffffff ffffffff ffffffff ffffffff   5207ddc2 45165e59 4d8ee751 8c52f662
philox4x32 7 243f6a88 85a308d3 13198a2e 03707344 a4093822 299f31d0   4dfccaba 190a87f0 c47362ba b6b5242a
philox4x32 10 00000000 00000000 00000000 00000000 00000000 00000000   6627e8d5 e169c58d bc57ac4c 9b00dbd8
philox4x32 10 ffffffff ffffffff ffffffff ffffffff ffffffff ffffffff   408f276d 41c83b0e a20bc7c6 6d5451fd
philox4x32 10 243f6a88 85a308d3 13198a2e 03707344 a4093822 299f31d0   d16cfe09 94fdcceb 5001e420 24126ea1
"""


def _kat_rows():
    rows = []
    for line in KAT.strip().splitlines():
        f = line.split()
        rows.append((int(f[1]), [int(x, 16) for x in f[2:6]], [int(x, 16) for x in f[6:8]],
                     [int(x, 16) for x in f[8:12]]))
    return rows


@pytest.mark.parametrize("rounds,ctr,key,want", _kat_rows())
def test_philox_kat(rounds, ctr, key, want):
    got = philox4x32_rounds(ctr[0], ctr[1], ctr[2], ctr[3], key[0], key[1], rounds)
    assert [int(x) for x in got] == want
    if rounds == 10:
        got10 = philox4x32(ctr[0], ctr[1], ctr[2], ctr[3], key[0], key[1])
        assert [int(x) for x in got10] == want
        assert all(0 <= int(x) < 2**32 for x in got10)


def test_uniform2_is_the_philox_block():
    """uniform2 keys Philox with the seed and counts (ray lo, ray hi, event, dim); 53-bit mapping."""
    seed = 0x299F31D0A4093822
    ray = 0x85A308D3243F6A88
    # the pi-digits KAT: counter (243f6a88, 85a308d3, 13198a2e, 03707344), key (a4093822, 299f31d0)
    u0, u1 = uniform2(np.uint64(seed), np.uint64(ray), 0x13198A2E, 0x03707344)
    w = [0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1]
    assert u0 == ((w[0] << 32 | w[1]) >> 11) * 2.0 ** -53
    assert u1 == ((w[2] << 32 | w[3]) >> 11) * 2.0 ** -53
    a = uniform4(np.uint64(seed), np.uint64(ray), 0x13198A2E, 0x03707344)
    assert a == tuple((x + 0.5) * 2.0 ** -32 for x in w)


def test_open_interval_and_determinism():
    u = uniform2_array(12345, 0, 200_000, 7, 3)
    assert np.all(u > 0.0) and np.all(u < 1.0)
    u_again = uniform2_array(12345, 0, 200_000, 7, 3)
    assert np.array_equal(u, u_again)
    # a ray's numbers do not depend on the batch it was drawn in
    part = uniform2_array(12345, 150_000, 10, 7, 3)
    assert np.array_equal(part, u[150_000:150_010])
    v = uniform4_array(12345, 0, 1000, 7, 3)
    assert np.all(v > 0.0) and np.all(v < 1.0)
    # negative seeds are their uint64 two's complement
    assert uniform2(-1, 5, 0, 0) == uniform2(np.uint64(2**64 - 1), 5, 0, 0)


def test_uniformity_chi_square():
    n = 1_000_000
    u = uniform2_array(20240917, 0, n, 0, 0)
    for col in range(2):
        counts, _ = np.histogram(u[:, col], bins=100, range=(0.0, 1.0))
        p = stats.chisquare(counts).pvalue
        assert p > 0.01, (col, p)
    # joint (u0, u1) on a 32 x 32 grid
    h, _, _ = np.histogram2d(u[:, 0], u[:, 1], bins=32, range=[[0, 1], [0, 1]])
    assert stats.chisquare(h.ravel()).pvalue > 0.01
    # uniform4's 32-bit words
    v = uniform4_array(20240917, 0, 250_000, 1, 0)
    counts, _ = np.histogram(v.ravel(), bins=100, range=(0.0, 1.0))
    assert stats.chisquare(counts).pvalue > 0.01


@pytest.mark.parametrize("field", ["ray", "event", "dim", "seed"])
def test_neighbouring_counters_independent(field):
    """Streams differing by one in a counter word (or in the seed) are uncorrelated and jointly uniform."""
    n = 200_000
    if field == "ray":
        a = uniform2_array(99, 0, n + 1, 0, 0)
        x, y = a[:-1, 0], a[1:, 0]
    elif field == "event":
        x = uniform2_array(99, 0, n, 4, 0)[:, 0]
        y = uniform2_array(99, 0, n, 5, 0)[:, 0]
    elif field == "dim":
        x = uniform2_array(99, 0, n, 4, 0)[:, 1]
        y = uniform2_array(99, 0, n, 4, 1)[:, 1]
    else:
        x = uniform2_array(99, 0, n, 0, 0)[:, 0]
        y = uniform2_array(100, 0, n, 0, 0)[:, 0]
    r = np.corrcoef(x, y)[0, 1]
    assert abs(r) < 5.0 / np.sqrt(n), r  # 5 standard errors of a null correlation
    h, _, _ = np.histogram2d(x, y, bins=20, range=[[0, 1], [0, 1]])
    assert stats.chisquare(h.ravel()).pvalue > 0.01
