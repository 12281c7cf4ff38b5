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
    part_point_fraction = 0.02    # optional, compound pairs: fraction of the touching part's
                                  # smallest extent (Scene.point_tolerance_m); default:
                                  # point_fraction

    [bodies.container40]          # one table per body; the key is the body's name
    size = [12.192, 2.438, 2.591] # full edge lengths [lx, ly, lz], metres, > 0
    description = "..."           # optional
                                  # or a compound body: `generator` and its parameters, or
                                  # [[bodies.NAME.parts]] (impactnet.models.scene_bodies)

    [[pairs]]                     # one entry per pair of bodies that can collide
    a = "container40"             # body A (a pair of a body with itself is allowed)
    b = "spreader"                # body B; (a, b) and (b, a) are the same pair: give it once
    description = "..."           # optional

"Shortest edge" of a pair is the shortest edge of either body (:meth:`Scene.smaller_shortest_edge`):
never longer than the smaller body's shortest edge (tolerances from it are never looser), and
the length by which :func:`impactnet.models.geometry.poses.first_contact_poses` scales its push
depths. For a pair with a compound body it is taken over the envelopes (``Body.size``), which is
what ``depth_fraction`` scales for every pair.

Compound bodies are not boxes: :meth:`Scene.pair_sizes` (the box paths' input) refuses a pair
with a compound body, naming it, and :meth:`Scene.require_box_pairs` lets a box-only tool say so
before it starts; :meth:`Scene.compound_pairs` and :meth:`Scene.box_pairs` split the pairs.

Validation raises :class:`SceneError` (a ``ValueError``) naming the file and the field, e.g.
``scenes/x.toml: pairs[2].b: unknown body 'container45'``.
"""
from __future__ import annotations

import hashlib
import json
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from impactnet.models import scene_fields as sf
from impactnet.models.compound.scene_parts import parts_geometry
from impactnet.models.scene_bodies import Body, BodyPair, parse_bodies, parse_pairs
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
_ACCURACY_KEYS = ({"normal_deg", "point_fraction"}, {"part_point_fraction"})


@dataclass(frozen=True)
class Accuracy:
    """What the scene requires of a predictor (the goals a bundle is validated against)."""

    normal_deg: float  # normal angle error, degrees, > 0
    point_fraction: float  # point error as a fraction of the pair's shortest edge, > 0
    part_point_fraction: float | None = None  # compound pairs: point error as a fraction of
    # the touching part's smallest extent (Scene.point_tolerance_m); None: point_fraction


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

    def _pair(self, pair: BodyPair | tuple[str, str] | int) -> tuple[str, str]:
        """(a, b) names of a BodyPair, (a, b) names or an index into :attr:`pairs`."""
        if isinstance(pair, int):
            pair = self.pairs[pair]
        return (pair.a, pair.b) if isinstance(pair, BodyPair) else tuple(pair)

    def is_compound_pair(self, pair: BodyPair | tuple[str, str] | int) -> bool:
        """Whether either body of ``pair`` is made of parts."""
        return any(self.body(name).is_compound for name in self._pair(pair))

    def compound_pairs(self) -> tuple[BodyPair, ...]:
        """The pairs with a compound body, in file order (the compound oracle's)."""
        return tuple(p for p in self.pairs if self.is_compound_pair(p))

    def box_pairs(self) -> tuple[BodyPair, ...]:
        """The pairs of two boxes, in file order (the box solver's and the box models')."""
        return tuple(p for p in self.pairs if not self.is_compound_pair(p))

    def require_box_pairs(self, what: str, pairs=None) -> None:
        """Raise :class:`SceneError` naming every pair of ``pairs`` (default: all; BodyPairs,
        (a, b) names or indices) that has a compound body, for ``what`` (a box-only tool)."""
        pairs = self.pairs if pairs is None else pairs
        compound = ["/".join(self._pair(p)) for p in pairs if self.is_compound_pair(p)]
        if compound:
            raise SceneError(self.name, "pairs", f"{what} handles pairs of boxes only; "
                             f"{', '.join(compound)} "
                             f"{'has' if len(compound) == 1 else 'have'} a compound body "
                             "(made of parts: the exact compound oracle answers it)")

    def pair_sizes(self, envelopes: bool = False) -> np.ndarray:
        """Sizes of every pair, float64, shape (m, 2, 3), metres: ``[k, 0]`` A, ``[k, 1]`` B.

        ``for size_a, size_b in scene.pair_sizes():`` walks the pairs in file order. A pair
        with a compound body raises :class:`SceneError` naming it (its size is an envelope,
        not the body), unless ``envelopes`` asks for the envelopes knowingly.
        """
        if not envelopes:
            self.require_box_pairs("Scene.pair_sizes (the box solver's sizes)")
        return np.array([[self.body(p.a).size, self.body(p.b).size] for p in self.pairs],
                        dtype=np.float64).reshape(len(self.pairs), 2, 3)

    def smaller_shortest_edge(self, pair: BodyPair | tuple[str, str] | int) -> float:
        """Shortest edge of either body of ``pair`` (a BodyPair, (a, b) names or an index), m;
        of the envelopes for a compound body (what ``depth_fraction`` scales)."""
        a, b = self._pair(pair)
        return float(min(min(self.body(a).size), min(self.body(b).size)))

    def point_tolerance_m(self, pair: BodyPair | tuple[str, str] | int,
                          part_a: str | None = None, part_b: str | None = None) -> float:
        """The point error the scene allows for ``pair``, metres.

        Box pairs: ``point_fraction`` x :meth:`smaller_shortest_edge`. Pairs with a compound
        body (issue #21): ``part_point_fraction`` (default ``point_fraction``) x the smaller of
        the two touching parts' smallest extents (:meth:`Body.touching_extent`: a part's group,
        so a casting's 118 mm at every detail level, 2.36 mm at 2 %); without part names, the
        smallest over the bodies' parts (the tightest the pair can ask for).
        """
        a, b = self._pair(pair)
        if not self.is_compound_pair((a, b)):
            return self.accuracy.point_fraction * self.smaller_shortest_edge((a, b))
        fraction = self.accuracy.part_point_fraction or self.accuracy.point_fraction
        return fraction * min(self.body(a).touching_extent(part_a),
                              self.body(b).touching_extent(part_b))

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
        accuracy = {"normal_deg": self.accuracy.normal_deg,
                    "point_fraction": self.accuracy.point_fraction}
        if self.accuracy.part_point_fraction is not None:
            accuracy["part_point_fraction"] = self.accuracy.part_point_fraction
        return {"scene": scene, "accuracy": accuracy, "bodies": bodies, "pairs": pairs}

    def hash(self) -> str:
        """SHA-256 (hex) of the scene's content, canonically ordered.

        Covers the name, the depth range, the accuracy, every body's size (and a compound
        body's parts: names, kinds, vertices, so a changed mesh file or generator changes it)
        and the pairs (as ordered (a, b) tuples); not the descriptions (documentation, they
        change no data) and not the order of keys, bodies or pairs, nor the file's whitespace
        or comments. Box-only scenes without ``part_point_fraction`` hash as they did before
        compound bodies existed.
        """
        accuracy = [self.accuracy.normal_deg, self.accuracy.point_fraction]
        if self.accuracy.part_point_fraction is not None:
            accuracy.append(self.accuracy.part_point_fraction)
        canonical = {
            "name": self.name,
            "depth_fraction": list(self.depth_fraction),
            "accuracy": accuracy,
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
    part_point = acc.get("part_point_fraction")
    accuracy = Accuracy(sf.positive(acc["normal_deg"], "accuracy.normal_deg", source),
                        sf.positive(acc["point_fraction"], "accuracy.point_fraction", source),
                        None if part_point is None else
                        sf.positive(part_point, "accuracy.part_point_fraction", source))
    bodies = parse_bodies(data["bodies"], source)
    pairs = parse_pairs(data["pairs"], {b.name for b in bodies}, source)
    return Scene(name, description, depth, accuracy, bodies, pairs)
