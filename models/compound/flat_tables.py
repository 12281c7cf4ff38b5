"""Bodies as the compiled pipeline reads them: a set of bodies' tables packed into three flat
buffers (float64, int64, bool), built once per body and cached on its
:class:`~impactnet.models.compound.body_table.BodyTable`.

A kernel call costs about 0.4 us per array it is handed, and a tuple of arrays more (a hull
table's 44 arrays, 9 us); three buffers cost almost nothing, and a kernel turns them back into
named views once per call (:mod:`impactnet.models.compound.kernel_tables`). The int buffer
opens with a directory: ``(start, stop)`` of every section (:data:`SECTIONS`) in its buffer.

A *set* holds several bodies back to back (:func:`joined_set`): parts, groups and hulls
numbered across the set (a body's parts from ``body_part[b]``, its groups from
``body_group[b]``; part p's hull is hull p), so that one launch answers rows of many pairs of
bodies, each row naming its body in each set. A body alone is a set of one
(:func:`body_set`).

Sections, per body: ``body_part``, ``body_group`` (CSR starts of its parts and groups),
``body_singleton`` (every part its own group: the broadphase's level 1 tests the parts themselves);
per group: the bounds of its parts (``group_centre``, ``group_size``, metres, body frame) and its
members (``member_start``, ``member``, ascending); per part: its bounds (``part_centre``,
``part_size``), the covered-surface filter's ``margin`` (metres), ``is_box`` and the parts whose
bounds overlap its own (``partner_start``, ``partner``); the hull table's arrays
(:class:`~impactnet.models.compound.hull_stack.HullArrays`, one hull per part); ``widest`` (the
set's largest per-body part and group counts and per-hull V, F, E, N, L: the kernels' scratch
sizes).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.hull_stack import HullArrays

#: A covered-surface point counts as inside another part of its body when it lies that far
#: (x the other part's smallest edge) inside all of its faces: far above round-off, far below
#: any part's thickness (the NumPy oracle's constant, kept).
INSIDE_MARGIN_REL = 1e-9

#: Concatenation rules of a section: plain values, CSR starts (a leading boundary, positions in
#: the section named), positions in the section named (no boundary), part indices.
PLAIN, STARTS, POSITIONS, PARTS = range(4)
#: Buffers: reals (float64), ints (int64), flags (bool).
REAL, INT, FLAG = range(3)

_BODY = (("body_part", INT, (), STARTS, "part_centre"), ("body_group", INT, (), STARTS,
                                                     "group_centre"),
         ("body_singleton", FLAG, (), PLAIN, None),
         ("group_centre", REAL, (3,), PLAIN, None), ("group_size", REAL, (3,), PLAIN, None),
         ("member_start", INT, (), STARTS, "member"), ("member", INT, (), PARTS, None),
         ("part_centre", REAL, (3,), PLAIN, None), ("part_size", REAL, (3,), PLAIN, None),
         ("margin", REAL, (), PLAIN, None), ("is_box", FLAG, (), PLAIN, None),
         ("partner_start", INT, (), STARTS, "partner"), ("partner", INT, (), PARTS, None))
#: Of the hull table: which fields are CSR starts (and of which field) or positions.
_HULL_STARTS = {"vertex_start": "vertices", "face_start": "face_normals", "edge_start": "edges",
                "node_start": "node_centre", "adjacency_start": "adjacency_vertex",
                "vertex_face_start": "vertex_face", "loop_start": "loop_vertex"}
_HULL_TRAILING = {"centre": (3,), "vertices": (3,), "face_normals": (3,),
                  "face_frames": (3, 3), "side_planes": (4,), "edges": (2,),
                  "edge_faces": (2,), "edge_arcs": (3,), "edge_angle": (4,), "edge_dir": (3,),
                  "node_centre": (3,), "node_dir": (3,)}
_HULL_FLAGS = ("convex", "climb")
_HULL_REALS = ("centre", "half_extent", "reach", "radius", "flat", "arc_min_sin", "longest_edge",
               "vertices", "face_normals", "face_offsets", "face_frames", "side_planes",
               "edge_arcs", "edge_angle", "edge_dir", "node_centre", "node_radius", "node_cos",
               "node_sin", "node_dir", "node_cone_cos", "node_cone_sin")


def _hull_section(name: str) -> tuple:
    kind = FLAG if name in _HULL_FLAGS else REAL if name in _HULL_REALS else INT
    if name in _HULL_STARTS:
        return (name, kind, (), STARTS, _HULL_STARTS[name])
    if name == "node_first":
        return (name, kind, (), POSITIONS, "tree_edge")
    return (name, kind, _HULL_TRAILING.get(name, ()), PLAIN, None)


#: Every section: (name, buffer, trailing shape, concatenation rule, the section it counts).
SECTIONS = (_BODY + tuple(_hull_section(name) for name in HullArrays._fields)
            + (("widest", INT, (), PLAIN, None),))
#: Section indices by name (the kernels' unpacking reads them in this order).
SECTION = {name: k for k, (name, *_) in enumerate(SECTIONS)}
#: The entries of ``widest``: per body parts and groups, per hull V, F, E, N, L.
WIDEST = ("parts", "groups", "V", "F", "E", "N", "L")
_DTYPES = (np.float64, np.int64, np.bool_)


@dataclass(frozen=True, eq=False)
class BodySet:
    """Bodies packed for the kernels (module docstring)."""

    reals: np.ndarray  # float64, read-only
    ints: np.ndarray  # int64, read-only: the directory, then the int sections
    flags: np.ndarray  # bool, read-only
    bodies: tuple  # the BodyTables, in order (their identities key the caches)
    parts: np.ndarray  # (B,) parts of each body

    @property
    def buffers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(reals, ints, flags)``: a kernel's arguments."""
        return self.reals, self.ints, self.flags


