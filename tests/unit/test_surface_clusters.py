"""Clusters of surfaces (compile.pack.surface_clusters): the kernel's nearest-hit search skips a run of surfaces
(an instrument's mirrors, baffles and detector) whose common bounding sphere the ray misses.  A pure speed-up:
the traces must be bitwise the same with and without it (the oracle here is the kernel's own search over every
surface, which is what this guards), and the sphere must hold every member's own bounding sphere."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from irtlang.cli import main
from irtlang.compile import pack as PK
from irtlang.kernels.layout import SF_BS, SF_N, SF_R, SF_TH, SF_TL

SCRIPT = Path(__file__).resolve().parents[2] / "examples_scripts" / "camera_cassegrain.inr"


def _run(out: Path, mode: str) -> dict:
    assert main(["run", str(SCRIPT), "--out", str(out), "--set", f"mode='{mode}'"]) == 0
    return {p.name: p.read_bytes() for p in sorted(out.glob("*.npy"))}


@pytest.mark.parametrize("mode", ["camera", "forward"])
def test_clusters_leave_the_trace_bitwise_unchanged(tmp_path, monkeypatch, mode):
    seen = []
    real = PK.surface_clusters

    def spy(f, fam):
        out = real(f, fam)
        seen.append(int(np.count_nonzero(out[1])))
        return out

    monkeypatch.setattr(PK, "surface_clusters", spy)
    with_clusters = _run(tmp_path / "a", mode)
    assert seen and max(seen) >= 1, "the Cassegrain scene should form a cluster"
    monkeypatch.setattr(PK, "CLUSTER_MIN", 10 ** 9)
    seen.clear()
    without = _run(tmp_path / "b", mode)
    assert max(seen) == 0
    assert with_clusters.keys() == without.keys() and with_clusters
    for name in with_clusters:
        assert with_clusters[name] == without[name], name


def test_cluster_sphere_holds_its_members():
    rng = np.random.default_rng(3)
    n = 9
    f = np.zeros((n, SF_N))
    for j in range(n):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        f[j, SF_R:SF_R + 9] = q.ravel()
        f[j, SF_TH:SF_TH + 3] = 2.7e10 + 0.5 * rng.normal(size=3)  # 0.18 AU away, a metre apart
        f[j, SF_TL:SF_TL + 3] = rng.normal(size=3) * 1e-7
        f[j, SF_BS:SF_BS + 3] = rng.normal(size=3) * 0.2
        f[j, SF_BS + 3] = rng.uniform(0.3, 0.5)
    fam = np.full(n, -1)
    fam[4] = 0              # a shell in the middle splits the run: 0..3 and 5..8
    f[6, SF_BS + 3] = np.inf  # an unbounded surface splits it again: 5 alone, 7..8 too short
    sph, ends = PK.surface_clusters(f, fam)
    assert list(np.nonzero(ends)[0]) == [0] and ends[0] == 4
    # a run that is the whole scene (a telescope alone) is no cluster
    assert not np.any(PK.surface_clusters(f[:4], np.full(4, -1))[1])
    # a surface 100 km away (the planet after the telescope in the script) ends the cluster
    g = np.concatenate([f[:4], f[:1]])
    g[4, SF_TH:SF_TH + 3] += 1e5
    sph2, ends2 = PK.surface_clusters(g, np.full(5, -1))
    assert list(np.nonzero(ends2)[0]) == [0] and ends2[0] == 4 and np.allclose(sph2[0], sph[0])
    c, r = sph[0, :3], sph[0, 3]
    for j in range(4):
        R = f[j, SF_R:SF_R + 9].reshape(3, 3)
        cw = R @ f[j, SF_BS:SF_BS + 3] + f[j, SF_TH:SF_TH + 3] + f[j, SF_TL:SF_TL + 3]
        assert np.linalg.norm(cw - c) + f[j, SF_BS + 3] <= r
