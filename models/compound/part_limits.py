"""Bounds on the geometry of parts, checked on the raw part tables before anything is built.

A part's cost grows with its size in vertices: a frustum of ``sides`` has ``2 sides`` corners, a
hull of k points up to k, and building its hull tables and testing it against another part
grow with them (a hull keeps a (V, V) edge table). Parts given by an untrusted client (the
HTTP API's inline ``parts``) are therefore counted first, from the tables as given, and
refused with the field and the limit named (:class:`LimitExceeded`) before a hull is built.

A scene file is trusted but may name mesh files only inside its own folder
(:attr:`PartLimits.mesh_folder`); an inline part may not name a file at all (its mesh is data).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from impactnet.models.scene_fields import SceneError

#: Corners of the fixed-size shapes.
BOX_VERTICES = 8
WEDGE_VERTICES = 8
#: Bytes of mesh data per base64 character (4 characters carry 3 bytes).
BASE64_BYTES_PER_CHAR = 0.75


class LimitExceeded(SceneError):
    """A count in the part tables passes a limit; ``limit`` names the limit (a setting)."""

    def __init__(self, source: str, path: str, reason: str, limit: str) -> None:
        self.limit = limit
        super().__init__(source, path, reason)


@dataclass(frozen=True)
class PartLimits:
    """What parts may hold. None: unbounded (scene files); the service sets every bound."""

    max_parts: int | None = None  # parts of one body (setting max_inline_parts)
    max_frustum_sides: int | None = None  # a frustum's `sides` (max_frustum_sides)
    max_hull_points: int | None = None  # points of a `points` part (max_hull_points)
    max_section_points: int | None = None  # a prism's section corners (max_section_points)
    max_mesh_bytes: int | None = None  # decoded bytes of one inline mesh (max_mesh_bytes)
    max_mesh_vertices: int | None = None  # vertices of one mesh as loaded (max_mesh_vertices)
    max_mesh_faces: int | None = None  # triangles of one mesh as loaded (max_mesh_faces)
    max_vertices: int | None = None  # corners of all parts counted together (max_inline_vertices)
    max_name_chars: int | None = None  # characters of a part's name (the names go in answers)
    mesh_folder: Path | None = None  # the folder mesh files may be read from; None: no files


def _over(value: int, cap: int | None) -> bool:
    return cap is not None and value > cap


def _count(value) -> int:
    """Entries of a list (0 for anything else: the part's parser refuses it)."""
    return len(value) if isinstance(value, list) else 0


def _vertices(shape: str, value, where: str, limits: PartLimits, source: str) -> int:
    """Corners of one part's shape table as given, after checking its own counts."""
    checks = []
    if shape == "frustum" and isinstance(value, Mapping):
        sides = value.get("sides")
        sides = sides if isinstance(sides, int) and not isinstance(sides, bool) else 0
        checks.append((f"{where}.sides", sides, limits.max_frustum_sides, "max_frustum_sides"))
        corners = 2 * max(sides, 0)
    elif shape == "points":
        corners = _count(value)
        checks.append((where, corners, limits.max_hull_points, "max_hull_points"))
    elif shape == "prism" and isinstance(value, Mapping):
        section = _count(value.get("section"))
        checks.append((f"{where}.section", section, limits.max_section_points,
                       "max_section_points"))
        corners = 2 * section
    elif shape == "mesh" and isinstance(value, Mapping):
        data = value.get("data")
        size = int(len(data) * BASE64_BYTES_PER_CHAR) if isinstance(data, str) else 0
        checks.append((f"{where}.data", size, limits.max_mesh_bytes, "max_mesh_bytes"))
        corners = 0  # counted once the mesh is loaded (check_mesh)
    else:
        corners = BOX_VERTICES if shape == "box" else WEDGE_VERTICES if shape == "wedge" else 0
    for field, count, cap, name in checks:
        if _over(count, cap):
            raise LimitExceeded(source, field, f"{count} is more than {name} ({cap})", name)
    return corners


def check_counts(parts, path: str, limits: PartLimits, source: str) -> int:
    """The corners of the part tables ``parts`` (a list of tables at ``path``), after checking
    every count against ``limits``; raises :class:`LimitExceeded` naming the field."""
    if not isinstance(parts, list):
        return 0
    if _over(len(parts), limits.max_parts):
        raise LimitExceeded(source, path, f"{len(parts)} parts, more than max_inline_parts "
                            f"({limits.max_parts})", "max_inline_parts")
    total = 0
    for k, part in enumerate(parts):
        if not isinstance(part, Mapping):
            continue
        name = part.get("name")
        if isinstance(name, str) and _over(len(name), limits.max_name_chars):
            raise LimitExceeded(source, f"{path}[{k}].name", f"{len(name)} characters, more "
                                f"than part_name_chars ({limits.max_name_chars})",
                                "part_name_chars")
        for shape, value in part.items():
            if shape != "name":
                total += _vertices(shape, value, f"{path}[{k}].{shape}", limits, source)
    check_total(total, path, limits, source)
    return total


def check_total(total: int, path: str, limits: PartLimits, source: str) -> None:
    """Refuse ``total`` corners of parts when they pass ``limits.max_vertices``."""
    if _over(total, limits.max_vertices):
        raise LimitExceeded(source, path, f"the parts have {total} corners, more than "
                            f"max_inline_vertices ({limits.max_vertices})", "max_inline_vertices")


def check_mesh(vertices: int, faces: int, where: str, limits: PartLimits, source: str) -> None:
    """Refuse a loaded mesh of more ``vertices`` or ``faces`` than ``limits`` allow."""
    for count, cap, name in ((vertices, limits.max_mesh_vertices, "max_mesh_vertices"),
                             (faces, limits.max_mesh_faces, "max_mesh_faces")):
        if _over(count, cap):
            raise LimitExceeded(source, where, f"the mesh has {count}, more than {name} "
                                f"({cap})", name)


def mesh_file(name: str, limits: PartLimits, where: str, source: str) -> Path:
    """The path of a mesh file named in a part table: inside ``limits.mesh_folder`` (symbolic
    links resolved), or refused. The message never says whether a path exists."""
    folder = limits.mesh_folder
    if folder is None:
        raise SceneError(source, where, "a mesh here is data: {format, data} with the file's "
                         "bytes in base64; file names are not accepted")
    root = folder.resolve()
    path = (root / name).resolve()
    if not path.is_relative_to(root):
        raise SceneError(source, where, f"mesh file {name!r} is outside the scene's folder; "
                         "a scene names mesh files in its own folder only")
    return path
