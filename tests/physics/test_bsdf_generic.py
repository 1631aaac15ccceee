"""Every scatter model of the registry against its own kernel contract.

For each plugin, a few parameter sets (built from script text, as a user writes them) and incidence angles:

* chi-square of 1e6 sampled directions against pdf(): bins in (cos theta_o, phi) of about equal probability,
  their edges chosen from an independent pilot sample (so they do not depend on the data tested), expected
  counts from Gauss-Legendre integration of pdf() over each bin; one more bin collects the samples that are not
  directions of the density (the delta of a slab, samples lost with weight 0).  alpha = 0.01 for the whole file,
  Sidak-corrected: alpha_each = 1 - (1 - 0.01)^(1/m) over the m chi-square tests;
* sample()'s weight equals eval |cos_o| / pdf at the sampled direction (and the delta's weight times its
  probability equals direct_transmission);
* pdf() integrates to one minus the delta / lost share; albedo() equals the quadrature of eval |cos_o| (plus the
  delta) to 1e-4, and R + T <= 1 for physical parameters;
* reciprocity where it holds; no NaN or negative value for degenerate inputs.
Random numbers come from the project's Philox (fixed seeds): every test is deterministic.
"""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numba
import numpy as np
import pytest
from scipy import stats

from irtlang.kernels.rng import uniform2_array
from irtlang.lang.interp import Interpreter
from irtlang.plugins.bsdfs import REGISTRY

ALPHA = 0.01
N_SAMPLES = 1_000_000
N_PILOT = 200_000


# ---------------------------------------------------------------- a BRDF table for TABLE
def _table_text() -> str:
    """A smooth test BRDF on a 15 x 10 x 20 deg grid: a Lambertian part and a lobe about the mirror direction."""
    rows = []
    for ti in range(0, 91, 15):
        for to in range(0, 91, 10):
            for ph in range(0, 181, 20):
                a, b, p = (math.radians(x) for x in (ti, to, ph))
                cs = math.cos(a) * math.cos(b) - math.sin(a) * math.sin(b) * math.cos(p)   # cos to the mirror dir.
                f1 = 0.2 / math.pi + 0.3 * max(0.0, cs) ** 8
                f2 = 0.05 / math.pi + 0.1 * max(0.0, cs) ** 3
                rows.append(f"{ti},{to},{ph},{f1:.7f},{f2:.7f}")
    return "# test BRDF\ntheta_i_deg,theta_o_deg,phi_deg,brdf_1,brdf_2\n" + "\n".join(rows) + "\n"


@lru_cache(maxsize=1)
def _table_dir() -> Path:
    import tempfile

    d = Path(tempfile.mkdtemp(prefix="irt_bsdf_"))
    (d / "brdf.csv").write_text(_table_text())
    return d


def build_model(text: str, base: Path | None = None, lines: str = "450 550"):
    """(module, P) of the model named X defined by `text` (a MODEL command's kind and arguments)."""
    it = Interpreter(check_only=True)
    it.base_dir = base or Path.cwd()
    it.include_stack = [it.base_dir / "snippet.inr"]
    it.run_text(f"WAVELENGTHS {lines} nm\nMODEL x {text}\n")
    diags = list(it.diags.items)
    assert not diags, "\n".join(d.render() for d in diags)
    m = it.state.models["X"]
    mod = REGISTRY[m.kind]
    return mod, mod.pack(m.params, len(it.state.wavelengths_nm))


