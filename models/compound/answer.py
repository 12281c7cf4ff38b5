"""The library entry for compound pairs: one call, the part contacts and the body-level summary.

    from impactnet.models.compound import container, spreader, compound_answer
    answer = compound_answer(container("40ft", detail=2), [0, 0, 0], [1, 0, 0, 0],
                             spreader("40ft", sides=32), [0, 0, 1.7], [1, 0, 0, 0])
    answer.summary.depth, answer.contacts_of(0)  # per pose: deepest depth; its part contacts

Poses broadcast as for :func:`impactnet.models.compound.oracle.compound_contacts` (one pose
``(3,)``/``(4,)`` or N poses ``(n, 3)``/``(n, 4)``). Body A's and B's parts are the tuples
their generators or scene return. One call of the compiled pipeline answers both the part
contacts and the summary (:mod:`impactnet.models.compound.pipeline`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound import pipeline
from impactnet.models.compound.results import BodySummary, PartContacts, made
from impactnet.models.contacts import CONTACT_TYPES


@dataclass(frozen=True)
class CompoundAnswer:
    """The exact answer for N poses of a pair of compound bodies."""

    parts: PartContacts  # the ragged part contacts (rows of every pose, pose-major)
    summary: BodySummary  # per pose: colliding, depth, normal, point, cluster size
    names_a: tuple[str, ...]  # body A's part names, indexed by ``parts.part_a``
    names_b: tuple[str, ...]  # body B's part names, indexed by ``parts.part_b``

    def __len__(self) -> int:
        return len(self.summary.depth)

    def contacts_of(self, pose: int) -> list[dict]:
        """The part contacts of one pose as plain Python (deepest first)."""
        rows = np.arange(*self.parts.offsets[pose:pose + 2])
        c = self.parts.contacts
        rows = rows[np.argsort(-c.depth[rows], kind="stable")]
        return [{"part_a": self.names_a[self.parts.part_a[r]],
                 "part_b": self.names_b[self.parts.part_b[r]],
                 "point": c.point[r].tolist(), "normal": c.normal[r].tolist(),
                 "depth": float(c.depth[r]),
                 "contact_type": CONTACT_TYPES[c.contact_type_code[r]],
                 "feature_a": int(c.feature_a[r]), "feature_b": int(c.feature_b[r]),
                 "pressure": float(c.pressure[r]),
                 "manifold": c.manifold_points[r, :c.manifold_count[r]].tolist()}
                for r in rows]


def compound_answer(parts_a, position_a, quaternion_a, parts_b, position_b,
                    quaternion_b) -> CompoundAnswer:
    """The part contacts and summary of N poses of body A against body B.

    Parameters
    ----------
    parts_a, parts_b : tuple of BoxPart or ConvexPart
        Validated parts, body frame (metres).
    position_a, position_b : array_like, shape (3,) or (n, 3)
        Body origins, world frame (metres).
    quaternion_a, quaternion_b : array_like, shape (4,) or (n, 4)
        Orientations (w, x, y, z), normalised here.
    """
    set_a, set_b, table_a, table_b = pipeline.sets_of(parts_a, parts_b)
    rows, n = pipeline.pose_rows(position_a, quaternion_a, position_b, quaternion_b)
    parts, summary = pipeline.solved(set_a, set_b, rows, n)
    return made(CompoundAnswer, {"parts": parts, "summary": summary, "names_a": table_a.names,
                                 "names_b": table_b.names})
