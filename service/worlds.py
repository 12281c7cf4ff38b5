"""Registered static worlds (POST /v2/worlds): the bodies a simulator never moves (the yard,
the cell guides), decoded once and kept by a name, so that a frame sends only what moved.

A world's name is ``w-`` and a digest of its decoded bodies and of the scene they were decoded
in, so the same world registered again, as JSON or npz, on any replica, gets the same name; a
replica keeps the :attr:`~Settings.max_worlds` most recently used, and a frame naming one it
does not hold gets 409 ``unknown_world`` (the client then registers it again).
"""
from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

import numpy as np
import orjson

from impactnet.models.frame import Bodies
from impactnet.service.errors import ServiceError

#: Hex digits of a world's name (80 bits: no two worlds of a fleet's lifetime meet).
NAME_HEX = 20


def world_name(bodies: Bodies, scene_hash: str | None) -> str:
    """The name of a world's decoded bodies (module docstring): their ids, shapes (a scene
    object's name, else its parts), poses and filters, and the scene's hash."""
    digest = hashlib.sha256(orjson.dumps({
        "scene": scene_hash, "ids": list(bodies.ids),
        "shapes": [s.name if s.name is not None else repr(tuple(s.parts)) for s in bodies.shapes],
    }))
    for array in (bodies.shape, bodies.position, bodies.quaternion, bodies.contype,
                  bodies.conaffinity):
        digest.update(np.ascontiguousarray(array).tobytes())
    return "w-" + digest.hexdigest()[:NAME_HEX]


class UnknownWorld(ServiceError):
    """409: a frame names a world this replica does not hold."""

    def __init__(self, name: str) -> None:
        super().__init__(409, "unknown_world", f"world {name!r} is not registered on this "
                         "replica (never, or forgotten since): POST /v2/worlds its bodies "
                         "again and retry", world=name)


class Worlds:
    """The registered worlds of a replica, the least recently used forgotten first."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self._worlds: OrderedDict[str, Bodies] = OrderedDict()
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._worlds)

    def add(self, name: str, bodies: Bodies) -> None:
        """Keep ``bodies`` as world ``name`` (marked static)."""
        static = Bodies(bodies.ids, bodies.shapes, bodies.shape, bodies.position,
                        bodies.quaternion, bodies.contype, bodies.conaffinity,
                        [True] * len(bodies))
        with self._lock:
            self._worlds[name] = static
            self._worlds.move_to_end(name)
            while len(self._worlds) > self.capacity:
                self._worlds.popitem(last=False)

    def get(self, name: str) -> Bodies:
        """The world ``name`` (409 :class:`UnknownWorld` if not held)."""
        with self._lock:
            world = self._worlds.get(name)
            if world is None:
                raise UnknownWorld(name)
            self._worlds.move_to_end(name)
            return world

    def holds(self, name: str) -> bool:
        with self._lock:
            return name in self._worlds