# (label, model text, line) -- a few representative parameter sets per plugin
CASES = [
    ("lambert", "LAMBERTIAN 0.5 0.3 TRANSMIT 0.3 0.2", 0),
    ("rossli", "ROSSLI ISO 0.1 0.05 VOL 0.05 0.02 GEO 0.02 0.01", 0),
    ("rossli_clamped", "ROSSLI ISO 0.03 0.03 VOL 0.02 0.12 GEO 0.005 0.04", 1),
    ("glint", "GLINT WIND 7 m/s INDEX 1.34 1.33 ALBEDO 0.05 0.08", 1),
    ("glint_calm", "GLINT WIND 2 m/s INDEX 1.34 ALBEDO 0", 0),
    ("rayleigh", "RAYLEIGH TAU 0.0971 0.3 ALBEDO 1 0.9 DEPOL 0.0279", 0),
    ("rayleigh_thick", "RAYLEIGH TAU 0.0971 2.0 ALBEDO 1 0.9 DEPOL 0.0279", 1),
    ("hg_cloud", "HG G 0.85 TAU 1 ALBEDO 0.99 ORDERS 4", 0),
    ("hg_back", "HG G 0.5 -0.3 TAU 2 0.2 ALBEDO 0.9 0.8 ORDERS 1", 1),
    ("eddington_cloud", "EDDINGTON G 0.85 0.7 TAU 16 0.5 ALBEDO 0.99999 0.9", 0),
    ("eddington_thin", "EDDINGTON G 0.85 0.7 TAU 16 0.5 ALBEDO 0.99999 0.9", 1),
    ("abg_polished", "ABG A 0.001 B 0.0001 G 2", 0),
    ("abg_rough", "ABG A 0.01 0.02 B 0.01 0.05 G 1.5 0.5", 1),
    ("table", "TABLE 'brdf.csv'", 1),
]
ANGLES = [0.0, 35.0, 75.0]
CHI_CASES = [(c, a) for c in CASES for a in ANGLES]
ALPHA_EACH = 1.0 - (1.0 - ALPHA) ** (1.0 / len(CHI_CASES))
# the fast tier runs one parameter set per plugin at 35 deg; the whole matrix is marked slow
FAST_CHI = {("lambert", 35.0), ("rossli_clamped", 35.0), ("glint", 35.0), ("rayleigh", 35.0), ("hg_cloud", 35.0), ("eddington_cloud", 35.0),
            ("abg_polished", 35.0), ("table", 35.0)}
CHI_PARAMS = [pytest.param(c[0], a, id=f"{c[0]}-{a:g}",
                           marks=() if (c[0], a) in FAST_CHI else pytest.mark.slow) for c, a in CHI_CASES]
SLABS = {"RAYLEIGH", "HG", "EDDINGTON"}


def test_every_registered_kind_is_covered():
    kinds = {build_model(t, _table_dir())[0].KIND for _, t, _ in CASES}
    assert kinds == set(REGISTRY)
    assert list(REGISTRY) == ["LAMBERTIAN", "ROSSLI", "GLINT", "RAYLEIGH", "HG", "EDDINGTON", "ABG", "TABLE"]


@lru_cache(maxsize=None)
def case(label):
    text, k = next((t, k) for lb, t, k in CASES if lb == label)
    mod, P = build_model(text, _table_dir())
    return mod, P, k


# ---------------------------------------------------------------- njit harnesses (one per plugin module)
@lru_cache(maxsize=None)
def harness(mod):
    sample, pdf, ev = mod.sample, mod.pdf, mod.eval

    @numba.njit
    def run(P, k, wi, n, U, out):
        """out[i] = wo (3), weight, delta, pdf(wo), eval(wo)."""
        for i in range(U.shape[0]):
            x, y, z, w, d = sample(P, k, wi[0], wi[1], wi[2], n[0], n[1], n[2], U[i, 0], U[i, 1], U[i, 2])
            out[i, 0] = x
            out[i, 1] = y
            out[i, 2] = z
            out[i, 3] = w
            out[i, 4] = 1.0 if d else 0.0
            out[i, 5] = pdf(P, k, wi[0], wi[1], wi[2], x, y, z, n[0], n[1], n[2])
            out[i, 6] = ev(P, k, wi[0], wi[1], wi[2], x, y, z, n[0], n[1], n[2])

    @numba.njit
    def grid(P, k, wi, n, D, out):
        """out[i] = (pdf, eval) at the directions D[i]."""
        for i in range(D.shape[0]):
            out[i, 0] = pdf(P, k, wi[0], wi[1], wi[2], D[i, 0], D[i, 1], D[i, 2], n[0], n[1], n[2])
            out[i, 1] = ev(P, k, wi[0], wi[1], wi[2], D[i, 0], D[i, 1], D[i, 2], n[0], n[1], n[2])

    return run, grid


