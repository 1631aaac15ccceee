"""Helpers shared by the scatter-model plugins: albedo tables over cos_i, the single-scattering slab.

Not a plugin (no KIND): the registry never imports it by name.

Albedo tables
-------------
``albedo(P, k, cos_i)`` of the models whose hemispherical integrals have no closed form reads a table that
``pack()`` fills with quadrature.  The nodes are uniform in ``t = sqrt(mu)`` on ``[t0, 1]``
(``mu_k = t_k^2``): they crowd towards grazing incidence, where thin slabs and rough surfaces change
fastest.  ``table_interp`` interpolates with the 4-point Lagrange polynomial in ``t`` (error O(h^4)) and
holds the end values outside ``[t0^2, 1]``.

Single-scattering slab (Ryu et al. 2017, eqs. 7-8)
--------------------------------------------------
With ``mu_s = |wi.n|`` (the light) and ``mu_v = |wo.n|`` (the viewer), reflectance factors

    rho_R = w/4 P(Theta) G_R,   G_R = [1 - exp(-tau (1/mu_s + 1/mu_v))] / (mu_s + mu_v)
    rho_T = w/4 P(Theta) G_T,   G_T = [exp(-tau/mu_v) - exp(-tau/mu_s)] / (mu_v - mu_s)

and BRDF / BTDF = rho / pi.  ``G_T`` is the divided difference of ``exp(-tau/mu)`` and symmetric in
(mu_s, mu_v); ``divided_exp`` evaluates it without cancellation as
``exp(-tau/mu_hi) * tau/(mu_hi mu_lo) * phi(x)``, ``x = tau/mu_lo - tau/mu_hi >= 0``,
``phi(x) = -expm1(-x)/x`` (``phi(0) = 1``), which tends to the limit ``tau/mu^2 exp(-tau/mu)`` at
mu_v = mu_s; for x > 1 the direct quotient (no cancellation there) is used: both branches are the same
analytic function, so the switch is continuous to rounding.
"""
import functools
import math

import numba
import numpy as np

from ...kernels.polar import frame
from ...kernels.sampling import onb

MU_MIN = 1e-9          # floor on every cosine in the kernels (grazing directions never give NaN or inf)
INV_PI = 1.0 / math.pi
INV_4PI = 0.25 / math.pi


# ---------------------------------------------------------------- tables over cos_i
def table_mu_nodes(nt: int, mu_lo: float = 0.0) -> np.ndarray:
    """The cos_i nodes of an albedo table: uniform in sqrt(mu) from sqrt(mu_lo) to 1."""
    t0 = math.sqrt(mu_lo)
    t = t0 + (1.0 - t0) * np.arange(nt) / (nt - 1)
    return np.maximum(t * t, MU_MIN)


@numba.njit(cache=True, fastmath=False, inline="always")
def table_weights(nt, t0, mu):
    """Where cos_i = mu falls in a table of nt nodes (table_mu_nodes): (edge, j, l0, l1, l2, l3), edge -1 below
    the first node, +1 beyond the last (the value is that node's), else 0 and the Lagrange weights on the nodes
    j, j+1, j+2, j+3 (local coordinate s in [0, 3])."""
    t = math.sqrt(min(1.0, max(0.0, mu)))
    x = (t - t0) / (1.0 - t0) * (nt - 1)
    if x <= 0.0:
        return -1, 0, 1.0, 0.0, 0.0, 0.0
    if x >= nt - 1:
        return 1, nt - 4, 0.0, 0.0, 0.0, 1.0
    i = int(x)
    j = min(max(i - 1, 0), nt - 4)
    s = x - j
    l0 = -(s - 1.0) * (s - 2.0) * (s - 3.0) / 6.0
    l1 = s * (s - 2.0) * (s - 3.0) / 2.0
    l2 = -s * (s - 1.0) * (s - 3.0) / 2.0
    l3 = s * (s - 1.0) * (s - 2.0) / 6.0
    return 0, j, l0, l1, l2, l3


@numba.njit(cache=True, fastmath=False, inline="always")
def table_at(P, k, row0, nt, w):
    """The value of the table in rows row0 .. row0 + nt - 1 of column k at table_weights' w."""
    edge, j, l0, l1, l2, l3 = w
    if edge < 0:
        return P[row0, k]
    if edge > 0:
        return P[row0 + nt - 1, k]
    return l0 * P[row0 + j, k] + l1 * P[row0 + j + 1, k] + l2 * P[row0 + j + 2, k] + l3 * P[row0 + j + 3, k]


@numba.njit(cache=True, fastmath=False)
def table_interp(P, k, row0, nt, t0, mu):
    """Value at cos_i = mu of the table in rows row0 .. row0 + nt - 1 of column k (nodes: table_mu_nodes)."""
    return table_at(P, k, row0, nt, table_weights(nt, t0, mu))


