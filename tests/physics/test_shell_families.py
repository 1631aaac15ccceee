"""Nested-shell families (compile.pack.shell_families, family_links): after a ray crosses shell i of a family it
can meet only shells i - 1, i and i + 1 next, so the kernel's nearest-hit search tests those three and jumps over
the rest.  A pure speed-up: a trace must be bitwise the same with the families and without them (every surface
tested on every segment).  The oracle is the kernel's own exhaustive search, so this guards the skip's
plumbing, not any physics.  The shells are declared out of order and with other surfaces between them, so the
jumps cross non-members and land on neighbours that are not adjacent in the surface table.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from _trace_util import ledger_gap, trace_text  # noqa: E402

from irtlang.compile import pack as PK  # noqa: E402

# radii of the family, in declaration order (not sorted), and a plane and a small ball declared between them
RADII = (1.3, 1.0, 1.6, 1.15, 1.45, 1.75, 1.05)


def _shell(kind: str, r: float) -> str:
    """A sphere of radius r, or a spheroid (a = b = r, c = 0.8 r: the Earth's kind of shell, flattened enough
    that its normals differ from a sphere's)."""
    return f"  SPHERE 0 0 0 {r}" if kind == "sphere" else f"  ELLIPSOID {r} {r} {0.8 * r} AT 0 0 0"


def _script(kind: str = "sphere") -> str:
    order = sorted(RADII)
    media = "\n".join(f"MEDIUM air{k} INDEX {1.0 + 0.02 * (len(order) - k):.3f}" for k in range(len(order)))
    parts = ["UNITS M", "WAVELENGTHS 450 650 NM", "SEED 5", media,
             "MODEL haze RAYLEIGH TAU 0.08", "MODEL ground LAMBERTIAN 0.4"]
    for q, r in enumerate(RADII):
        k = order.index(r)
        inner = f"air{k - 1}" if k > 0 else None
        outer = f"air{k}" if k < len(order) - 1 else "AIR"
        if inner is None:
            parts += ["SURFACE", _shell(kind, r), f"OBJECT core_{q}", f"  INTERFACE TRANSMIT {outer} {outer}",
                      "  SCATTER MODEL ground"]
        else:
            parts += ["SURFACE", _shell(kind, r), f"OBJECT shell_{q}", f"  INTERFACE TRANSMIT {inner} {outer}",
                      "  SCATTER MODEL haze"]
        if q == 2:
            parts += ["SURFACE", "  PLANE Z -3 DISK 2", "OBJECT floor", "  INTERFACE ABSORB"]
        if q == 4:
            parts += ["SURFACE", "  SPHERE 0 2.5 0 0.3", "OBJECT moon", "  INTERFACE ABSORB"]
    parts += ["SURFACE", "  PLANE Z 3 RECT 2 2", "OBJECT screen", "  INTERFACE ABSORB", "  DETECTOR PIXELS 32 32",
              "GRID DISK Z 2.5 1.8 RAYS 20000 RANDOM", "SOURCE DIRECTION 0.1 0 -1", "FLUX TOTAL 1 W",
              "LEVEL 60", "HALT 0", "TRACE"]
    return "\n".join(parts) + "\n"


@pytest.mark.parametrize("kind", ["sphere", "ellipsoid"])
def test_family_jumps_leave_the_trace_bitwise_unchanged(tmp_path, monkeypatch, kind):
    """With the families the search also drops, from the side the ray leaves shell i to, the two of i - 1, i,
    i + 1 that it cannot meet first (outward: i and i - 1; inward: i + 1): the same bits again."""
    fam_seen = []
    real = PK.shell_families

    def spy(pk):
        fam, fidx = real(pk)
        fam_seen.append(fam.copy())
        return fam, fidx

    monkeypatch.setattr(PK, "shell_families", spy)
    (tmp_path / "a").mkdir()
    a = trace_text(tmp_path / "a", _script(kind), records=False)
    fam = fam_seen[-1]
    assert np.count_nonzero(fam >= 0) == len(RADII) and len(set(fam[fam >= 0])) == 1, fam
    # the members are not one run of the surface table: the jumps must cross other surfaces
    members = np.nonzero(fam >= 0)[0]
    assert members[-1] - members[0] + 1 > len(members)

    monkeypatch.setattr(PK, "shell_families", lambda pk: (np.full(len(pk.s_kind), -1, np.int64),
                                                          np.zeros(len(pk.s_kind), np.int64)))
    (tmp_path / "b").mkdir()
    b = trace_text(tmp_path / "b", _script(kind), records=False)
    # the scene does what it is meant to: light scatters in the shells, reaches the screen, the ledger closes
    names = [n.upper() for n in a.rows]
    assert a.ledger[names.index("SCREEN")].sum() > 0
    assert ledger_gap(a) < 1e-12
    assert np.array_equal(a.ledger, b.ledger)
    assert np.array_equal(a.ledger_sq, b.ledger_sq)
    for name in a.images:
        for x, y in zip(a.images[name], b.images[name]):
            assert np.array_equal(x, y), name


def test_family_links():
    fam = np.array([-1, 0, 0, -1, 0, 1, 1, 1, 0])
    fidx = np.array([0, 2, 0, 0, 1, 0, 2, 1, 3])
    prev, nxt, out = PK.family_links(fam, fidx)
    assert list(prev) == [-1, 4, -1, -1, 2, -1, 7, 5, 1]
    assert list(nxt) == [-1, 8, 4, -1, 1, 7, -1, 6, -1]
    assert list(out) == [0, 3, 3, 0, 5, 8, 8, 8, 9]