def uniforms3(n, seed):
    a = uniform2_array(seed, 0, n, 0, 0)
    b = uniform2_array(seed, 0, n, 1, 0)
    return np.ascontiguousarray(np.column_stack([a, b[:, 0]]))


def geometry(theta_deg, tilt=False):
    """(wi, n, e1, e2): e1 along wi's tangential direction (phi = 0: backscattering side), e2 = n x e1."""
    if not tilt:
        n = np.array([0.0, 0.0, 1.0])
    else:
        n = np.array([0.3, -0.5, 0.8])
        n /= np.linalg.norm(n)
    a = np.array([1.0, 0.0, 0.0]) - n[0] * n
    e1 = a / np.linalg.norm(a)
    e2 = np.cross(n, e1)
    t = math.radians(theta_deg)
    wi = math.sin(t) * e1 + math.cos(t) * n
    return wi, n, e1, e2


def directions(mu, phi, n, e1, e2):
    s = np.sqrt(np.maximum(0.0, 1.0 - mu * mu))
    return np.ascontiguousarray(s[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2) + mu[:, None] * n)


def run_samples(mod, P, k, wi, n, nsamp, seed):
    run, _ = harness(mod)
    U = uniforms3(nsamp, seed)
    out = np.empty((nsamp, 7))
    run(P, k, wi, n, U, out)
    return out


def eval_grid(mod, P, k, wi, n, D):
    _, grid = harness(mod)
    out = np.empty((D.shape[0], 2))
    grid(P, k, wi, n, D, out)
    return out


# ---------------------------------------------------------------- quadrature over the sphere
def _graded(points, lo, hi, levels=34, n_gl=8, extra=()):
    """Gauss-Legendre nodes/weights on [lo, hi] in panels graded geometrically towards each of `points`,
    with further panel edges at `extra`."""
    brk = {lo, hi} | {float(x) for x in extra if lo <= x <= hi}
    for p in points:
        if lo <= p <= hi:
            brk.add(p)
            for lv in range(1, levels + 1):
                for q in (p - (p - lo) * 0.5 ** lv, p + (hi - p) * 0.5 ** lv):
                    brk.add(q)
    b = np.array(sorted(brk))
    b = b[np.concatenate(([True], np.diff(b) > 1e-14))]
    x, w = np.polynomial.legendre.leggauss(n_gl)
    a0, a1 = b[:-1, None], b[1:, None]
    return ((a0 + a1) / 2 + (a1 - a0) / 2 * x).ravel(), ((a1 - a0) / 2 * w).ravel()


def _cell_edges(mod, P, k):
    """TABLE: the (cos theta_o, phi) edges of its sampler's cells, where its pdf jumps; () for the others."""
    if mod.KIND != "TABLE":
        return (), ()
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = mod._offsets(P, k)
    return P[oEo + nEo:oEo + 2 * nEo, k], P[oEp:oEp + nEp, k]


