"""Seeded poses of convex part pairs and their answers from the NumPy convex solver (not a test
module).

The compiled convex solver replaced a vectorised NumPy one (issue #32, the convex part) with
the promise of the same answers. ``tests/data/convex/numpy_solver.npz`` holds, for the cases
below, the inputs and every output of that NumPy solver (``convex_contacts`` and the
separating-axis test ``choose_axis`` of commit 44b01cc), recorded by :func:`record` with the
NumPy solver on the path (``tests/data/convex/README.md``); ``test_convex_kernels.py`` replays
them on the kernels.

Cases (hull A, hull B; the head is the spreader's twistlock head, a stadium frustum):

* ``random`` poses near contact: both parts turned at random, B's centre within 6 cm of A's;
* ``resting``: B standing on A's top face, turned about the vertical, tilted by up to
  ``tilt`` rad, pushed in by up to 1 mm;
* ``aligned``: B standing on A's top face exactly level or tilted by 1e-12 .. 1e-6 rad about
  a horizontal axis, no turn (parallel and nearly parallel edges: the edge axes' worst
  conditioning).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.hull import box_hull, convex_hull
from impactnet.models.geometry.rotations import quaternion_to_matrix, random_quaternions

#: Where the recorded answers live.
DATA = "tests/data/convex/numpy_solver.npz"
#: Sides of the twistlock heads.
SIDES = (8, 32, 128, 256)
#: The plate the heads meet (m), and a small piece like an aperture's ring piece.
PLATE, PIECE = (0.3, 0.3, 0.03), (0.04, 0.03, 0.026)
#: The fields of Contacts and of the separating-axis test that are compared.
CONTACT_FIELDS = ("colliding", "normal", "depth", "point", "contact_type_code", "feature_a",
                  "feature_b", "axis", "manifold_points", "manifold_depths", "manifold_count",
                  "pressure")
AXIS_FIELDS = ("colliding", "kind", "face", "depth", "normal", "edge_a", "edge_b", "edge_point",
               "scale")


def head(sides: int):
    """The hull of a spreader's twistlock head of ``sides`` sides (body frame)."""
    part = next(p for p in cb.spreader("40ft", sides=sides) if p.name.startswith("head"))
    return convex_hull(part.vertices())


def hull_of(spec: str):
    """A case's hull by name: ``head<sides>``, ``plate``, ``piece``, ``box``, ``box2``."""
    if spec.startswith("head"):
        return head(int(spec[4:]))
    return box_hull({"plate": PLATE, "piece": PIECE, "box": (2.0, 1.0, 0.5),
                     "box2": (1.0, 0.7, 0.3)}[spec])


def random_poses(a, b, n: int, seed: int, spread: float = 0.06):
    """(p_A, R_A, p_B, R_B): both turned at random, B's centre within ``spread`` of A's."""
    rng = np.random.default_rng(seed)
    ra = quaternion_to_matrix(random_quaternions(n, rng))
    rb = quaternion_to_matrix(random_quaternions(n, rng))
    pa = rng.normal(size=(n, 3))
    pb = (pa + np.einsum("nij,j->ni", ra, a.vertices.mean(axis=0))
          - np.einsum("nij,j->ni", rb, b.vertices.mean(axis=0))
          + rng.uniform(-spread, spread, (n, 3)))
    return pa, ra, pb, rb


def _standing(a, b, rb, xy, push):
    """Poses of B turned by ``rb`` standing on A's top face (A at the origin, level)."""
    n = len(rb)
    top = a.vertices[:, 2].max()
    bottom = np.einsum("nij,kj->nki", rb, b.vertices)[:, :, 2].min(axis=1)
    centre = np.einsum("nij,j->ni", rb, b.vertices.mean(axis=0))[:, :2]
    pb = np.c_[a.vertices[:, :2].mean(axis=0) + xy - centre, top - bottom - push]
    return np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), pb, rb


