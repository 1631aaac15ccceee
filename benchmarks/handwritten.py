"""A hand-written Numba kernel of the Cassegrain in benchmarks/cassegrain_plain.inr: the baseline the
script-driven tracer is measured against (same geometry, same source sampling, same Philox numbers, same
detector tally), written the way one would write a one-off sequential trace: primary, secondary, focal plane
in fixed order, no dispatch, no stack, no generality.

What it computes is what irtlang's TRACE gives for this scene, so that the comparison measures the tracer's
overhead and not a difference in outputs (benchmarks/REPORT.md):
* the focal-plane image and the image of squared per-ray deposits (the pixels' standard errors);
* the energy ledger: per object incident / reflected / absorbed flux and the sum of squared incident flux
  per source ray (the objects' standard errors), plus the emitted and the escaped flux.
It uses the same geometry primitives as irtlang's kernel (``hit_conic_plain``, ``conic_normal_plain``,
``in_annulus``, ``in_disk`` of irtlang.kernels.geometry), so a faster primitive speeds both alike.
Neither renormalizes directions after a mirror reflection (a unit normal keeps |d| = 1 to rounding); this
kernel tests each surface only where a sequential trace knows it can be hit (irtlang, non-sequential, tests
every surface on every segment).
"""
import math

import numba
import numpy as np

from irtlang.kernels.geometry import conic_normal_plain, hit_conic_plain, in_annulus, in_disk
from irtlang.kernels.rng import uniform2
from irtlang.kernels.sampling import uniform_disk

# ledger rows and columns of `tal` (per thread): the objects of cassegrain_plain.inr, then EMITTED, ESCAPED
PRIMARY, SECONDARY, MOUNT, FPA, EMITTED, ESCAPED = range(6)
INC, REF, ABS = range(3)
REFLECT = 0.91     # COATING aluminium REFLECT 0.91


@numba.njit(cache=True, parallel=True)
def _trace(n, seed, z_src, r_src, c1, k1, r1_in, r1_out, z2, c2, k2, r2, z_obs, r_obs, z_fpa, half, npix, img,
           img_sq, tal, tal_sq):
    nth = img.shape[0]
    w = 1.0 / n
    ww = w * w
    nchunk = nth
    per = (n + nchunk - 1) // nchunk
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
            tal[c, EMITTED, INC] += w
            # obscuration (secondary mount)
            t = (z_obs - oz) / dz
            if in_disk(ox + t * dx, oy + t * dy, r_obs):
                tal[c, MOUNT, INC] += w
                tal[c, MOUNT, ABS] += w
                tal_sq[c, MOUNT] += ww
                continue
            # primary
            t1, t2 = hit_conic_plain(ox, oy, oz, dx, dy, dz, c1, k1)
            t = t1 if t1 > 1e-9 else t2
            if not math.isfinite(t):
                tal[c, ESCAPED, ABS] += w
                continue
            px = ox + t * dx
            py = oy + t * dy
            pz = oz + t * dz
            if not in_annulus(px, py, r1_in, r1_out):
                tal[c, ESCAPED, ABS] += w
                continue
            tal[c, PRIMARY, INC] += w
            tal[c, PRIMARY, REF] += w * REFLECT
            tal[c, PRIMARY, ABS] += w * (1.0 - REFLECT)
            tal_sq[c, PRIMARY] += ww
            w1 = w * REFLECT
            nx, ny, nz = conic_normal_plain(px, py, c1, k1)
            ci = -(dx * nx + dy * ny + dz * nz)
            dx += 2 * ci * nx
            dy += 2 * ci * ny
            dz += 2 * ci * nz
            # secondary (local frame: vertex at z2)
            t1, t2 = hit_conic_plain(px, py, pz - z2, dx, dy, dz, c2, k2)
            t = t1 if t1 > 1e-9 else t2
            if not math.isfinite(t):
                tal[c, ESCAPED, ABS] += w1
                continue
            sx = px + t * dx
            sy = py + t * dy
            sz = pz - z2 + t * dz
            if not in_disk(sx, sy, r2):
                tal[c, ESCAPED, ABS] += w1
                continue
            tal[c, SECONDARY, INC] += w1
            tal[c, SECONDARY, REF] += w1 * REFLECT
            tal[c, SECONDARY, ABS] += w1 * (1.0 - REFLECT)
            tal_sq[c, SECONDARY] += w1 * w1
            w2 = w1 * REFLECT
            nx, ny, nz = conic_normal_plain(sx, sy, c2, k2)
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
                img[c, iy, ix] += w2
                img_sq[c, iy, ix] += w2 * w2
                tal[c, FPA, INC] += w2
                tal[c, FPA, ABS] += w2
                tal_sq[c, FPA] += w2 * w2
            else:
                tal[c, ESCAPED, ABS] += w2


def trace_cassegrain(n, seed, z_src, r_src, c1, k1, r1_in, r1_out, z2, c2, k2, r2, z_obs, r_obs, z_fpa, half, npix,
                     img, img_sq=None, tal=None, tal_sq=None):
    """n rays, collimated along -z from a random disk of radius r_src at z_src.  Per thread t (img.shape[0]
    threads' partial tallies, summed by the caller): img[t] (npix, npix) += flux, img_sq[t] += flux^2 per ray,
    tal[t] (6, 3) the ledger (rows PRIMARY .. ESCAPED, columns INC, REF, ABS), tal_sq[t] (6,) the sum of
    squared incident flux per ray.  The tallies not passed are allocated here (and computed all the same)."""
    nth = img.shape[0]
    if img_sq is None:
        img_sq = np.zeros_like(img)
    if tal is None:
        tal = np.zeros((nth, 6, 3))
    if tal_sq is None:
        tal_sq = np.zeros((nth, 6))
    _trace(n, seed, z_src, r_src, c1, k1, r1_in, r1_out, z2, c2, k2, r2, z_obs, r_obs, z_fpa, half, npix, img, img_sq,
           tal, tal_sq)
    return img, img_sq, tal, tal_sq
