"""The disk cache of parses and packed scatter-model tables (irtlang.core.diskcache): it may only save time.
A cached value equals the one computed afresh, a changed input misses, a damaged entry is computed again,
IRT_DISK_CACHE=0 writes nothing.  (Regression guards of the cache's plumbing; no physics here.)"""
import numpy as np
import pytest

from irtlang.compile import pack as PK
from irtlang.core import diskcache
from irtlang.core.diagnostics import Source
from irtlang.lang import parser


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("IRT_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("IRT_DISK_CACHE", "1")
    parser._FLAT_CACHE.clear()
    PK._MODEL_PACKS.clear()
    yield tmp_path
    parser._FLAT_CACHE.clear()
    PK._MODEL_PACKS.clear()


def _big_script(n: int = 1200, value: float = 0.5) -> Source:
    lines = [f"MODEL m{k} LAMBERTIAN {value + k * 1e-4}" for k in range(n)]
    text = "\n".join(lines) + "\n"
    assert len(text) >= parser.DISK_CACHE_MIN_BYTES
    return Source("big.inr", text)


def test_parse_from_disk_equals_a_fresh_parse(cache):
    src = _big_script()
    fresh = parser.parse_source(src)
    assert len(list((cache / "parse").glob("*.pkl"))) == 1
    parser._FLAT_CACHE.clear()
    again = parser.parse_source(Source(src.name, src.text))
    assert again.stmts == fresh.stmts
    # a changed text misses (a second entry), and parses to its own statements
    parser._FLAT_CACHE.clear()
    other = parser.parse_source(_big_script(value=0.25))
    assert other.stmts != fresh.stmts
    assert len(list((cache / "parse").glob("*.pkl"))) == 2


def test_small_scripts_stay_off_disk(cache):
    parser.parse_source(Source("small.inr", "MODEL m LAMBERTIAN 0.5\n"))
    assert not (cache / "parse").exists()


def test_damaged_entry_is_computed_again(cache):
    src = _big_script()
    fresh = parser.parse_source(src)
    (entry,) = (cache / "parse").glob("*.pkl")
    entry.write_bytes(entry.read_bytes()[:100])     # a crash mid-write cannot do this (atomic), a full disk might
    parser._FLAT_CACHE.clear()
    assert parser.parse_source(Source(src.name, src.text)).stmts == fresh.stmts


def test_turned_off_writes_nothing(cache, monkeypatch):
    monkeypatch.setenv("IRT_DISK_CACHE", "0")
    parser.parse_source(_big_script())
    PK._pack_model("RAYLEIGH", {"tau": (0.1, 0.05), "albedo": (1.0, 1.0)}, 2)
    assert not any(cache.iterdir())


def test_packed_tables_from_disk_are_bitwise_the_packed_ones(cache):
    from irtlang.plugins.bsdfs import REGISTRY as BSDFS

    lam = np.linspace(300.0, 2500.0, 295)
    params = {"tau": tuple(0.0088 * (lam / 1000.0) ** -4.05), "albedo": (1.0,) * 295, "depol": 0.0279}
    a = PK._pack_model("RAYLEIGH", params, 295)
    assert len(list((cache / "packs").glob("*.pkl"))) == 1
    PK._MODEL_PACKS.clear()
    b = PK._pack_model("RAYLEIGH", params, 295)
    direct = BSDFS["RAYLEIGH"].pack(params, 295)
    assert a.tobytes() == b.tobytes() == direct.tobytes()
    # another tau misses
    PK._MODEL_PACKS.clear()
    PK._pack_model("RAYLEIGH", dict(params, tau=tuple(0.5 * np.array(params["tau"]))), 295)
    assert len(list((cache / "packs").glob("*.pkl"))) == 2


def test_keys_tell_parts_apart():
    assert diskcache.key("a", "bc") != diskcache.key("ab", "c")
    assert diskcache.key(1.0) != diskcache.key(1)


def test_trim_keeps_the_recently_used(cache, monkeypatch):
    import os
    import time

    monkeypatch.setattr(diskcache, "MAX_BYTES", 3500)
    for q in range(3):
        diskcache.store("t", f"k{q}", b"x" * 1000)
        p = cache / "t" / f"k{q}.pkl"
        os.utime(p, (time.time() - 100 + q, time.time() - 100 + q))
    assert diskcache.load("t", "k0") == b"x" * 1000       # used now: the newest
    diskcache.store("t", "k3", b"x" * 1000)              # over 3500 bytes: the least recently used (k1) goes
    names = sorted(p.stem for p in (cache / "t").glob("*.pkl"))
    assert "k0" in names and "k3" in names and "k1" not in names
