"""MESH 'file' [SCALE s]

A triangle mesh read with trimesh (STL, OBJ, PLY, OFF, GLB, ...); `file` is relative to the script's folder.
Vertex coordinates are in the script's length unit, times SCALE.  A closed mesh's normals point outward.

| parameter | unit | meaning |
|---|---|---|
| file | path | mesh file |
| SCALE | 1 | scale factor on the vertex coordinates (default 1) |
"""
from ...core.diagnostics import error
from ...lang.spec import Clause, Form, Path, V, positive
from ...core.units import NONE
from ...model.scene import Surface, IDENTITY

KIND = "MESH"
FORM = Form((Path("file"),), (Clause("SCALE", (V("scale", NONE, check=positive),), doc="scale factor"),))
EXAMPLE = None  # needs a mesh file; examples_scripts/mesh_object.inr shows one


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
