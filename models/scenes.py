"""Scenes: the bodies of a simulation, the pairs that can collide, how deep, how exact.

A scene file is TOML (read with :mod:`tomllib`); every table and key below is required unless
marked optional, and any other key is an error::

    [scene]
    name = "quay_crane"           # identifier: datasets and bundles are named after it
    description = "..."           # optional
    depth_fraction = [0.0, 0.01]  # penetration depths the simulator produces, as fractions
                                  # of the pair's shortest edge: 0 <= lo <= hi < 1

    [accuracy]
    normal_deg = 1.0              # required normal angle error, degrees, > 0
    point_fraction = 0.02         # required point error, fraction of the shortest edge, > 0

    [bodies.container40]          # one table per body; the key is the body's name
    size = [12.192, 2.438, 2.591] # full edge lengths [lx, ly, lz], metres, > 0
    description = "..."           # optional

    [[pairs]]                     # one entry per pair of bodies that can collide
    a = "container40"             # body A (a pair of a body with itself is allowed)
    b = "spreader"                # body B; (a, b) and (b, a) are the same pair: give it once
    description = "..."           # optional

"Shortest edge" of a pair is the shortest edge of either body (:meth:`Scene.smaller_shortest_edge`):
never longer than the smaller body's shortest edge (tolerances from it are never looser), and
the length by which :func:`impactnet.models.geometry.poses.first_contact_poses` scales its push
depths.

Validation raises :class:`SceneError` (a ``ValueError``) naming the file and the field, e.g.
``scenes/x.toml: pairs[2].b: unknown body 'container45'``.
"""
from __future__ import annotations

import hashlib
import json
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from impactnet.models import scene_fields as sf
from impactnet.models.compound.parts import bounds
from impactnet.models.compound.scene_parts import (
    COMPOUND_KEYS,
    compound_parts,
    is_compound,
    parts_geometry,
)
from impactnet.models.scene_fields import (  # noqa: F401  (re-exported: the scene's API)
    MAX_DEPTH_FRACTION,
    NAME_PATTERN,
    SceneError,
)

#: Environment variable naming the folder where bare scene names are looked up.
SCENES_DIR_ENV = "IMPACTNET_SCENES_DIR"
#: The repository's scene folder (used when SCENES_DIR_ENV is not set).
DEFAULT_SCENES_DIR = Path(__file__).resolve().parent.parent / "scenes"
#: The scene the service and the CLI use when none is named.
DEFAULT_SCENE = "quay_crane"


_TOP_KEYS = ({"scene", "accuracy", "bodies", "pairs"}, set())
_SCENE_KEYS = ({"name", "depth_fraction"}, {"description"})
_ACCURACY_KEYS = ({"normal_deg", "point_fraction"}, set())
_BODY_KEYS = (set(), {"size", "description", *COMPOUND_KEYS})
_PAIR_KEYS = ({"a", "b"}, {"description"})


@dataclass(frozen=True)
class Body:
    """A body of a scene: a box, or a compound body made of parts."""

    name: str  # identifier, unique in the scene
    size: tuple[float, float, float]  # full edge lengths (lx, ly, lz), metres, > 0; for a
    # compound body the extent of its parts' bounds (its envelope)
    description: str = ""  # free text, not part of the scene hash
    parts: tuple | None = None  # compound body: its validated parts (body frame); None: a box
    spec: Mapping | None = field(default=None, compare=False)  # compound: the file's table

    @property
    def is_compound(self) -> bool:
        """Whether the body is made of parts (:mod:`impactnet.models.compound`)."""
        return self.parts is not None


@dataclass(frozen=True)
class BodyPair:
    """Two bodies (names) that can collide; A is the first, the normal points from A to B."""

    a: str  # name of body A
    b: str  # name of body B (may equal a)
    description: str = ""  # why the pair is in the scene; not part of the scene hash

    @property
    def key(self) -> str:
        """``"a/b"``: a readable, unique name of the pair."""
        return f"{self.a}/{self.b}"


@dataclass(frozen=True)
class Accuracy:
    """What the scene requires of a predictor (the goals a bundle is validated against)."""

    normal_deg: float  # normal angle error, degrees, > 0
    point_fraction: float  # point error as a fraction of the pair's shortest edge, > 0