def resting_poses(a, b, n: int, seed: int, tilt: float):
    """B resting on A's top face: turned about the vertical, tilted by up to ``tilt``."""
    rng = np.random.default_rng(seed)
    axis = np.c_[rng.normal(size=(n, 2)), np.zeros(n)]
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0.0, tilt, n)
    yaw = rng.uniform(-np.pi, np.pi, n)
    tilted = quaternion_to_matrix(np.c_[np.cos(angle / 2), np.sin(angle / 2)[:, None] * axis])
    turned = quaternion_to_matrix(np.c_[np.cos(yaw / 2), np.zeros((n, 2)), np.sin(yaw / 2)])
    return _standing(a, b, tilted @ turned, rng.uniform(-0.05, 0.05, (n, 2)),
                     rng.uniform(0.0, 1e-3, n))


def aligned_poses(a, b, seed: int):
    """B standing on A's top face, not turned, level or tilted by 1e-12 .. 1e-6 rad."""
    rng = np.random.default_rng(seed)
    tilts = np.array([0.0, 1e-12, 1e-9, 1e-6, 0.0, 1e-12, 1e-9, 1e-6])
    axis = np.c_[rng.normal(size=(len(tilts), 2)), np.zeros(len(tilts))]
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    rb = quaternion_to_matrix(np.c_[np.cos(tilts / 2), np.sin(tilts / 2)[:, None] * axis])
    return _standing(a, b, rb, rng.uniform(-0.02, 0.02, (len(tilts), 2)),
                     np.r_[np.full(4, 1e-4), np.zeros(4)])


def cases() -> dict[str, tuple[str, str, tuple]]:
    """name -> (A's hull name, B's hull name, (p_A, R_A, p_B, R_B))."""
    out = {}
    for sides in SIDES:
        name = f"head{sides}"
        h = head(sides)
        plate = hull_of("plate")
        out[f"{name}_on_plate_random"] = ("plate", name, random_poses(plate, h, 24, sides))
        out[f"{name}_on_plate_resting"] = ("plate", name, resting_poses(plate, h, 8, sides, 1e-3))
        out[f"plate_on_{name}_random"] = (name, "plate", random_poses(h, plate, 12, sides + 1))
        out[f"{name}_on_{name}_random"] = (name, name, random_poses(h, h, 16, sides + 2))
        out[f"{name}_on_{name}_resting"] = (name, name, resting_poses(h, h, 8, sides + 3, 1e-2))
        out[f"{name}_on_{name}_aligned"] = (name, name, aligned_poses(h, h, sides + 4))
    piece, h128 = hull_of("piece"), head(128)
    out["head128_beside_piece"] = ("piece", "head128", random_poses(piece, h128, 40, 128))
    box, box2 = hull_of("box"), hull_of("box2")
    out["boxes_random"] = ("box", "box2", random_poses(box, box2, 40, 1, 0.6))
    out["boxes_aligned"] = ("box", "box2", aligned_poses(box, box2, 2))
    return out


def solve(name: str, spec_a: str, spec_b: str, poses, convex_contacts, choose_axis) -> dict:
    """The solver's answers of one case: contact fields and the test alone (``axis_*``)."""
    a, b = hull_of(spec_a), hull_of(spec_b)
    pa, ra, pb, rb = poses
    found = convex_contacts(a, b, pa, ra, pb, rb).arrays()
    ra_t = ra.transpose(0, 2, 1)
    choice = choose_axis(a, b, np.einsum("nij,nj->ni", ra_t, pb - pa), ra_t @ rb)
    out = {f"{name}/{field}": found[field] for field in CONTACT_FIELDS}
    out.update({f"{name}/axis_{field}": getattr(choice, field) for field in AXIS_FIELDS})
    return out


def record(path: str = DATA) -> None:
    """Write the cases' inputs and the answers of the solver on the path (run it with the
    NumPy solver: ``tests/data/convex/README.md``)."""
    from impactnet.models.compound.convex_contact import convex_contacts
    from impactnet.models.compound.convex_sat import choose_axis

    data = {}
    for name, (spec_a, spec_b, poses) in cases().items():
        data[f"{name}/hulls"] = np.array([spec_a, spec_b])
        for key, value in zip(("position_a", "rot_a", "position_b", "rot_b"), poses):
            data[f"{name}/{key}"] = value
        data.update(solve(name, spec_a, spec_b, poses, convex_contacts, choose_axis))
    np.savez_compressed(path, **data)