@numba.njit(cache=True, fastmath=False)
def table_interp2(P, k, row_a, row_b, nt, t0, mu):
    """table_interp of two tables of column k at one cos_i = mu (the same nodes): the weights once."""
    w = table_weights(nt, t0, mu)
    return table_at(P, k, row_a, nt, w), table_at(P, k, row_b, nt, w)


# ---------------------------------------------------------------- slab geometry
@numba.njit(cache=True, fastmath=False)
def divided_exp(tau, m1, m2):
    """[exp(-tau/m1) - exp(-tau/m2)] / (m1 - m2) >= 0, symmetric in (m1, m2); tau/m^2 exp(-tau/m) at m1 = m2."""
    if tau <= 0.0:
        return 0.0
    hi = max(m1, m2, MU_MIN)
    lo = max(min(m1, m2), MU_MIN)
    a = tau / hi
    x = tau / lo - a
    if x > 1.0:
        return math.exp(-a) * (-math.expm1(-x)) / (hi - lo)
    phi = 1.0 if x <= 0.0 else -math.expm1(-x) / x
    return math.exp(-a) * (tau / hi) / lo * phi


@numba.njit(cache=True, fastmath=False)
def slab_geometry(tau, mu_s, mu_v, reflect):
    """G_R (reflect) or G_T: rho = w/4 P(Theta) G."""
    mu_s = max(mu_s, MU_MIN)
    mu_v = max(mu_v, MU_MIN)
    if tau <= 0.0:
        return 0.0
    if reflect:
        return -math.expm1(-tau * (1.0 / mu_s + 1.0 / mu_v)) / (mu_s + mu_v)
    return divided_exp(tau, mu_s, mu_v)


@numba.njit(cache=True, fastmath=False)
def slab_direct(tau, cos_i):
    """exp(-tau / cos_i): the unscattered share (0 at grazing incidence unless tau = 0)."""
    if tau <= 0.0:
        return 1.0
    return math.exp(-tau / max(cos_i, MU_MIN))


@numba.njit(cache=True, fastmath=False)
def slab_delta_prob(tau, w, cos_i):
    """(p_delta, q, norm, om): the probability with which sample() picks the unscattered beam, q = 1 - p_delta
    (computed without cancellation), norm = e + w (1 - e) with e = exp(-tau/mu_s), and om = 1 - e.
    p_delta = e / norm: the analog choice for w = 1; the delta's weight is then e / p_delta = norm."""
    if tau <= 0.0:
        return 1.0, 0.0, 1.0, 0.0
    x = tau / max(cos_i, MU_MIN)
    e = math.exp(-x)
    om = -math.expm1(-x)
    norm = e + w * om
    if norm <= 0.0:
        return 0.0, 0.0, 0.0, om
    return e / norm, w * om / norm, norm, om


@numba.njit(cache=True, fastmath=False)
def slab_albedo_parts(P, k, row_r, row_t, nt, t0, tau, w, cos_i):
    """A single-scattering slab's ``albedo_parts`` (its R and T tables in rows row_r.. and row_t.., optical depth
    tau, single-scattering albedo w): (R, T + e, e, p_delta) with e = exp(-tau/cos_i), each bit for bit as albedo,
    direct_transmission (slab_direct) and delta_prob (slab_delta_prob) give it, the exponential once."""
    R, T = table_interp2(P, k, row_r, row_t, nt, t0, cos_i)
    if tau <= 0.0:
        return max(R, 0.0), max(T, 0.0) + 1.0, 1.0, 1.0
    x = tau / max(cos_i, MU_MIN)
    e = math.exp(-x)
    om = -math.expm1(-x)
    norm = e + w * om
    return max(R, 0.0), max(T, 0.0) + e, e, (e / norm if norm > 0.0 else 0.0)


# ---------------------------------------------------------------- slab albedo (numpy, for pack())
def _divided_exp_np(tau, m1, m2):
    hi = np.maximum(np.maximum(m1, m2), MU_MIN)
    lo = np.maximum(np.minimum(m1, m2), MU_MIN)
    a = tau / hi
    x = tau / lo - a
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        big = np.exp(-a) * (-np.expm1(-x)) / (hi - lo)
        phi = np.where(x > 0, -np.expm1(-x) / np.where(x > 0, x, 1.0), 1.0)
        small = np.exp(-a) * (tau / hi) / lo * phi
    out = np.where(x > 1.0, big, small)
    return np.where(tau > 0, out, 0.0)