@dataclass(frozen=True)
class Scene:
    """A validated scene; build it with :func:`load_scene` or :func:`parse_scene`."""

    name: str  # identifier; datasets and bundles are named after it
    description: str  # free text, not part of the hash
    depth_fraction: tuple[float, float]  # (lo, hi) penetration depth / shortest edge
    accuracy: Accuracy  # required accuracy
    bodies: tuple[Body, ...]  # in file order
    pairs: tuple[BodyPair, ...]  # in file order

    def body(self, name: str) -> Body:
        """The body called ``name``; raises SceneError if there is none."""
        for body in self.bodies:
            if body.name == name:
                return body
        raise SceneError(self.name, "bodies", f"unknown body {name!r} "
                         f"(bodies: {', '.join(b.name for b in self.bodies)})")

    def size(self, name: str) -> np.ndarray:
        """Full edge lengths of body ``name``, float64, shape (3,), metres (a fresh copy)."""
        return np.array(self.body(name).size, dtype=np.float64)

    def pair_sizes(self) -> np.ndarray:
        """Sizes of every pair, float64, shape (m, 2, 3), metres: ``[k, 0]`` A, ``[k, 1]`` B.

        ``for size_a, size_b in scene.pair_sizes():`` walks the pairs in file order.
        """
        return np.array([[self.body(p.a).size, self.body(p.b).size] for p in self.pairs],
                        dtype=np.float64).reshape(len(self.pairs), 2, 3)

    def smaller_shortest_edge(self, pair: BodyPair | tuple[str, str] | int) -> float:
        """Shortest edge of either body of ``pair`` (a BodyPair, (a, b) names or an index), m."""
        if isinstance(pair, int):
            pair = self.pairs[pair]
        a, b = (pair.a, pair.b) if isinstance(pair, BodyPair) else pair
        return float(min(min(self.body(a).size), min(self.body(b).size)))

    def to_dict(self) -> dict:
        """The scene as the TOML structure (plain types); ``parse_scene`` inverts it."""
        scene = {"name": self.name, "depth_fraction": list(self.depth_fraction)}
        if self.description:
            scene["description"] = self.description
        bodies = {}
        for body in self.bodies:
            bodies[body.name] = (dict(body.spec) if body.is_compound else
                                 {"size": list(body.size)})
            if body.description:
                bodies[body.name]["description"] = body.description
        pairs = [{"a": p.a, "b": p.b, **({"description": p.description} if p.description
                                          else {})} for p in self.pairs]
        return {"scene": scene,
                "accuracy": {"normal_deg": self.accuracy.normal_deg,
                             "point_fraction": self.accuracy.point_fraction},
                "bodies": bodies, "pairs": pairs}

    def hash(self) -> str:
        """SHA-256 (hex) of the scene's content, canonically ordered.

        Covers the name, the depth range, the accuracy, every body's size (and a compound
        body's parts: names, kinds, vertices) and the pairs (as
        ordered (a, b) tuples); not the descriptions (documentation, they change no data) and
        not the order of keys, bodies or pairs, nor the file's whitespace or comments.
        """
        canonical = {
            "name": self.name,
            "depth_fraction": list(self.depth_fraction),
            "accuracy": [self.accuracy.normal_deg, self.accuracy.point_fraction],
            "bodies": {b.name: [list(b.size), parts_geometry(b.parts)] if b.is_compound
                       else list(b.size) for b in self.bodies},
            "pairs": sorted([p.a, p.b] for p in self.pairs),
        }
        text = json.dumps(canonical, sort_keys=True, separators=(",", ":"), allow_nan=False)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()


# --------------------------------------------------------------------------------- loading


def scenes_dir() -> Path:
    """Folder of bare scene names: ``$IMPACTNET_SCENES_DIR`` if set, else the repo's scenes/."""
    override = os.environ.get(SCENES_DIR_ENV)
    return Path(override) if override else DEFAULT_SCENES_DIR


def available_scenes() -> list[str]:
    """Names of the scene files in :func:`scenes_dir`, sorted."""
    folder = scenes_dir()
    return sorted(p.stem for p in folder.glob("*.toml")) if folder.is_dir() else []


def scene_path(name_or_path: str | os.PathLike) -> Path:
    """The file of a scene: a bare name (``"quay_crane"``) is looked up in :func:`scenes_dir`,
    anything with a ``.toml`` suffix or a path separator is taken as a path."""
    text = os.fspath(name_or_path)
    if text.endswith(".toml") or os.sep in text or "/" in text:
        return Path(text)
    return scenes_dir() / f"{text}.toml"


def load_scene(name_or_path: str | os.PathLike = DEFAULT_SCENE) -> Scene:
    """Read and validate a scene file; see the module docstring for the format.

    Raises
    ------
    SceneError
        The file is missing, is not valid TOML, or fails validation.
    """
    path = scene_path(name_or_path)
    if not path.is_file():
        known = ", ".join(available_scenes()) or "none"
        raise SceneError(str(path), "", f"no such scene file (scenes in {scenes_dir()}: "
                         f"{known})")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:  # also duplicate tables / keys
        raise SceneError(str(path), "", f"invalid TOML: {exc}") from exc
    return parse_scene(data, source=str(path))


