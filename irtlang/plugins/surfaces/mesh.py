"""MESH 'file' [SCALE s]

A triangle mesh read with trimesh (STL, OBJ, PLY, OFF, GLB, ...); `file` is relative to the script's folder.
Vertex coordinates are in the script's length unit, times SCALE.  A closed mesh's normals point outward.

| parameter | unit | meaning |
|---|---|---|
| file | path | mesh file |
| SCALE | 1 | scale factor on the vertex coordinates (default 1) |
"""
import math

import numba

import numpy as np

from ...core.diagnostics import error
from ...kernels.bvh import build_bvh, hit_mesh
from ...kernels.layout import MI_NODE_N, MI_NODE_OFF, MI_TRI_N, MI_TRI_OFF, SI_MESH
from ...lang.spec import Clause, Form, Path, V, positive
from ...core.units import NONE
from ...model.scene import Surface, IDENTITY

KIND = "MESH"
FORM = Form((Path("file"),), (Clause("SCALE", (V("scale", NONE, check=positive),), doc="scale factor"),))
EXAMPLE = None  # needs a mesh file; examples_scripts/mesh_object.inr shows one
FEATURE = "mesh"
BOUNDS_PAD = (1e-9, 1e-12)


def build(b, ctx) -> Surface:
    path = ctx.input_path(b["file"], b.span_of("file"))
    try:
        import trimesh

        mesh = trimesh.load(str(path), force="mesh", process=True)
    except Exception as e:  # trimesh raises many kinds on a broken file
        # the reader's own message is not shown: it may quote what the file holds (issue 21)
        raise error(b.span_of("file"), f"cannot read mesh '{b['file']}': not a mesh file trimesh can read "
                    f"({type(e).__name__})", "STL, OBJ, PLY, OFF, GLB, ...") from None
    if mesh is None or len(getattr(mesh, "faces", ())) == 0:
        raise error(b.span_of("file"), f"mesh '{b['file']}' has no triangles")
    scale = b.get("scale", 1.0) * ctx.length_factor()
    p = {"file": str(path), "scale": scale, "n_triangles": int(len(mesh.faces)),
         "closed": bool(mesh.is_watertight), "vertices": mesh.vertices * scale, "faces": mesh.faces.copy()}
    return Surface(KIND, p, IDENTITY, None, b.span)


# ---- packing and the kernel (the contract: irtlang/plugins/surfaces/__init__.py) ----
def pack(s: Surface) -> dict:
    """No parameters: the triangles go to the scene's concatenated BVHs (Surfaces.mesh row SI_MESH)."""
    return {"mesh": build_bvh(s.params["vertices"], s.params["faces"])}


def bounds(s: Surface) -> tuple:
    v = s.params["vertices"]
    lo, hi = v.min(0), v.max(0)
    c = 0.5 * (lo + hi)
    return (*c, 0.5 * float(np.linalg.norm(hi - lo)))


def size(s: Surface) -> float:
    return float(np.ptp(s.params["vertices"], axis=0).max())


@numba.njit(cache=True, inline="always")
def hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    """The nearest triangle past tmin (the ray may meet the mesh again at once: no root is dropped); the face
    is its row in the scene's triangle tables."""
    m = si[j, SI_MESH]
    a0 = S.mesh[m, MI_NODE_OFF]
    a1 = a0 + S.mesh[m, MI_NODE_N]
    b0 = S.mesh[m, MI_TRI_OFF]
    b1 = b0 + S.mesh[m, MI_TRI_N]
    t, face, _u, _v = hit_mesh(ox, oy, oz, dx, dy, dz, tmin, S.bmin[a0:a1], S.bmax[a0:a1], S.child[a0:a1],
                               S.count[a0:a1], S.tris[b0:b1], S.ids[b0:b1])
    return t, math.inf, (b0 + face if face >= 0 else -1)


@numba.njit(cache=True, inline="always")
def normal(f, si, S, j, x, y, z, face):
    if face < 0:
        return 0.0, 0.0, 1.0
    return S.fn[face, 0], S.fn[face, 1], S.fn[face, 2]
