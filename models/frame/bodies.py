"""The bodies of a frame: N bodies, each an id, a shape (a box or a body of parts) and a pose,
with the contact filter (MuJoCo's ``contype`` / ``conaffinity`` bit masks) and whether it belongs
to a registered static world.

A static world (the yard, the cell guides) is a :class:`Bodies` of its own, registered once;
a frame joins it to the bodies that moved (:meth:`Bodies.joined`), so that a simulator stepping
at 1 kHz sends only those.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from impactnet.models.dispatch.shapes import Shape
from impactnet.models.geometry.rotations import quaternion_to_matrix

#: Filter bits of a body that names none (every body touches every other, as in MuJoCo).
DEFAULT_CONTYPE = 1
DEFAULT_CONAFFINITY = 1


class DuplicateBodyId(ValueError):
    """Two bodies of a frame (or of a frame and its world) share ``body_id``."""

    def __init__(self, body_id: str, index: int) -> None:
        self.body_id, self.index = body_id, index
        super().__init__(f"body id {body_id!r} is used twice")


@dataclass(frozen=True, eq=False)
class Bodies:
    """N bodies (world frame, metres, unit quaternions [w, x, y, z])."""

    ids: tuple[str, ...]  # (n,) distinct
    shapes: tuple[Shape, ...]  # the distinct shapes the bodies name
    shape: np.ndarray  # (n,) int64 index into shapes
    position: np.ndarray  # (n, 3)
    quaternion: np.ndarray  # (n, 4)
    contype: np.ndarray = field(default=None)  # (n,) int64 bit mask; None: DEFAULT_CONTYPE
    conaffinity: np.ndarray = field(default=None)  # (n,) int64; None: DEFAULT_CONAFFINITY
    static: np.ndarray = field(default=None)  # (n,) bool: of a registered world; None: none

    def __post_init__(self) -> None:
        n = len(self.ids)
        for name, default, dtype in (("contype", DEFAULT_CONTYPE, np.int64),
                                     ("conaffinity", DEFAULT_CONAFFINITY, np.int64),
                                     ("static", False, np.bool_)):
            value = getattr(self, name)
            value = np.full(n, default, dtype) if value is None else np.asarray(value, dtype)
            object.__setattr__(self, name, value)
        for name in ("shape", "position", "quaternion"):
            object.__setattr__(self, name, np.ascontiguousarray(getattr(self, name)))
        seen: dict[str, int] = {}
        for index, body_id in enumerate(self.ids):
            if seen.setdefault(body_id, index) != index:
                raise DuplicateBodyId(body_id, index)

    def __len__(self) -> int:
        return len(self.ids)

    @cached_property
    def rotation(self) -> np.ndarray:
        """(n, 3, 3) rotation matrices of the quaternions."""
        return quaternion_to_matrix(self.quaternion)

    @cached_property
    def envelopes(self) -> tuple[np.ndarray, np.ndarray]:
        """(centre (n, 3), half extents (n, 3)): each body's bounds in its own frame, m."""
        centre = np.array([s.bounds[0] for s in self.shapes]).reshape(-1, 3)
        half = np.array([s.bounds[1] for s in self.shapes]).reshape(-1, 3)
        return centre[self.shape], half[self.shape]

    def joined(self, moving: Bodies) -> Bodies:
        """This (static) world followed by ``moving``: one frame's bodies, the world's marked
        static; an id used by both raises :class:`DuplicateBodyId`."""
        shapes = self.shapes + tuple(s for s in moving.shapes if s not in self.shapes)
        slot = np.array([shapes.index(s) for s in moving.shapes], np.int64).reshape(-1)
        return Bodies(self.ids + moving.ids, shapes,
                      np.concatenate([self.shape, slot[moving.shape]]),
                      np.concatenate([self.position, moving.position]),
                      np.concatenate([self.quaternion, moving.quaternion]),
                      np.concatenate([self.contype, moving.contype]),
                      np.concatenate([self.conaffinity, moving.conaffinity]),
                      np.concatenate([np.ones(len(self), bool), moving.static]))