# ------------------------------------------------------------------------------ validation


def parse_scene(data: Mapping, source: str = "scene") -> Scene:
    """Validate a scene given as the TOML structure (nested dicts and lists).

    Parameters
    ----------
    data : Mapping
        ``{"scene": {...}, "accuracy": {...}, "bodies": {name: {...}}, "pairs": [{...}]}``.
    source : str
        Name of the origin, used as the prefix of error messages.

    Raises
    ------
    SceneError
        Naming the field: missing or unknown keys, bad names, sizes not 3 numbers > 0, depth
        range not ``0 <= lo <= hi < 1``, accuracy <= 0, unknown body in a pair, a pair given
        twice (also as (b, a)), no bodies or no pairs.
    """
    if not isinstance(data, Mapping):
        raise SceneError(source, "", f"expected a table, got {type(data).__name__}")
    sf.check_keys(data, "", _TOP_KEYS, source)
    head = sf.table(data["scene"], "scene", _SCENE_KEYS, source)
    name = sf.name(head["name"], "scene.name", source)
    description = sf.text(head.get("description", ""), "scene.description", source)
    depth = sf.depth_range(head["depth_fraction"], "scene.depth_fraction", source)
    acc = sf.table(data["accuracy"], "accuracy", _ACCURACY_KEYS, source)
    accuracy = Accuracy(sf.positive(acc["normal_deg"], "accuracy.normal_deg", source),
                        sf.positive(acc["point_fraction"], "accuracy.point_fraction", source))
    bodies = _bodies(data["bodies"], source)
    pairs = _pairs(data["pairs"], {b.name for b in bodies}, source)
    return Scene(name, description, depth, accuracy, bodies, pairs)


def _bodies(table, source: str) -> tuple[Body, ...]:
    if not isinstance(table, Mapping) or not table:
        raise SceneError(source, "bodies", "expected at least one [bodies.NAME] table")
    bodies = []
    for key, entry in table.items():
        path = f"bodies.{key}"
        name = sf.name(key, path, source)
        entry = sf.table(entry, path, _BODY_KEYS, source)
        description = sf.text(entry.get("description", ""), f"{path}.description", source)
        if is_compound(entry):
            if "size" in entry:
                raise SceneError(source, path, "a compound body takes no `size` (its parts "
                                 "give it)")
            parts = compound_parts(entry, path, source)
            lows, highs = zip(*(bounds(p) for p in parts))
            extent = tuple(float(v) for v in np.max(highs, axis=0) - np.min(lows, axis=0))
            spec = {k: v for k, v in entry.items() if k != "description"}
            bodies.append(Body(name, extent, description, parts, spec))
            continue
        if "size" not in entry:
            raise SceneError(source, path, f"missing {path}.size (or, for a compound body, "
                             "`generator` or `parts`)")
        size = entry["size"]
        if not isinstance(size, list | tuple) or len(size) != 3:
            raise SceneError(source, f"{path}.size",
                             f"expected 3 numbers [lx, ly, lz] in metres, got {size!r}")
        edges = tuple(sf.positive(v, f"{path}.size[{i}]", source) for i, v in enumerate(size))
        bodies.append(Body(name, edges, description))
    return tuple(bodies)


def _pairs(entries, names: set[str], source: str) -> tuple[BodyPair, ...]:
    if not isinstance(entries, list) or not entries:
        raise SceneError(source, "pairs", "expected at least one [[pairs]] entry")
    pairs, seen = [], {}
    for k, entry in enumerate(entries):
        path = f"pairs[{k}]"
        entry = sf.table(entry, path, _PAIR_KEYS, source)
        a, b = (sf.text(entry[s], f"{path}.{s}", source) for s in "ab")
        for side, body in (("a", a), ("b", b)):
            if body not in names:
                raise SceneError(source, f"{path}.{side}", f"unknown body {body!r} "
                                 f"(bodies: {', '.join(sorted(names))})")
        unordered = frozenset((a, b))
        if unordered in seen:
            raise SceneError(source, path, f"duplicate pair ({a}, {b}): already given as "
                             f"pairs[{seen[unordered]}]")
        seen[unordered] = k
        pairs.append(BodyPair(a, b, sf.text(entry.get("description", ""),
                                          f"{path}.description", source)))
    return tuple(pairs)