def sphere_integrals(mod, P, k, theta_deg, tilt=False):
    """(int pdf, int_up f cos, int_down f |cos|) with panels graded towards the specular, forward and
    backscattering directions, normal incidence and the horizon; phi in [0, pi], doubled (isotropic models)."""
    wi, n, e1, e2 = geometry(theta_deg, tilt)
    c = math.cos(math.radians(theta_deg))
    mu_e, ph_e = _cell_edges(mod, P, k)
    mu, wm = _graded([-1.0, -c, 0.0, c, 1.0], -1.0, 1.0, extra=mu_e)
    ph, wp = _graded([0.0, math.pi], 0.0, math.pi, extra=ph_e)
    MU, PH = np.meshgrid(mu, ph, indexing="ij")
    W = np.outer(wm, wp) * 2.0
    vals = eval_grid(mod, P, k, wi, n, directions(MU.ravel(), PH.ravel(), n, e1, e2)).reshape(MU.shape + (2,))
    up = MU > 0
    return (float(np.sum(W * vals[..., 0])), float(np.sum((W * vals[..., 1] * np.abs(MU))[up])),
            float(np.sum((W * vals[..., 1] * np.abs(MU))[~up])))


# ---------------------------------------------------------------- chi-square
def _bins_from_pilot(mu, phi, n_bands=16, n_phi=16):
    """Rectangles in (mu, phi) tiling the sphere, about equally probable under the pilot sample."""
    rects = []
    for lo, hi, sel in ((-1.0, 0.0, mu < 0), (0.0, 1.0, mu >= 0)):
        frac = sel.mean()
        nb = max(1, int(round(n_bands * frac))) if frac > 1e-3 else 1
        m = mu[sel]
        edges = np.quantile(m, np.linspace(0, 1, nb + 1)) if len(m) > 100 * nb else np.linspace(lo, hi, nb + 1)
        edges[0], edges[-1] = lo, hi
        edges = np.unique(edges)
        for a, b in zip(edges[:-1], edges[1:]):
            inb = sel & (mu >= a) & (mu < b)
            p = phi[inb]
            npb = n_phi if len(p) > 100 * n_phi else 1
            pe = np.quantile(p, np.linspace(0, 1, npb + 1)) if npb > 1 else np.array([-np.pi, np.pi])
            pe[0], pe[-1] = -np.pi, np.pi
            pe = np.unique(pe)
            for c0, c1 in zip(pe[:-1], pe[1:]):
                rects.append((a, b, c0, c1))
    return rects


def _table_bins(mod, P, k):
    """TABLE: bins aligned with the sampler's own cells (its pdf is constant on each)."""
    nI, nO, nP, nEo, nEp, oI, oO, oP, oA, oF, oEo, oEp, oW, oT, ncell = mod._offsets(P, k)
    mu_e = np.sort(P[oEo + nEo:oEo + 2 * nEo, k])
    ph_e = P[oEp:oEp + nEp, k]
    ph_e = np.unique(np.concatenate((-ph_e, ph_e)))
    rects = [(-1.0, 0.0, -np.pi, np.pi)]
    for a, b in zip(mu_e[:-1], mu_e[1:]):
        for c0, c1 in zip(ph_e[:-1], ph_e[1:]):
            rects.append((a, b, c0, c1))
    return rects


def _rect_probs_fixed(mod, P, k, wi, n, e1, e2, R, nq):
    x, w = np.polynomial.legendre.leggauss(nq)
    a, b, c0, c1 = (R[:, i][:, None, None] for i in range(4))
    MU = (a + b) / 2 + (b - a) / 2 * x[None, :, None]
    PH = (c0 + c1) / 2 + (c1 - c0) / 2 * x[None, None, :]
    MU, PH = np.broadcast_arrays(MU, PH)
    W = ((b - a) / 2 * w[None, :, None]) * ((c1 - c0) / 2 * w[None, None, :])
    vals = eval_grid(mod, P, k, wi, n, directions(MU.ravel(), PH.ravel(), n, e1, e2))[:, 0].reshape(MU.shape)
    return np.sum(W * vals, axis=(1, 2))


def _split(R, m):
    """Each rectangle cut into m x m equal sub-rectangles."""
    t = np.linspace(0.0, 1.0, m + 1)
    a, b, c0, c1 = R.T
    ma = a[:, None] + (b - a)[:, None] * t[None, :]
    pa = c0[:, None] + (c1 - c0)[:, None] * t[None, :]
    out = np.empty((len(R), m, m, 4))
    out[..., 0] = ma[:, :-1, None]
    out[..., 1] = ma[:, 1:, None]
    out[..., 2] = pa[:, None, :-1]
    out[..., 3] = pa[:, None, 1:]
    return out.reshape(-1, 4)


