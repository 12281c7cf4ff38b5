"""Mesh files as convex parts: loaded with trimesh (STL, OBJ, GLB, ...), replaced by their
convex hull, with a warning when the hull is not the mesh (a non-convex or open mesh)."""
from __future__ import annotations

import base64
import binascii
import io
import warnings
from pathlib import Path

import numpy as np

from impactnet.models.compound.part_limits import PartLimits, check_mesh, check_total
from impactnet.models.compound.parts import ConvexPart
from impactnet.models.scene_fields import SceneError

#: The hull stands for the mesh silently when their volumes differ by less than this fraction
#: of the hull's: far above the rounding of a convex mesh's volume (1e-12), far below a
#: visible dent.
HULL_VOLUME_TOL_REL = 1e-6


class HullWarning(UserWarning):
    """A mesh part was replaced by a convex hull that differs from it."""


#: Mesh formats accepted inline (base64 in a request).
INLINE_FORMATS = ("stl", "obj", "glb", "ply", "off")


def mesh_part(name: str, path: Path, where: str, source: str) -> ConvexPart:
    """The convex part of the mesh file ``path`` (a scene's, already checked to lie in its
    folder: :func:`impactnet.models.compound.part_limits.mesh_file`); ``where``/``source``
    name the field in errors (:class:`SceneError`) and warnings (:class:`HullWarning`)."""
    import trimesh

    if not path.is_file():
        raise SceneError(source, where, f"no such mesh file {path.name!r}")
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception:  # noqa: BLE001  trimesh raises many types for a bad file
        raise SceneError(source, where, f"cannot read mesh file {path.name!r} as a mesh "
                         "(STL, OBJ, GLB, PLY or OFF)") from None
    return _hull_part(name, mesh, path.name, where, source)


def _decoded(value, where: str, source: str) -> bytes:
    """The bytes of an inline mesh ``{"format", "data"}`` (base64)."""
    if not isinstance(value, dict) or set(value) != {"format", "data"}:
        raise SceneError(source, where, "expected {format, data}: a mesh format and its "
                         "bytes in base64")
    if value["format"] not in INLINE_FORMATS:
        raise SceneError(source, f"{where}.format", f"unknown mesh format {value['format']!r}; "
                         f"choose one of {', '.join(INLINE_FORMATS)}")
    if not isinstance(value["data"], str):
        raise SceneError(source, f"{where}.data", "expected the mesh's bytes as a base64 string")
    try:
        return base64.b64decode(value["data"], validate=True)
    except (binascii.Error, ValueError):
        raise SceneError(source, f"{where}.data", "not base64 (standard alphabet, padded)") \
            from None


def inline_mesh_part(name: str, value, where: str, source: str,
                     limits: PartLimits | None = None) -> ConvexPart:
    """The convex part of a mesh given inline: ``{"format": "stl", "data": "<base64>"}``,
    within ``limits`` (its vertices and triangles counted once loaded, before its hull)."""
    import trimesh

    data = _decoded(value, where, source)
    kind = value["format"]
    try:
        mesh = trimesh.load(io.BytesIO(data), file_type=kind, force="mesh", process=False)
    except Exception:  # noqa: BLE001  trimesh raises many types for a bad file
        mesh = None
    if mesh is None or not hasattr(mesh, "vertices") or not hasattr(mesh, "faces"):
        raise SceneError(source, f"{where}.data", f"the data is not a readable {kind} mesh")
    limits = limits or PartLimits()
    check_mesh(len(mesh.vertices), len(mesh.faces), f"{where}.data", limits, source)
    check_total(len(mesh.vertices), f"{where}.data", limits, source)
    return _hull_part(name, mesh, f"inline {kind}", where, source)


def _hull_part(name: str, mesh, label: str, where: str, source: str) -> ConvexPart:
    """The convex hull of a loaded mesh as a part (refusing non-finite and degenerate
    meshes); ``label`` names the mesh in messages."""
    vertices = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), np.float64)
    if not np.isfinite(vertices).all():
        row = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
        raise SceneError(source, where, f"mesh {label!r}: vertex {row} is not finite")
    mesh.merge_vertices()
    if len(mesh.vertices) < 4:
        raise SceneError(source, where, f"mesh {label!r} has fewer than 4 vertices (once "
                         "repeats are merged)")
    try:
        hull = mesh.convex_hull
    except Exception:  # noqa: BLE001  qhull errors on flat or degenerate meshes
        raise SceneError(source, where, f"mesh {label!r} has no convex hull (its vertices are "
                         "flat or degenerate)") from None
    volume = abs(float(mesh.volume)) if mesh.is_watertight else 0.0
    if abs(float(hull.volume) - volume) > HULL_VOLUME_TOL_REL * float(hull.volume):
        warnings.warn(f"{source}: {where}: mesh {label!r} is not convex (or not closed): "
                      f"it is replaced by its convex hull ({volume:.6g} -> "
                      f"{float(hull.volume):.6g} m^3)", HullWarning, stacklevel=2)
    return ConvexPart(name, tuple(map(tuple, np.asarray(hull.vertices, np.float64))))
