"""The irtlang ray-file format (HDF5 schema 1, docs/rayfile.md): it lives in :mod:`irtlang.io.rayfile`, the
file stage of irtlang; this module re-exports it for the analysis package and its users."""

from irtlang.io.rayfile import FLAGS, SCHEMA, SCHEMA_VERSION, Detector, RayFile, read_rays, write_rays_v1

__all__ = ["SCHEMA", "SCHEMA_VERSION", "FLAGS", "Detector", "RayFile", "read_rays", "write_rays_v1"]