def _rect_probs(mod, P, k, wi, n, e1, e2, rects, nq=12, rtol=1e-4, max_level=4):
    """Integral of pdf over each (mu, phi) rectangle: Gauss-Legendre on 2^L x 2^L sub-rectangles, L raised
    until two successive levels agree to rtol (relative to the bin) or 1e-10 (absolute)."""
    R = np.asarray(rects, float)
    prev = _rect_probs_fixed(mod, P, k, wi, n, e1, e2, R, nq)
    todo = np.arange(len(R))
    for level in range(1, max_level + 1):
        m = 2 ** level
        sub = _rect_probs_fixed(mod, P, k, wi, n, e1, e2, _split(R[todo], m), nq).reshape(len(todo), m * m).sum(1)
        done = np.abs(sub - prev[todo]) <= np.maximum(rtol * np.abs(sub), 1e-10)
        prev[todo] = sub
        todo = todo[~done]
        if len(todo) == 0:
            break
    return prev


def _bin_counts(rects, mu, phi):
    """Counts per rectangle; the rectangles are bands in mu, each cut in phi (half-open, closed at mu = 1 and
    phi = pi), tiling the sphere."""
    R = np.asarray(rects, float)
    obs = np.zeros(len(R), np.int64)
    bands = np.unique(R[:, :2], axis=0)
    for a, b in bands:
        inb = (mu >= a) & ((mu <= b) if b == 1.0 else (mu < b))
        idx = np.nonzero((R[:, 0] == a) & (R[:, 1] == b))[0]
        idx = idx[np.argsort(R[idx, 2])]
        edges = np.concatenate((R[idx, 2], [R[idx[-1], 3]]))
        j = np.clip(np.searchsorted(edges, phi[inb], side="right") - 1, 0, len(idx) - 1)
        obs[idx] += np.bincount(j, minlength=len(idx))
    return obs


def _classify(out, n, e1, e2):
    d = out[:, :3]
    other = (out[:, 4] > 0) | (out[:, 5] <= 0)
    mu = np.clip(d @ n, -1, 1)
    phi = np.arctan2(d @ e2, d @ e1)
    return mu, phi, other


@pytest.mark.parametrize("label,theta", CHI_PARAMS)
def test_sampled_directions_follow_pdf(label, theta):
    mod, P, k = case(label)
    wi, n, e1, e2 = geometry(theta)
    seed = 1000 + 17 * CASES.index(next(c for c in CASES if c[0] == label)) + int(theta)
    if mod.KIND == "TABLE":
        rects = _table_bins(mod, P, k)
    else:
        pilot = run_samples(mod, P, k, wi, n, N_PILOT, seed + 500_000)
        mu, phi, other = _classify(pilot, n, e1, e2)
        rects = _bins_from_pilot(mu[~other], phi[~other])
    probs = _rect_probs(mod, P, k, wi, n, e1, e2, rects)
    out = run_samples(mod, P, k, wi, n, N_SAMPLES, seed)
    mu, phi, other = _classify(out, n, e1, e2)
    obs = _bin_counts(rects, mu[~other], phi[~other])
    assert obs.sum() == np.count_nonzero(~other), "a sampled direction fell outside every bin"
    exp = probs * N_SAMPLES
    p_other = 1.0 - probs.sum()
    n_other = int(other.sum())
    assert p_other > -2e-4, f"pdf integrates to {probs.sum():.8f} > 1"   # bins integrated to rtol 1e-4
    keep = exp >= 5
    assert obs[~keep].sum() <= max(10, 3 * exp[~keep].sum() + 10), "samples where pdf is (almost) zero"
    o = np.concatenate((obs[keep], [obs[~keep].sum() + n_other]))
    e = np.concatenate((exp[keep], [exp[~keep].sum() + max(p_other, 0.0) * N_SAMPLES]))
    if e[-1] < 5:
        assert o[-1] <= 10 + 3 * e[-1], f"{o[-1]} samples outside the density where {e[-1]:.2f} are expected"
        o, e = o[:-1], e[:-1]
    chi2 = float(np.sum((o - e) ** 2 / e))
    df = len(o) - 1
    pval = stats.chi2.sf(chi2, df)
    assert pval > ALPHA_EACH, f"chi2 = {chi2:.1f} for {df} dof (p = {pval:.3g}); worst bins " \
                              f"{np.argsort(-(o - e) ** 2 / e)[:5]}"


