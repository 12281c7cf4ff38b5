"""Coarse contact regions of a part pair (issue #21, step 1): what the classifier names besides
the touching part pairs, at a granularity that does not grow with the parts' detail.

A part contact's *coarse region* is its contact type
(:data:`impactnet.models.contacts.CONTACT_TYPES`) and, on each part, the face of the part's
body-frame bounding box that the contact normal leaves A's part through and enters B's part through:
a box part's own face; a twistlock head's side (``+x`` ... ``-y``), top (``+z``) or base (``-z``),
however many sides its frustum has. Which of 128 frustum sides touches is the expert's business.

A region is one integer, ``type * 36 + face_a * 6 + face_b``, faces numbered as
:data:`FACE_NAMES`. Seen through a mirror of both bodies
(:data:`impactnet.models.learned.compound.groups.CORNER_MIRRORS`), a region keeps its type and both
faces flip along the mirrored axes (:func:`mirror_regions`): the canonical frame of the pooled
corner classifier.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.contacts import CONTACT_TYPES

#: The faces of an axis-aligned box, numbered 2 * axis + (1 on the negative side).
FACE_NAMES = ("+x", "-x", "+y", "-y", "+z", "-z")
N_FACES = len(FACE_NAMES)
#: Region codes per contact type (A's face x B's face).
CODES_PER_TYPE = N_FACES * N_FACES
#: One past the largest region code.
N_REGION_CODES = len(CONTACT_TYPES) * CODES_PER_TYPE


def box_face(direction: np.ndarray) -> np.ndarray:
    """(k,) int in 0-5: the face of an axis-aligned box that ``direction`` (k, 3) leaves
    through (the axis of its largest component, and that component's sign)."""
    direction = np.asarray(direction, np.float64)
    axis = np.argmax(np.abs(direction), axis=1)
    return 2 * axis + (direction[np.arange(len(direction)), axis] < 0)


def coarse_regions(type_code, normal, rotation_b) -> np.ndarray:
    """(k,) int64 region codes of part contacts.

    Parameters
    ----------
    type_code : ndarray of int, shape (k,)
        Contact types (indices into ``CONTACT_TYPES``).
    normal : ndarray, shape (k, 3)
        Contact normals in A's body frame (unit; pointing from A into B, as docs/design.md).
    rotation_b : ndarray, shape (k, 3, 3)
        B's orientation in A's frame at each contact's pose.
    """
    normal = np.asarray(normal, np.float64)
    face_a = box_face(normal)
    face_b = box_face(-np.einsum("kji,kj->ki", rotation_b, normal))  # -normal in B's frame
    return (np.asarray(type_code, np.int64) * CODES_PER_TYPE + face_a * N_FACES + face_b)


def mirror_regions(codes, mirror) -> np.ndarray:
    """Region codes seen through ``mirror`` (3,) (+-1 each, applied to both bodies): the type
    stays, each face along a mirrored axis swaps sides. An involution, like the mirror."""
    codes = np.asarray(codes, np.int64)
    flip = np.asarray(mirror, np.float64) < 0

    def seen(face):
        return np.where(flip[face // 2], face ^ 1, face)

    type_code, rest = np.divmod(codes, CODES_PER_TYPE)
    face_a, face_b = np.divmod(rest, N_FACES)
    return type_code * CODES_PER_TYPE + seen(face_a) * N_FACES + seen(face_b)


def valid_region(code: int) -> bool:
    """True for the code of a contact type other than ``none`` and two faces."""
    return CODES_PER_TYPE <= int(code) < N_REGION_CODES


def describe_region(code: int) -> dict:
    """``{"type": ..., "face_a": ..., "face_b": ...}`` of a region code, by name."""
    type_code, rest = divmod(int(code), CODES_PER_TYPE)
    return {"type": CONTACT_TYPES[type_code], "face_a": FACE_NAMES[rest // N_FACES],
            "face_b": FACE_NAMES[rest % N_FACES]}
