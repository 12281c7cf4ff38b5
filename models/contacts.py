"""The result type shared by every predictor: `Contacts`, arrays over N pairs.

Conventions (see docs/design.md): metres, world frame; ``normal`` points from A towards B (the
direction in which B must move to separate); ``depth`` >= 0 is the penetration along
``normal``; ``point`` lies on the mid-surface between the bodies.

Codes
-----
``contact_type_code`` indexes :data:`CONTACT_TYPES` (0 = no contact). ``axis`` is the
separating-axis index: 0-2 face normal i of A, 3-5 face normal j of B, ``6 + 3 i + j`` the
cross product of A's edge direction i with B's edge direction j. Features use the unified ids
of :mod:`impactnet.models.geometry.box_features` (faces 0-5, edges 6-17, vertices 18-25, -1 none).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Contact type names, indexed by ``Contacts.contact_type_code``; first word is A's feature.
CONTACT_TYPES = (
    "none",
    "vertex-face",
    "face-vertex",
    "edge-edge",
    "edge-face",
    "face-edge",
    "face-face",
)
CONTACT_TYPE_CODES = {name: code for code, name in enumerate(CONTACT_TYPES)}
NONE, VERTEX_FACE, FACE_VERTEX, EDGE_EDGE, EDGE_FACE, FACE_EDGE, FACE_FACE = range(7)

#: The rule that defines ``point`` and its version, reported by the service's ``GET /v1/models``
#: under ``conventions`` so that a client can check what it gets (CHANGELOG.md). Version 1 was
#: the depth-weighted mean of the manifold's vertices; version 2 is the centre of pressure of the
#: overlap footprint (docs/design.md, :mod:`impactnet.models.box.kernel_pressure`).
POINT_RULE = "centre-of-pressure"
POINT_RULE_VERSION = 2

#: Maximum number of manifold points (a quad clipped by a rectangle has at most 8 vertices).
MAX_MANIFOLD_POINTS = 8


@dataclass
class Contacts:
    """Contacts of N box pairs; every array has N rows, separated rows carry no NaN.

    Attributes
    ----------
    colliding : ndarray of bool, shape (n,)
        True where the boxes overlap or touch (penetration >= 0).
    normal : ndarray of float64, shape (n, 3)
        Unit contact normal, world frame, from A towards B. For separated rows: the
        separating axis of largest separation, oriented from A towards B.
    depth : ndarray of float64, shape (n,)
        Penetration depth along ``normal`` in metres; 0 for separated rows.
    point : ndarray of float64, shape (n, 3)
        Impact point in the world frame, metres: the centre of pressure on the mid-surface
        (docs/design.md); the midpoint of the two centres for separated rows.
    contact_type_code : ndarray of int8, shape (n,)
        Index into :data:`CONTACT_TYPES`.
    feature_a, feature_b : ndarray of int8, shape (n,)
        Unified feature ids (see :mod:`impactnet.models.geometry.box_features`) of A and B; -1 when
        separated.
    axis : ndarray of int8, shape (n,)
        Separating-axis index of the contact normal (see module docstring).
    manifold_points : ndarray of float64, shape (n, 8, 3)
        Contact manifold on the mid-surface, world frame; rows past ``manifold_count`` are 0.
    manifold_depths : ndarray of float64, shape (n, 8)
        Penetration depth of each manifold point in metres; padding rows are 0.
    manifold_count : ndarray of int8, shape (n,)
        Number of valid manifold points (0 when separated, 1 for edge-edge).
    confidence : ndarray of float64, shape (n,)
        1 for the exact solver; a learned predictor's calibrated confidence in [0, 1].
    predictor : ndarray of str, shape (n,)
        Name of the predictor that answered each row.
    pressure : ndarray of float64, shape (n,)
        The integral of the pressure over a face contact's region, ``int (d + tau) dA`` in m^3
        (``tau`` the depth floor of :mod:`impactnet.models.box.tolerances`): a part contact's
        weight in a compound body's summary. 0 for edge-edge contacts, separated rows and
        learned answers.
    """

    colliding: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    point: np.ndarray
    contact_type_code: np.ndarray
    feature_a: np.ndarray
    feature_b: np.ndarray
    axis: np.ndarray
    manifold_points: np.ndarray
    manifold_depths: np.ndarray
    manifold_count: np.ndarray
    confidence: np.ndarray = field(default=None)  # filled with ones when not given
    predictor: np.ndarray = field(default=None)  # filled with "exact" when not given
    pressure: np.ndarray = field(default=None)  # int (d + tau) dA (m^3); zeros when not given

    def __post_init__(self) -> None:
        n = self.depth.shape[0]
        if self.confidence is None:
            self.confidence = np.ones(n)
        if self.predictor is None:
            self.predictor = np.full(n, "exact")
        if self.pressure is None:
            self.pressure = np.zeros(n)

    def __len__(self) -> int:
        return int(self.depth.shape[0])

    @property
    def contact_type(self) -> np.ndarray:
        """Contact type names, shape (n,), e.g. ``"vertex-face"``; ``"none"`` if separated."""
        return np.asarray(CONTACT_TYPES)[self.contact_type_code]

    def row(self, i: int) -> Contacts:
        """The i-th pair as a one-row `Contacts` (shapes keep their leading axis of 1)."""
        return self.take(np.array([i]))

    def take(self, index: np.ndarray) -> Contacts:
        """Rows selected by an integer or boolean index array, as a new `Contacts`."""
        return Contacts(**{name: value[index] for name, value in self.arrays().items()})

    @classmethod
    def one_row(cls, floats: list, ints: list, colliding: bool, predictor: str,
                pressure: float = 0.0) -> Contacts:
        """A one-row `Contacts` from two flat lists, with two allocations instead of a dozen
        (NumPy's per-call cost dominates a single pair).

        Parameters
        ----------
        floats : list of float, length 7 + 4 * MAX_MANIFOLD_POINTS + 1
            normal (3), point (3), depth, manifold points (8 x 3, row-major, zero padded),
            manifold depths (8, zero padded), confidence.
        ints : list of int, length 5
            contact type code, feature_a, feature_b, axis, manifold count.
        colliding : bool
        predictor : str
            Name of the predictor that answered.
        pressure : float
            The pressure integral of a face contact (m^3), 0 otherwise.
        """
        values = np.array(floats)
        small = np.array(ints, np.int8)
        m = 7 + 3 * MAX_MANIFOLD_POINTS
        return cls(
            colliding=np.array([colliding]), normal=values[0:3].reshape(1, 3),
            depth=values[6:7], point=values[3:6].reshape(1, 3), contact_type_code=small[0:1],
            feature_a=small[1:2], feature_b=small[2:3], axis=small[3:4],
            manifold_points=values[7:m].reshape(1, MAX_MANIFOLD_POINTS, 3),
            manifold_depths=values[m:m + MAX_MANIFOLD_POINTS].reshape(1, -1),
            manifold_count=small[4:5], confidence=values[-1:],
            predictor=np.array([predictor]), pressure=np.array([pressure]))

    def arrays(self) -> dict[str, np.ndarray]:
        """All fields as a name -> array mapping (the arrays themselves, not copies)."""
        return {name: getattr(self, name) for name in self.__dataclass_fields__}
