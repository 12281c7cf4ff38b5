"""The scene as the service sees it: object names -> box sizes, looked up without Python loops.

Wraps :func:`impactnet.models.scenes.load_scene` (``Scene.name``, ``Scene.bodies``: Body(name,
size), ``Scene.pairs``: BodyPair(a, b), ``Scene.hash()``). A server started without a scene
(``scene=None``) accepts raw sizes only; a request that names an object then gets a 422 that says
so.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from impactnet.models.scenes import load_scene


class SceneLoadError(RuntimeError):
    """The configured scene cannot be loaded (unknown name, bad file)."""


@dataclass(frozen=True, eq=False)
class SceneView:
    """Immutable lookup table of a scene's bodies."""

    name: str | None  # scene name, None when serving without a scene
    hash: str | None  # Scene.hash() of the loaded scene
    object_names: tuple[str, ...] = ()  # sorted body names
    sizes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (k, 3) metres
    pairs: tuple[tuple[str, str], ...] = ()  # (a, b) names of the pairs that can collide
    compound_names: tuple[str, ...] = ()  # bodies made of parts (sorted)
    compound_parts: dict = field(default_factory=dict)  # name -> parts of a compound body
    compound_sizes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # envelopes
    bodies: dict = field(default_factory=dict)  # name -> what GET /v1/models shows of it

    def __post_init__(self) -> None:
        self.sizes.setflags(write=False)
        self.compound_sizes.setflags(write=False)
        object.__setattr__(self, "_index", {n: i for i, n in enumerate(self.object_names)})

    def size_of(self, name: str) -> list[float] | None:
        """Full edge lengths of one named object, or None if the scene has no such body."""
        i = self._index.get(name)
        return None if i is None else self.sizes[i].tolist()

    def index_of(self, name: str | None) -> int:
        """Index of one object name into :attr:`object_names`; -1 for None or unknown."""
        return -1 if name is None else self._index.get(name, -1)

    def lookup(self, names: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Indices into :attr:`object_names` of an array of names; -1 where unknown.

        Returns ``(index (n,), unknown_rows)``. Loops over distinct names only.
        """
        names = np.asarray(names)
        unique, inverse = np.unique(names, return_inverse=True)
        table = np.array([self._index.get(str(u), -1) for u in unique], dtype=np.int64)
        index = table[inverse.reshape(-1)]
        return index, np.flatnonzero(index < 0)

    @cached_property
    def with_compound(self) -> SceneView:
        """The same scene with its compound bodies as objects too (their envelopes as sizes),
        for parsing a request that names them; a compound object's index is at or past
        ``len(self.object_names)``."""
        if not self.compound_names:
            return self
        view = SceneView(self.name, self.hash, self.object_names + self.compound_names,
                         np.concatenate([self.sizes, self.compound_sizes]), self.pairs,
                         bodies=self.bodies)
        view.__dict__["shapes"] = self.shapes  # the same shapes, by the same indices
        return view

    @cached_property
    def shapes(self) -> tuple:
        """The shape of every object of :meth:`with_compound`, in its index order (a box object
        a box shape, a compound object its parts), named; built once."""
        from impactnet.models.dispatch.shapes import Shape

        boxes = tuple(Shape.box(size, name, transient=False)
                      for name, size in zip(self.object_names, self.sizes, strict=True))
        return boxes + tuple(Shape(self.compound_parts[name], name)
                             for name in self.compound_names)

    def parts_of(self, index: int, size) -> tuple:
        """The parts of object ``index`` of :meth:`with_compound` (a box object or a raw
        ``size``: one box part, built for this request, so kept out of the solver's shared
        caches)."""
        from impactnet.models.compound.body_table import TransientParts
        from impactnet.models.compound.parts import BoxPart

        box_count = len(self.object_names)
        if index >= box_count:
            return self.compound_parts[self.compound_names[index - box_count]]
        return TransientParts((BoxPart("box", tuple(float(v) for v in size)),))

    def describe(self) -> dict:
        return {
            "name": self.name,
            "hash": self.hash,
            "objects": {n: s for n, s in zip(self.object_names, self.sizes.tolist(), strict=True)},
            "pairs": [list(p) for p in self.pairs],
            "compound_objects": list(self.compound_names),
            "bodies": self.bodies,
        }


EMPTY_SCENE = SceneView(name=None, hash=None)


def _bodies_of(scene) -> tuple[dict, dict]:
    """(name -> size of the box bodies, name -> body of the compound bodies) of
    ``scene.bodies`` (a tuple of Body, or a name -> Body mapping)."""
    bodies = scene.bodies
    items = list(bodies.values() if isinstance(bodies, dict) else bodies)
    compound = {str(b.name): b for b in items if getattr(b, "is_compound", False)}
    return {str(b.name): b.size for b in items if str(b.name) not in compound}, compound


def _rounded(values) -> list[float]:
    """Coordinates for a client to read (micrometres)."""
    return [round(float(v), 6) for v in values]


def describe_body(body) -> dict:
    """What a client sees of a scene body: a box's size; a compound body's envelope, how it
    was made (generator and detail) and every part with its group, kind and bounds in the
    body's frame (whose origin is the body's ``position``)."""
    from impactnet.models.compound.parts import BoxPart, bounds
    from impactnet.models.scene_bodies import part_group

    out = {"description": getattr(body, "description", "")}
    if not getattr(body, "is_compound", False):
        return {"kind": "box", "size": _rounded(body.size)} | out
    parts = []
    for part in body.parts:
        lo, hi = bounds(part)
        parts.append({"name": part.name, "group": part_group(part.name),
                      "kind": "box" if isinstance(part, BoxPart) else "convex",
                      "lo": _rounded(lo), "hi": _rounded(hi)})
    lo = np.min([p["lo"] for p in parts], axis=0)
    hi = np.max([p["hi"] for p in parts], axis=0)
    made = {k: v for k, v in (body.spec or {}).items() if k != "parts"}
    return {"kind": "compound", "envelope": {"lo": _rounded(lo), "hi": _rounded(hi)},
            "origin": "the body frame's origin is the body's `position`; parts' bounds are in "
                      "that frame", "made_by": made, "parts": parts} | out


def view_of(scene) -> SceneView:
    """A :class:`SceneView` of a ``impactnet.models.scenes.Scene``."""
    bodies, compound = _bodies_of(scene)
    items = list(scene.bodies.values() if isinstance(scene.bodies, dict) else scene.bodies)
    names = tuple(sorted(bodies))
    sizes = np.array([np.asarray(bodies[n], dtype=np.float64).reshape(3) for n in names],
                     dtype=np.float64).reshape(-1, 3)
    pairs = tuple((str(p.a), str(p.b)) for p in scene.pairs)
    compound_names = tuple(sorted(compound))
    return SceneView(name=str(scene.name), hash=str(scene.hash()), object_names=names,
                     sizes=sizes, pairs=pairs, compound_names=compound_names,
                     compound_parts={n: compound[n].parts for n in compound_names},
                     compound_sizes=np.array([compound[n].size for n in compound_names],
                                             np.float64).reshape(-1, 3),
                     bodies={str(b.name): describe_body(b) for b in items})


def load_scene_view(name_or_path: str | None) -> SceneView:
    """Load the configured scene; ``None`` or ``""`` gives the empty scene.

    Raises
    ------
    SceneLoadError
        The scene cannot be loaded.
    """
    if not name_or_path:
        return EMPTY_SCENE
    try:
        scene = load_scene(name_or_path)
    except Exception as exc:  # noqa: BLE001 - any scene error becomes one clear message
        raise SceneLoadError(f"cannot load scene {name_or_path!r}: {exc}") from exc
    return view_of(scene)
