"""A hand-written Numba kernel of the Cassegrain in benchmarks/cassegrain_plain.inr: the baseline the
script-driven tracer is measured against (same geometry, same source sampling, same Philox numbers, same
detector tally), written the way one would write a one-off sequential trace: primary, secondary, focal plane
in fixed order, no dispatch, no ledger."""
import math

import numba
import numpy as np

from irtlang.kernels.geometry import conic_normal, hit_conic
from irtlang.kernels.rng import uniform2
from irtlang.kernels.sampling import uniform_disk


@numba.njit(cache=True, parallel=True)
def trace_cassegrain(n, seed, z_src, r_src, c1, k1, r1_in, r1_out, z2, c2, k2, r2, z_obs, r_obs, z_fpa, half,
                     npix, img):
    """n rays, collimated along -z from a random disk of radius r_src at z_src; img (npix, npix) += flux.
    Returns the flux on the focal plane (per-thread partial images are summed by the caller's reduction)."""
    nth = img.shape[0]
    w = 1.0 / n
    nchunk = nth
    per = (n + nchunk - 1) // nchunk
    empty = np.zeros(0)
    for c in numba.prange(nchunk):
        for i in range(c * per, min(n, (c + 1) * per)):
            u0, u1 = uniform2(seed, i, 0, 0)
            x, y = uniform_disk(u0, u1)
            ox = r_src * x
            oy = r_src * y
            oz = z_src
            dx = 0.0
            dy = 0.0
            dz = -1.0
            # obscuration (secondary mount)
            t = (z_obs - oz) / dz
            if (ox + t * dx) ** 2 + (oy + t * dy) ** 2 <= r_obs * r_obs:
                continue
            # primary
            t1, t2 = hit_conic(ox, oy, oz, dx, dy, dz, c1, k1, empty)
            t = t1 if t1 > 1e-9 else t2
            if not math.isfinite(t):
                continue
            px = ox + t * dx
            py = oy + t * dy
            pz = oz + t * dz
            rr = math.hypot(px, py)
            if rr < r1_in or rr > r1_out:
                continue
            nx, ny, nz = conic_normal(px, py, c1, k1, empty)
            ci = -(dx * nx + dy * ny + dz * nz)
            dx += 2 * ci * nx
            dy += 2 * ci * ny
            dz += 2 * ci * nz
            # secondary (local frame: vertex at z2)
            t1, t2 = hit_conic(px, py, pz - z2, dx, dy, dz, c2, k2, empty)
            t = t1 if t1 > 1e-9 else t2
            if not math.isfinite(t):
                continue
            sx = px + t * dx
            sy = py + t * dy
            sz = pz - z2 + t * dz
            if math.hypot(sx, sy) > r2:
                continue
            nx, ny, nz = conic_normal(sx, sy, c2, k2, empty)
            ci = -(dx * nx + dy * ny + dz * nz)
            dx += 2 * ci * nx
            dy += 2 * ci * ny
            dz += 2 * ci * nz
            # focal plane
            t = (z_fpa - (sz + z2)) / dz
            fx = sx + t * dx
            fy = sy + t * dy
            if abs(fx) <= half and abs(fy) <= half:
                ix = min(npix - 1, int((fx + half) / (2 * half) * npix))
                iy = min(npix - 1, int((fy + half) / (2 * half) * npix))
                img[c, iy, ix] += w * 0.91 * 0.91