def _slab_geometry_np(tau, mu_s, mu_v, reflect):
    mu_s = np.maximum(mu_s, MU_MIN)
    mu_v = np.maximum(mu_v, MU_MIN)
    if reflect:
        return -np.expm1(-tau * (1.0 / mu_s + 1.0 / mu_v)) / (mu_s + mu_v)
    return _divided_exp_np(tau, mu_s, mu_v)


@functools.lru_cache(maxsize=512)
def _graded_nodes(mu_s: float, n_gl: int = 12, levels: int = 20):
    """Gauss-Legendre nodes and weights on (0, 1) in panels graded geometrically towards mu_s (and 1).
    (Cached: the table nodes mu_s are the same for every slab model; callers must not modify the arrays.)"""
    brk = {0.0, 1.0, mu_s}
    for lv in range(1, levels + 1):
        f = 0.5 ** lv
        brk.add(mu_s * (1.0 - f))
        brk.add(mu_s + (1.0 - mu_s) * f)
        brk.add(1.0 - f)
    b = np.array(sorted(x for x in brk if 0.0 <= x <= 1.0))
    b = b[np.concatenate(([True], np.diff(b) > 1e-15))]
    x, wq = np.polynomial.legendre.leggauss(n_gl)
    a0, a1 = b[:-1, None], b[1:, None]
    nodes = (a0 + a1) / 2 + (a1 - a0) / 2 * x[None, :]
    weights = (a1 - a0) / 2 * wq[None, :]
    return nodes.ravel(), weights.ravel()


def slab_albedo(phase_avg, tau, w, mu_nodes: np.ndarray):
    """(R_d, T_d) at each mu_s node: the scattered (non-delta) hemispherical reflectance and transmittance.

    phase_avg(mu_s, mu_v, reflect) -> azimuthal mean of the phase function (normalized to mean 1) over the
    ring of viewing directions with |wo.n| = mu_v on the reflection or transmission side.  With
    dOmega = dmu_v dphi and BRDF = rho/pi:  R_d = (w/2) int_0^1 Pbar_R G_R mu_v dmu_v  (likewise T_d).
    tau and w may be arrays (one slab each, sharing the phase function): then R_d and T_d are (n, nodes).
    """
    many = np.ndim(tau) > 0 or np.ndim(w) > 0
    tau_a, w_a = np.broadcast_arrays(np.atleast_1d(np.asarray(tau, float)), np.atleast_1d(np.asarray(w, float)))
    R = np.zeros((len(tau_a), len(mu_nodes)))
    T = np.zeros((len(tau_a), len(mu_nodes)))
    for i, ms in enumerate(mu_nodes):
        mv, wq = _graded_nodes(float(ms))
        for refl, out in ((True, R), (False, T)):
            g = _slab_geometry_np(tau_a[:, None], ms, mv[None, :], refl)
            out[:, i] = 0.5 * w_a * np.sum((wq * phase_avg(ms, mv, refl) * mv)[None, :] * g, axis=1)
    return (R, T) if many else (R[0], T[0])


CHEB_TAU_NODES = 10      # Chebyshev nodes per panel of log tau
CHEB_PANEL_DECADES = 0.5
_PANELS: dict = {}       # (phase key, w, panel, mu nodes) -> (R, T) at the panel's Chebyshev nodes


def _cheb_panel(phase_avg, key, w, q, mu_nodes):
    """R_d, T_d at the Chebyshev nodes of fixed panel q (log10 tau in [q/2, (q+1)/2]) and those nodes (ln tau).
    With a key (the phase function's identity: its kind and parameters), remembered for the session: the
    panels are the same for every model sharing the phase function and w (the Earth's 75 Rayleigh shells)."""
    k = np.arange(CHEB_TAU_NODES)
    a = q * CHEB_PANEL_DECADES * math.log(10.0)
    b = (q + 1) * CHEB_PANEL_DECADES * math.log(10.0)
    x = 0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * (2 * k + 1) / (2 * CHEB_TAU_NODES))
    mk = None
    if key is not None:
        mk = (key, float(w), int(q), len(mu_nodes), np.asarray(mu_nodes, float).tobytes())
        hit = _PANELS.get(mk)
        if hit is not None:
            return x, hit[0], hit[1]
    Rn, Tn = slab_albedo(phase_avg, np.exp(x), w, mu_nodes)
    if mk is not None:
        if len(_PANELS) > 4096:
            _PANELS.clear()
        _PANELS[mk] = (Rn, Tn)
    return x, Rn, Tn