# ---------------------------------------------------------------- weights, pdf normalization, energy
@pytest.mark.parametrize("label", [c[0] for c in CASES])
@pytest.mark.parametrize("theta", ANGLES + [88.0])
def test_weight_is_f_cos_over_pdf(label, theta):
    mod, P, k = case(label)
    wi, n, _, _ = geometry(theta, tilt=True)
    out = run_samples(mod, P, k, wi, n, 20_000, 77)
    assert np.all(np.isfinite(out)), "NaN or inf from sample/pdf/eval"
    assert np.all(out[:, 3] >= 0)
    assert np.allclose(np.linalg.norm(out[:, :3], axis=1), 1.0, atol=1e-12)
    delta = out[:, 4] > 0
    ok = ~delta & (out[:, 5] > 0)
    cos_o = np.abs(out[ok, :3] @ n)
    np.testing.assert_allclose(out[ok, 3], out[ok, 6] * cos_o / out[ok, 5], rtol=1e-9, atol=1e-300)
    lost = ~delta & (out[:, 5] <= 0)
    assert np.all(out[lost, 3] == 0.0), "a sample outside the density must have weight 0"
    if delta.any():
        assert mod.KIND in SLABS
        np.testing.assert_allclose(out[delta, :3], np.broadcast_to(-wi, (int(delta.sum()), 3)), atol=1e-15)


@pytest.mark.parametrize("label", [c[0] for c in CASES])
@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0, 80.0])
def test_pdf_normalization_and_energy(label, theta):
    mod, P, k = case(label)
    ipdf, r_num, t_num = sphere_integrals(mod, P, k, theta, tilt=True)
    ci = math.cos(math.radians(theta))
    R, T = mod.albedo(P, k, ci)
    direct = mod.direct_transmission(P, k, ci)
    assert abs(R - r_num) <= 1e-4, f"albedo R {R:.7f} vs quadrature {r_num:.7f}"
    assert abs(T - (t_num + direct)) <= 1e-4, f"albedo T {T:.7f} vs quadrature {t_num + direct:.7f}"
    assert R + T <= 1.0 + 1e-6
    assert ipdf <= 1.0 + 1e-5
    if mod.KIND in ("LAMBERTIAN", "ROSSLI", "TABLE"):
        assert abs(ipdf - 1.0) < 1e-5
    if mod.KIND in SLABS:
        # the delta's probability is 1 - int pdf; its weight times that probability is the direct share
        wi, n, _, _ = geometry(theta, tilt=True)
        x, y, z, w_delta, is_delta = mod.sample(P, k, *wi, *n, 0.5, 0.5, 1e-300)
        assert is_delta and np.allclose((x, y, z), -wi, atol=1e-15)
        assert abs(w_delta * (1.0 - ipdf) - direct) <= 1e-5 * max(1.0, w_delta)
    if mod.KIND in ("GLINT", "ABG"):
        # the share of valid samples equals int pdf (the rest is lost with weight 0)
        wi, n, _, _ = geometry(theta, tilt=True)
        out = run_samples(mod, P, k, wi, n, 200_000, 6)
        frac = np.mean(out[:, 5] > 0)
        assert abs(frac - ipdf) < 5 * math.sqrt(max(ipdf * (1 - ipdf), 1e-6) / len(out)) + 1e-5


