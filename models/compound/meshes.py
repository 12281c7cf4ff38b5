"""Mesh files as convex parts: loaded with trimesh (STL, OBJ, GLB, ...), replaced by their
convex hull, with a warning when the hull is not the mesh (a non-convex or open mesh)."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

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
    """The convex part of the mesh file ``path``; ``where``/``source`` name the field in
    errors (:class:`SceneError`) and warnings (:class:`HullWarning`)."""
    import trimesh

    if not path.is_file():
        raise SceneError(source, where, f"no such mesh file {str(path)!r}")
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # noqa: BLE001  trimesh raises many types for a bad file
        raise SceneError(source, where, f"cannot load mesh {path.name!r}: {exc}") from None
    return _hull_part(name, mesh, path.name, where, source)


def inline_mesh_part(name: str, value, where: str, source: str) -> ConvexPart:
    """The convex part of a mesh given inline: ``{"format": "stl", "data": "<base64>"}``."""
    import base64
    import binascii
    import io

    import trimesh

    if not isinstance(value, dict) or set(value) != {"format", "data"}:
        raise SceneError(source, where, "expected {format, data}: a mesh format and its "
                         "bytes in base64")
    if value["format"] not in INLINE_FORMATS:
        raise SceneError(source, f"{where}.format", f"unknown mesh format {value['format']!r}; "
                         f"choose one of {', '.join(INLINE_FORMATS)}")
    try:
        data = base64.b64decode(str(value["data"]), validate=True)
        mesh = trimesh.load(io.BytesIO(data), file_type=value["format"], force="mesh")
    except (binascii.Error, ValueError) as exc:
        raise SceneError(source, f"{where}.data", f"not base64: {exc}") from None
    except Exception as exc:  # noqa: BLE001  trimesh raises many types for a bad file
        raise SceneError(source, f"{where}.data", f"cannot load the mesh: {exc}") from None
    return _hull_part(name, mesh, f"inline {value['format']}", where, source)


def _hull_part(name: str, mesh, label: str, where: str, source: str) -> ConvexPart:
    """The convex hull of a loaded mesh as a part (refusing degenerate meshes); ``label``
    names the mesh in messages."""
    if len(getattr(mesh, "vertices", ())) < 4:
        raise SceneError(source, where, f"mesh {label!r} has fewer than 4 vertices")
    try:
        hull = mesh.convex_hull
    except Exception as exc:  # noqa: BLE001  qhull errors on flat or degenerate meshes
        raise SceneError(source, where, f"mesh {label!r} has no convex hull (flat or "
                         f"degenerate): {str(exc).splitlines()[0]}") from None
    volume = abs(float(mesh.volume)) if mesh.is_watertight else 0.0
    if abs(float(hull.volume) - volume) > HULL_VOLUME_TOL_REL * float(hull.volume):
        warnings.warn(f"{source}: {where}: mesh {label!r} is not convex (or not closed): "
                      f"it is replaced by its convex hull ({volume:.6g} -> "
                      f"{float(hull.volume):.6g} m^3)", HullWarning, stacklevel=2)
    return ConvexPart(name, tuple(map(tuple, np.asarray(hull.vertices, np.float64))))