def slab_albedo_lines(phase_avg, taus, w, mu_nodes: np.ndarray, key=None):
    """slab_albedo for many optical depths sharing one phase function and albedo w (the lines of one model):
    exact when there are few distinct taus, else computed at CHEB_TAU_NODES Chebyshev nodes on fixed panels of
    half a decade of tau (log10 tau in [q/2, (q+1)/2], q integer) and interpolated (barycentric, of log R_d and
    log T_d, smooth in log tau: agreement with the direct computation to ~1e-7 on 300-2500 nm Rayleigh and
    aerosol layers, tests/physics/test_bsdf_slab_lines.py).  key: a hashable identity of phase_avg (for
    example ("RAYLEIGH", gamma)); with it the panels are computed once per session for every model that
    shares the phase function and w (the Earth's Rayleigh shells: 75 models, 14 panels; 37 s -> 0.5 s)."""
    taus = np.asarray(taus, float)
    R = np.zeros((len(taus), len(mu_nodes)))
    T = np.zeros((len(taus), len(mu_nodes)))
    pos = taus > 0
    u, inv = np.unique(taus[pos], return_inverse=True)
    if len(u) == 0:
        return R, T
    lu = np.log(u)
    panel = np.floor(np.log10(u) / CHEB_PANEL_DECADES).astype(np.int64)
    panels = np.unique(panel)
    if len(u) <= CHEB_TAU_NODES * len(panels):
        Ru, Tu = slab_albedo(phase_avg, u, w, mu_nodes)
    else:
        from scipy.interpolate import BarycentricInterpolator

        Ru = np.zeros((len(u), len(mu_nodes)))
        Tu = np.zeros((len(u), len(mu_nodes)))
        k = np.arange(CHEB_TAU_NODES)
        # the barycentric weights of Chebyshev points of the first kind, in closed form (Berrut & Trefethen,
        # SIAM Review 2004, section 5).  Given explicitly: without them SciPy computes the weights from a random permutation of the
        # nodes (its global RandomState), which made the tables, and every Earth frame, differ in the last bits
        # from one run to the next (tests/physics/test_earth_reproducible.py)
        wts = (-1.0) ** k * np.sin((2 * k + 1) * np.pi / (2 * CHEB_TAU_NODES))
        tiny = 1e-300
        for q in panels:
            sel = panel == q
            x, Rn, Tn = _cheb_panel(phase_avg, key, w, q, mu_nodes)
            Ru[sel] = np.exp(BarycentricInterpolator(x, np.log(np.maximum(Rn, tiny)), wi=wts)(lu[sel]))
            Tu[sel] = np.exp(BarycentricInterpolator(x, np.log(np.maximum(Tn, tiny)), wi=wts)(lu[sel]))
    R[pos] = Ru[np.ravel(inv)]
    T[pos] = Tu[np.ravel(inv)]
    return R, T


@numba.njit(cache=True, fastmath=False)
def slab_scatter(wix, wiy, wiz, nx, ny, nz, mu, u, tau, ci, norm, om):
    """A slab model's scattered sample: the direction at angle acos(mu) from the propagation direction -wi,
    azimuth 2 pi u, and its weight f |cos_o| / pdf = G |cos_o| norm / om (the phase function cancels)."""
    s = math.sqrt(max(0.0, (1.0 - mu) * (1.0 + mu)))
    ph = 2.0 * math.pi * u
    t1x, t1y, t1z, t2x, t2y, t2z = onb(-wix, -wiy, -wiz)
    a = s * math.cos(ph)
    b = s * math.sin(ph)
    ox = a * t1x + b * t2x - mu * wix
    oy = a * t1y + b * t2y - mu * wiy
    oz = a * t1z + b * t2z - mu * wiz
    m = math.sqrt(ox * ox + oy * oy + oz * oz)
    ox /= m
    oy /= m
    oz /= m
    co = ox * nx + oy * ny + oz * nz
    G = slab_geometry(tau, max(ci, MU_MIN), max(abs(co), MU_MIN), co > 0.0)
    return ox, oy, oz, G * abs(co) * norm / om, False


@numba.njit(cache=True, inline="always")
def no_delta(P, k, cos_i):
    """A scatter model's ``delta_prob`` when its ``sample`` never returns a delta: 0."""
    return 0.0


# ---------------------------------------------------------------- polarization
@numba.njit(cache=True, inline="always")
def depolarize(P, k, wix, wiy, wiz, wox, woy, woz, nx, ny, nz, q, u, v, ex, ey, ez):
    """A scatter model's ``mueller`` for POLARIZATION traces when the plugin has none: the scattered light leaves
    unpolarized, with the scalar model's intensity.  The contract: (I factor relative to the scalar BSDF,
    q', u', v', e1') for incoming Stokes (1, q, u, v) referred to e (perpendicular to the incoming direction
    -wi), the outgoing state referred to e1' (perpendicular to wo); kernels/polar.py states the conventions."""
    fx, fy, fz = frame(wox, woy, woz, ex, ey, ez)
    return 1.0, 0.0, 0.0, 0.0, fx, fy, fz