# ---------------------------------------------------------------- reciprocity
def _rand_dirs(rng, m, sign=1.0):
    v = rng.normal(size=(m, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    v[:, 2] = sign * np.abs(v[:, 2])
    return v


RECIPROCAL = [  # (label or text, transmission too?)
    ("LAMBERTIAN 0.4 TRANSMIT 0", False),
    ("ROSSLI ISO 0.1 VOL 0.05 GEO 0.02", False),
    ("ROSSLI ISO 0.03 VOL 0.12 GEO 0.04", False),
    ("GLINT WIND 7 m/s INDEX 1.34 ALBEDO 0", False),      # ALBEDO 0: the glint term alone
    ("RAYLEIGH TAU 0.3 ALBEDO 0.9", True),
    ("HG G 0.7 TAU 1.5 ALBEDO 0.95 ORDERS 3", True),
    ("ABG A 0.01 B 0.01 G 1.5", False),
]


@pytest.mark.parametrize("text,trans", RECIPROCAL, ids=[t.split()[0] + str(i) for i, (t, _) in enumerate(RECIPROCAL)])
def test_reciprocity(text, trans):
    """f(wi, wo) = f(wo, wi) for the reflection part; for slabs also f(wi, wo; n) = f(wo, wi; -n) in transmission.
    Not tested (does not hold in general): GLINT's water-leaving Lambert term (a function of mu_s only) and
    TABLE (reciprocal only if its data are)."""
    mod, P = build_model(text)
    rng = np.random.default_rng(3)
    wi = _rand_dirs(rng, 500)
    wo = _rand_dirs(rng, 500)
    n = np.array([0.0, 0.0, 1.0])
    for a, b in zip(wi, wo):
        f1 = mod.eval(P, 0, *a, *b, *n)
        f2 = mod.eval(P, 0, *b, *a, *n)
        assert f1 == pytest.approx(f2, rel=1e-11, abs=1e-300)
    if trans:
        wt = _rand_dirs(rng, 500, -1.0)
        for a, b in zip(wi, wt):
            f1 = mod.eval(P, 0, *a, *b, *n)
            f2 = mod.eval(P, 0, *b, *a, *(-n))
            assert f1 > 0 and f1 == pytest.approx(f2, rel=1e-11)


# ---------------------------------------------------------------- degenerate inputs
DEGENERATE = [
    "LAMBERTIAN 0 TRANSMIT 0",
    "LAMBERTIAN 1",
    "ROSSLI ISO 0 VOL 0 GEO 0",
    "ROSSLI ISO 0.2 VOL 1 GEO 1",
    "GLINT WIND 0 m/s INDEX 1 ALBEDO 0",
    "GLINT WIND 30 m/s INDEX 1.34 ALBEDO 1",
    "RAYLEIGH TAU 0 ALBEDO 0 DEPOL 0",
    "RAYLEIGH TAU 1e-12 ALBEDO 1",
    "RAYLEIGH TAU 500 ALBEDO 0",
    "HG G 0.999 TAU 0 ALBEDO 0 ORDERS 1",
    "HG G -0.999 TAU 300 ALBEDO 1 ORDERS 32",
    "HG G 0 TAU 1e-12 ALBEDO 1",
    "EDDINGTON G 0.999 TAU 0 ALBEDO 0",
    "EDDINGTON G -0.999 TAU 1e5 ALBEDO 1",
    "EDDINGTON G 0 TAU 1e-12 ALBEDO 1",
    "ABG A 0 B 1 G 0",
    "ABG A 0.0001 B 1e-8 G 3",
    "TABLE 'brdf.csv'",
]


@pytest.mark.parametrize("text", DEGENERATE)
def test_degenerate_inputs_never_nan(text):
    mod, P = build_model(text, _table_dir())
    n = np.array([0.0, 0.0, 1.0])
    cosines = [1.0, 0.5, 1e-3, 1e-12, 1e-300, 0.0]
    dirs = []
    for c in cosines:
        s = math.sqrt(max(0.0, 1.0 - c * c))
        dirs += [(s, 0.0, c), (-s, 0.0, c), (0.0, s, c), (s, 0.0, -c), (-s, 0.0, -c)]
    us = [0.0, 1e-300, 1e-9, 0.5, 1.0 - 1e-16, 1.0]
    for k in range(P.shape[1]):
        for wi in dirs:
            if wi[2] < 0:
                continue
            ci = wi[2]
            R, T = mod.albedo(P, k, ci)
            d = mod.direct_transmission(P, k, ci)
            assert all(math.isfinite(x) and x >= 0 for x in (R, T, d)), (wi, R, T, d)
            for wo in dirs:
                f = mod.eval(P, k, *wi, *wo, *n)
                p = mod.pdf(P, k, *wi, *wo, *n)
                assert math.isfinite(f) and f >= 0, (wi, wo, f)
                assert math.isfinite(p) and p >= 0, (wi, wo, p)
            for u0 in us:
                for u1 in (0.0, 0.3, 1.0):
                    for u2 in us:
                        x, y, z, w, dl = mod.sample(P, k, *wi, *n, u0, u1, u2)
                        assert all(math.isfinite(v) for v in (x, y, z, w)) and w >= 0, (wi, u0, u1, u2, x, y, z, w)


@pytest.mark.parametrize("label", [c[0] for c in CASES])
@pytest.mark.parametrize("theta", [0.0, 60.0])
def test_delta_prob_is_the_share_of_delta_samples(label, theta):
    """A model's ``delta_prob`` (hero wavelengths weigh a sampled delta by it: docs/tracer.md) is the probability
    with which its ``sample`` returns a delta: the share of deltas among 20,000 samples within 5 binomial sigma
    (and exactly 0 for a model without one, whose delta_prob is the default)."""
    from irtlang.plugins.bsdfs._common import no_delta

    mod, P, k = case(label)
    wi, n, _, _ = geometry(theta)
    out = run_samples(mod, P, k, wi, n, 20000, 31)
    share = float(out[:, 4].mean())
    dp = getattr(mod, "delta_prob", no_delta)
    p = float(dp(P, k, float(wi @ n)))
    assert abs(share - p) <= 5 * math.sqrt(max(p * (1 - p), 1e-12) / 20000) + 1e-12, (share, p)
    if mod.KIND not in SLABS:
        assert share == 0.0 and p == 0.0


@pytest.mark.parametrize("label", [c[0] for c in CASES])
def test_albedo_parts_are_the_three_calls_bit_for_bit(label):
    """A model's optional ``albedo_parts`` (hero wavelengths call it per line at every slab crossing) returns
    (albedo's R, albedo's T, direct_transmission, delta_prob) exactly, at cosines down to grazing and below
    MU_MIN (a regression guard on an optimization, not a physics oracle: the physics of each part is tested
    above).  The kernel's default for a model without it calls the three."""
    from irtlang.plugins.bsdfs._common import no_delta

    mod, P, k = case(label)
    if not hasattr(mod, "albedo_parts"):
        assert mod.KIND not in ("RAYLEIGH", "HG", "EDDINGTON"), "the slabs carry albedo_parts"
        return
    dp = getattr(mod, "delta_prob", no_delta)
    for ci in (1.0, 0.9, 0.5, 0.13, 1e-3, 1e-6, 1e-9, 0.0):
        for kk in range(P.shape[1]):
            got = mod.albedo_parts(P, kk, ci)
            want = (*mod.albedo(P, kk, ci), mod.direct_transmission(P, kk, ci), dp(P, kk, ci))
            assert got == want, (ci, kk, got, want)