def _body_sections(table) -> dict[str, np.ndarray]:
    """The sections of one body (its own numbering) from its BodyTable."""
    members = [np.asarray(m, np.int64) for m in table.members]
    start, partner = table.partners
    group_centre, group_size = table.group_bounds
    hulls = table.classes.table
    out = {"body_part": np.array([0, len(table.parts)]),
           "body_group": np.array([0, len(members)]),
           "body_singleton": np.array([len(members) == len(table.parts)]),
           "group_centre": group_centre, "group_size": group_size,
           "member_start": np.cumsum([0] + [len(m) for m in members]),
           "member": np.concatenate(members), "part_centre": table.centre,
           "part_size": table.size,
           "margin": INSIDE_MARGIN_REL * table.size.min(axis=1), "is_box": table.is_box,
           "partner_start": start, "partner": partner}
    out |= {name: getattr(hulls.arrays, name) for name in HullArrays._fields}
    widest = hulls.widest
    out["widest"] = np.array([len(table.parts), len(members), widest["V"], widest["F"],
                              widest["E"], widest["N"], widest["L"]])
    return out


def _joined(sections: list[dict]) -> dict[str, np.ndarray]:
    """The sections of several bodies back to back, renumbered (module docstring)."""
    out = {}
    for name, _, trailing, rule, counted in SECTIONS:
        pieces = [np.asarray(s[name]).reshape((-1,) + trailing) for s in sections]
        if name == "widest":
            out[name] = np.max(pieces, axis=0)
            continue
        if rule in (STARTS, POSITIONS):
            totals = np.cumsum([0] + [len(s[counted]) for s in sections])
            pieces = [p + total for p, total in zip(pieces, totals)]
            if rule == STARTS:
                pieces = [pieces[0]] + [p[1:] for p in pieces[1:]]
        elif rule == PARTS:
            bases = np.cumsum([0] + [len(s["part_centre"]) for s in sections])
            pieces = [p + base for p, base in zip(pieces, bases)]
        out[name] = np.concatenate(pieces)
    return out


def _packed(sections: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three read-only buffers of the sections, the directory first in the ints."""
    buffers: tuple[list, list, list] = ([], [], [])
    sizes = [0, 2 * len(SECTIONS), 0]
    directory = np.empty(2 * len(SECTIONS), np.int64)
    for k, (name, kind, _, _, _) in enumerate(SECTIONS):
        flat = np.ascontiguousarray(sections[name], _DTYPES[kind]).reshape(-1)
        directory[2 * k], directory[2 * k + 1] = sizes[kind], sizes[kind] + len(flat)
        sizes[kind] += len(flat)
        buffers[kind].append(flat)
    buffers[INT].insert(0, directory)
    out = tuple(np.concatenate(b) if b else np.zeros(0, dtype)
                for b, dtype in zip(buffers, _DTYPES))
    for array in out:
        array.setflags(write=False)
    return out


def body_set(table) -> BodySet:
    """One body as a set (:class:`BodySet`); the caller caches it
    (:attr:`~impactnet.models.compound.body_table.BodyTable.packed`)."""
    return BodySet(*_packed(_body_sections(table)), (table,),
                   np.array([len(table.parts)], np.int64))


def joined_set(tables) -> BodySet:
    """Several bodies as one set, in order (module docstring); built per call (its bodies'
    own sections are cached)."""
    tables = tuple(tables)
    sections = [_body_sections(t) for t in tables]
    return BodySet(*_packed(_joined(sections)), tables,
                   np.array([len(t.parts) for t in tables], np.int64))
