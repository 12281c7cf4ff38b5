"""The exact contact oracle of two compound bodies made of box and convex parts, compiled end to
end (issue #20, step 2; issue #32).

Stages, for N poses of one pair of bodies (A with ``P_a`` parts, B with ``P_b``), each a stage
of the compiled pipeline (:mod:`impactnet.models.compound.kernel_pipeline`, scalar loops over
one pose):

1. Broadphase (:mod:`~impactnet.models.compound.kernel_broadphase`): every part's bounds (a box
   part itself, a convex part's axis-aligned bounding box in the body frame) an oriented box
   in the world with its body's rotation; the groups' bounds tested first, then the member
   part pairs of the groups that may touch, on the six face axes of the two boxes (the box
   solver's face tests without its edge axes, so nothing that touches is culled); the
   survivors are the candidates, in the order (group of A, group of B, part of A, part of B).
2. Narrowphase (:mod:`~impactnet.models.compound.kernel_narrowphase`): box part pairs through
   the box solver's row function, pairs with a convex part through the convex solver
   (:mod:`impactnet.models.compound.convex_contact`); the conventions hold for every part
   contact (normal from A's part towards B's, the centre of pressure as the point,
   docs/design.md). Features are int32: box ids for box parts, hull ids for convex ones.
3. Filter (:mod:`~impactnet.models.compound.kernel_filter`): a part contact whose touched
   surface one body covers with its other parts is dropped (a container's roof under its own
   top castings): all of its manifold points, moved from the mid-surface back onto that body's
   part, inside other parts of that body (deeper than :data:`INSIDE_MARGIN_REL` of their size).
   A contact that reaches out of the covering parts stays.
4. Summary (:mod:`~impactnet.models.compound.kernel_summary`): the body-level summary of
   docs/design.md (a cluster around the deepest contact, weighted by the integral of the depth).

The answer is ragged: :class:`PartContacts` lists the part contacts of all poses, pose-major,
with ``offsets`` (n + 1,) delimiting each pose's rows. Every sum is the NumPy oracle's that
recorded the golden answers (``tests/data/golden``), so the answers keep their bits; a pose's
answer is the same alone, in a batch of any size and in any thread.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound import pipeline
from impactnet.models.compound.flat_tables import INSIDE_MARGIN_REL
from impactnet.models.compound.pipeline import ORACLE_CHUNK, concatenated, joined
from impactnet.models.compound.results import PartContacts

__all__ = ["INSIDE_MARGIN_REL", "ORACLE_CHUNK", "PartContacts", "compound_contacts",
           "compound_touching", "concatenated", "joined", "part_pair_contacts", "solved"]


def solved(parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b):
    """(PartContacts, BodySummary) of N poses (arguments as :func:`compound_contacts`)."""
    set_a, set_b, _, _ = pipeline.sets_of(parts_a, parts_b)
    rows, n = pipeline.pose_rows(position_a, quaternion_a, position_b, quaternion_b)
    return pipeline.solved(set_a, set_b, rows, n)


def compound_contacts(parts_a, position_a, quaternion_a, parts_b, position_b,
                      quaternion_b) -> PartContacts:
    """Part contacts of N poses of body A (``parts_a``) against body B (``parts_b``).

    Parameters
    ----------
    parts_a, parts_b : tuple of BoxPart or ConvexPart
        Validated parts (:func:`impactnet.models.compound.parts.validate_parts`), body frame.
    position_a, position_b : array_like, shape (3,) or (n, 3)
        Body origins in the world (metres).
    quaternion_a, quaternion_b : array_like, shape (4,) or (n, 4)
        Body orientations (w, x, y, z), normalised here.

    Returns
    -------
    PartContacts
        The colliding part pairs of every pose, after the filter of internal contacts.
    """
    return solved(parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b)[0]


def compound_touching(parts_a, position_a, quaternion_a, parts_b, position_b,
                      quaternion_b) -> np.ndarray:
    """(n,) bool: whether any part of B touches any part of A, pose by pose (arguments as
    :func:`compound_contacts`).

    The separating-axis test alone, on the broadphase's candidates (box parts through their
    box hulls), stopping at the first pair that touches: no contact geometry and no filter of
    covered surfaces, a fraction of the oracle's cost. A covered surface lies inside another
    part of its body, which the other body's part then overlaps too, so a pose touches here iff
    the oracle finds a contact (within the contact tolerance). Data generation's first-contact
    search asks only this.
    """
    set_a, set_b, _, _ = pipeline.sets_of(parts_a, parts_b)
    rows, n = pipeline.pose_rows(position_a, quaternion_a, position_b, quaternion_b)
    return pipeline.touching(set_a, set_b, rows, n)


def given_candidates(table_a, table_b, n: int, pose, part_a, part_b):
    """(offsets (n + 1,), part_a, part_b) of candidates sorted by pose, checked (int64)."""
    pose = np.asarray(pose, np.int64)
    part_a = np.ascontiguousarray(part_a, np.int64)
    part_b = np.ascontiguousarray(part_b, np.int64)
    if len(pose) > 1 and (np.diff(pose) < 0).any():
        raise ValueError("part_pair_contacts: candidates must be sorted by pose")
    if not len(pose) == len(part_a) == len(part_b):
        raise ValueError("part_pair_contacts: pose, part_a and part_b differ in length")
    for index, bound in ((pose, n), (part_a, len(table_a.parts)), (part_b, len(table_b.parts))):
        if len(index) and (index.min() < 0 or index.max() >= bound):
            raise IndexError(f"part_pair_contacts: an index out of range [0, {bound})")
    return np.searchsorted(pose, np.arange(n + 1)).astype(np.int64), part_a, part_b


def part_pair_contacts(parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b,
                       pose, part_a, part_b) -> PartContacts:
    """The oracle's narrowphase and filter on chosen part pairs only, no broadphase: the exact
    part-pair expert of the learned path (issue #21), which names the candidates.

    Parameters
    ----------
    parts_a, parts_b, position_a, quaternion_a, position_b, quaternion_b
        As :func:`compound_contacts` (n poses).
    pose, part_a, part_b : array_like, shape (k,)
        The candidate part pairs: pose index, A's part, B's part; sorted by pose.

    Returns
    -------
    PartContacts
        The candidates that touch (after the filter of covered surfaces), pose-major, with
        ``offsets`` over the n poses: the oracle's answer whenever the candidates include every
        touching part pair (in the broadphase's order within a pose: the order of the rows).
    """
    set_a, set_b, table_a, table_b = pipeline.sets_of(parts_a, parts_b)
    rows, n = pipeline.pose_rows(position_a, quaternion_a, position_b, quaternion_b)
    found = given_candidates(table_a, table_b, n, pose, part_a, part_b)
    return pipeline.solved_given(set_a, set_b, rows, n, found)[0]
