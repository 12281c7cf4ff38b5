"""Test helper: seeded pairs of polytopes and poses at chosen gaps, per body kind.

Not a test module. A kind names the two bodies: ``box-box`` (boxes of random sizes), ``box-
frustum8``, ``box-frustum32``, ``box-frustum128`` (a box against a frustum of that many sides,
:func:`impactnet.models.compound.shapes.frustum_points`) and ``frustum-frustum`` (a 32-sided
against an 8-sided frustum). Sizes are log-uniform (box edges 0.05-3 m, frustum diameters
0.05-2 m, heights 0.05-2 m, tips 0.2-1 of the base), orientations uniform (a random axis and
angle), A anywhere within 10 m of the origin.

B is first placed beyond both bodies' reach along a random direction; the query under test
gives that pose's distance ``d0`` and closest direction ``n``; moving B by ``(d0 - gap) n``
towards A makes the distance exactly ``gap`` (the closest pair moves along its own direction,
and the separating plane keeps every other pair at least as far). Gaps: 5 % exactly 0
(touching), 5 % log-uniform in 1e-9-1e-3 m, the rest uniform in 0-1 m.

Flat cases (:func:`flat_cases`): two boxes with parallel faces, B turned about A's vertical
only and placed over A's top face with their footprints overlapping in part or whole, so that
the closest points are a whole polygon (the region centroid's test).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from impactnet.models.compound.shapes import frustum_points
from impactnet.models.distance.query import PolytopePair
from impactnet.models.geometry.rotations import quaternion_to_matrix, random_quaternions

KINDS = ("box-box", "box-frustum8", "box-frustum32", "box-frustum128", "frustum-frustum")
#: (shapes, poses per shape, seed) of the FCL and MuJoCo comparisons: a fast set and a slow
#: one (pytest.mark.slow).
SIZES = (pytest.param((2, 100, 301), id="fast"),
         pytest.param((20, 100, 302), id="slow", marks=pytest.mark.slow))


@dataclass
class Case:
    """One pair of polytopes at N poses (world frame)."""

    vertices_a: np.ndarray  # (k_a, 3) m
    vertices_b: np.ndarray  # (k_b, 3) m
    position_a: np.ndarray  # (n, 3) m
    rotation_a: np.ndarray  # (n, 3, 3)
    position_b: np.ndarray  # (n, 3) m
    rotation_b: np.ndarray  # (n, 3, 3)
    gap: np.ndarray  # (n,) m, the distance the poses were built for


def box_corners(size) -> np.ndarray:
    """The 8 corners (8, 3) of a box of full edges ``size`` (3,) m about the origin."""
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    return 0.5 * signs * np.asarray(size, float)


def _log_uniform(rng, lo, hi, size=None):
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size))


def _frustum(rng, sides: int) -> np.ndarray:
    height = _log_uniform(rng, 0.05, 2.0) * rng.choice([-1.0, 1.0])
    points = frustum_points(_log_uniform(rng, 0.05, 2.0), sides, height,
                            rng.uniform(0.2, 1.0), (0.0, 0.0, -0.5 * height))
    return points


def bodies(kind: str, rng) -> tuple[np.ndarray, np.ndarray]:
    """A random pair of vertex arrays of ``kind`` (module docstring)."""
    if kind == "box-box":
        return (box_corners(_log_uniform(rng, 0.05, 3.0, 3)),
                box_corners(_log_uniform(rng, 0.05, 3.0, 3)))
    if kind == "frustum-frustum":
        return _frustum(rng, 32), _frustum(rng, 8)
    return box_corners(_log_uniform(rng, 0.05, 3.0, 3)), _frustum(rng, int(kind[11:]))


def gaps(rng, n: int) -> np.ndarray:
    """Target gaps (n,) m (module docstring)."""
    out = rng.uniform(0.0, 1.0, n)
    pick = rng.random(n)
    out[pick < 0.05] = 0.0
    tiny = (pick >= 0.05) & (pick < 0.10)
    out[tiny] = _log_uniform(rng, 1e-9, 1e-3, int(tiny.sum()))
    return out


def rotations(rng, n: int) -> np.ndarray:
    """Uniform random rotation matrices (n, 3, 3)."""
    return quaternion_to_matrix(random_quaternions(n, rng))


def at_gaps(vertices_a, vertices_b, target, rng, flat: bool = False) -> Case:
    """Poses of the pair at the distances ``target`` (n,) m (module docstring); ``flat``: B
    turned about A's z only, over A's top face (boxes)."""
    n = len(target)
    pair = PolytopePair(vertices_a, vertices_b)
    reach = np.linalg.norm(vertices_a, axis=1).max() + np.linalg.norm(vertices_b, axis=1).max()
    pa, ra, rb = rng.uniform(-10.0, 10.0, (n, 3)), rotations(rng, n), rotations(rng, n)
    if flat:
        turn = rng.uniform(-np.pi, np.pi, n)
        about_z = np.zeros((n, 3, 3))
        about_z[:, 0, 0], about_z[:, 0, 1] = np.cos(turn), -np.sin(turn)
        about_z[:, 1, 0], about_z[:, 1, 1] = np.sin(turn), np.cos(turn)
        about_z[:, 2, 2] = 1.0
        rb = ra @ about_z
        spread = 0.8 * (vertices_a.max(axis=0) + vertices_b.max(axis=0))[:2]
        offset = np.column_stack([rng.uniform(-1.0, 1.0, (n, 2)) * spread, np.full(n, reach)])
        pb = pa + np.einsum("pij,pj->pi", ra, offset)
    else:
        way = rng.normal(size=(n, 3))
        way /= np.linalg.norm(way, axis=1, keepdims=True)
        pb = pa + (reach + 1.0) * way
    first = pair.gaps(pa, ra, pb, rb)
    pb = pb - (first.distance - target)[:, None] * first.direction
    return Case(vertices_a, vertices_b, pa, ra, pb, rb, target)


def cases(kind: str, shapes: int, poses: int, seed: int) -> list[Case]:
    """``shapes`` random pairs of ``kind``, each at ``poses`` poses, seeded."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(shapes):
        vertices_a, vertices_b = bodies(kind, rng)
        out.append(at_gaps(vertices_a, vertices_b, gaps(rng, poses), rng))
    return out


def flat_cases(shapes: int, poses: int, seed: int) -> list[Case]:
    """``shapes`` random box pairs with parallel faces (module docstring), seeded."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(shapes):
        vertices_a, vertices_b = bodies("box-box", rng)
        out.append(at_gaps(vertices_a, vertices_b, gaps(rng, poses), rng, flat=True))
    return out
