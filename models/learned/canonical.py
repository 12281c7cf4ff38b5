"""The canonical frame of a box pair, the pose features and the region labels of the learned
predictors (the contract: docs/learned_predictors.md).

Stages, as training and inference both apply them:

1. :func:`relative_pose`: B in A's frame, ``t = R_A^T (p_B - p_A)``, ``R = R_A^T R_B``,
   float64, computed exactly as the exact solver does
   (:func:`impactnet.models.box.decision.relative_pose`).
2. :func:`canonicalize`: the sign symmetries of both boxes move B's centre into A's positive
   octant and A's centre into B's: ``S = diag(sign t)``, ``T = diag(sign u)`` with
   ``u = -(S R)^T S t`` (ties +1), ``t' = S t``, ``R' = S R T`` (possibly improper: it still
   describes the same pair of boxes as sets).
3. :func:`pose_features` (``pose-v1``, 12 float32): ``t' / L`` then ``R'`` row-major, with
   ``L = max(h_A) + max(h_B)`` the pair scale.
4. :func:`contact_targets` (``contact-v1``, 7 float32): canonical point ``/ L``, canonical
   normal, ``depth / e`` (``e``: the shortest edge of the pair); :func:`from_canonical`
   inverts it (``point = p_A + R_A S L point'``, ``normal = R_A S normal'``).
5. :func:`canonical_labels`: the region key ``"<contact_type>:<feature_a>:<feature_b>"`` of
   the canonical features (A's mapped by S, B's by T; sign flips are involutions, so the same
   tables map them back), ``"none"`` for separated pairs.

The predictors run stages 1-4 in a compiled row function
(:mod:`impactnet.models.learned.kernel_frame`) whose features equal these functions' to the last
bit where the pair's sizes are the bundle's (tested).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from impactnet.models.box import decision
from impactnet.models.contacts import CONTACT_TYPE_CODES, CONTACT_TYPES, NONE
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import quaternion_to_matrix

#: Name of the feature layout (``mlps.<m>.inputs`` in a bundle manifest).
FEATURES_VERSION = "pose-v1"
#: Name of the regression output layout (``mlps.<m>.outputs``).
OUTPUTS_VERSION = "contact-v1"
#: The committee's region classifier: the exact solver's separating-axis test and incident
#: feature, without the clipping (:mod:`impactnet.models.learned.region_label`), named in the
#: bundle.
REGION_LABELLER = "exact-sat-v1"
#: Outputs of the committee's experts: ``contact-v1`` whose point is the residual of the
#: contact point from the labeller's unclipped point (canonical A frame, / L).
EXPERT_OUTPUTS_VERSION = "contact-residual-v1"
N_POSE_FEATURES = 12
N_CONTACT_OUTPUTS = 7
#: Region key of separated pairs (the first entry of a pair's region list).
NONE_KEY = "none"
#: A predicted canonical normal shorter than this (dimensionless) has no direction; it is
#: replaced by :data:`FALLBACK_NORMAL` instead of being divided by ~0.
NORMAL_NORM_MIN = 1e-6
#: Canonical fallback normal: into the positive octant, where B's centre lies.
FALLBACK_NORMAL = np.full(3, 3.0 ** -0.5)

#: ``FLIP_FEATURES[k, f]``: image of feature id f under the sign flip k (index into
#: SIGNED_PERMUTATIONS, 0-7); column 26 (id -1 read as index -1) keeps "no feature".
FLIP_FEATURES = np.concatenate([bf.FEATURE_PERMUTATIONS[:8], np.full((8, 1), bf.NO_FEATURE)],
                               axis=1).astype(np.int8)
FLIP_FEATURES.setflags(write=False)
_KEY_BASE = bf.N_FEATURES + 1  # feature ids -1..25 shifted to 0..26


class RelativePose(NamedTuple):
    """B seen from A, float64: half-extents (n, 3) metres, ``R = R_A^T R_B`` (n, 3, 3) and
    ``t = R_A^T (p_B - p_A)`` (n, 3) metres."""

    half_a: np.ndarray
    half_b: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray


class Canonical(NamedTuple):
    """A canonicalised pose: sign diagonals ``S``, ``T`` (n, 3) int64 in {-1, 1}, ``R'`` (n, 3,
    3) and ``t'`` (n, 3) metres, float64."""

    S: np.ndarray
    T: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray


class CanonicalLabels(NamedTuple):
    """Canonical labels of n contacts: ``contact_type_code``, ``feature_a``, ``feature_b``
    (n,) int8 (features mapped by S and T, -1 when separated) and region ``keys`` (n,) str."""

    contact_type_code: np.ndarray
    feature_a: np.ndarray
    feature_b: np.ndarray
    keys: np.ndarray


def relative_pose(size_a, position_a, quaternion_a, size_b, position_b,
                  quaternion_b) -> RelativePose:
    """B's pose in A's frame, validated like :func:`impactnet.models.box.exact.box_box` (same
    arguments).

    Raises
    ------
    impactnet.models.box.exact.InvalidBoxError,
    impactnet.models.geometry.rotations.InvalidRotationError
        As the exact solver does.
    """
    return RelativePose(*decision.relative_pose(size_a, position_a, quaternion_a, size_b,
                                                position_b, quaternion_b))


def world_rotation(quaternion) -> np.ndarray:
    """Rotation matrices (n, 3, 3) (``v_world = R v_body``) of quaternions (n, 4) or (4,),
    normalised first (:func:`impactnet.models.geometry.rotations.quaternion_to_matrix`)."""
    q = np.asarray(quaternion, dtype=np.float64).reshape(-1, 4)
    return quaternion_to_matrix(q / np.sqrt((q * q).sum(axis=1))[:, None])


def canonicalize(rotation, translation) -> Canonical:
    """The canonical pose of B in A's frame (see the module docstring, stage 2).

    Parameters
    ----------
    rotation : array_like, shape (n, 3, 3)
        ``R = R_A^T R_B``.
    translation : array_like, shape (n, 3)
        ``t``, metres.
    """
    rotation = np.asarray(rotation, dtype=np.float64)
    translation = np.asarray(translation, dtype=np.float64)
    S = bf.canonical_sign_flip(translation)
    t = S * translation
    sr = S[:, :, None] * rotation
    u = -(sr[:, 0] * t[:, :1] + sr[:, 1] * t[:, 1:2] + sr[:, 2] * t[:, 2:3])  # -(S R)^T t'
    T = bf.canonical_sign_flip(u)
    return Canonical(S, T, sr * T[:, None, :], t)


def pair_lengths(half_a, half_b) -> tuple[np.ndarray, np.ndarray]:
    """``L = max(h_A) + max(h_B)`` and ``e`` = the pair's shortest full edge, (n,) metres."""
    half_a, half_b = np.asarray(half_a), np.asarray(half_b)
    return (half_a.max(axis=-1) + half_b.max(axis=-1),
            2.0 * np.minimum(half_a.min(axis=-1), half_b.min(axis=-1)))


def pose_features(canonical: Canonical, half_a, half_b) -> np.ndarray:
    """``pose-v1`` features (n, 12) float32: ``t' / L`` (3), then ``R'`` row-major (9)."""
    scale, _ = pair_lengths(half_a, half_b)
    n = len(scale)
    out = np.empty((n, N_POSE_FEATURES), np.float32)
    out[:, :3] = canonical.translation / scale[:, None]
    out[:, 3:] = canonical.rotation.reshape(n, 9)
    return out


def contact_targets(point, normal, depth, position_a, quaternion_a, canonical: Canonical,
                    half_a, half_b) -> np.ndarray:
    """``contact-v1`` regression targets (n, 7) float32 of world-frame contacts.

    Parameters
    ----------
    point, normal : array_like, shape (n, 3)
        World-frame impact point (metres) and unit normal (A towards B).
    depth : array_like, shape (n,)
        Penetration depth, metres.
    position_a, quaternion_a : array_like, shape (n, 3), (n, 4)
        A's pose (the quaternion is normalised here).
    canonical : Canonical
        The canonical pose of the same rows; ``half_a``, ``half_b`` (n, 3) metres.
    """
    rot_a = world_rotation(quaternion_a)
    scale, edge = pair_lengths(half_a, half_b)
    offset = np.asarray(point, dtype=np.float64) - np.asarray(position_a, dtype=np.float64)
    local_point = np.einsum("nij,ni->nj", rot_a, offset)  # R_A^T (point - p_A)
    local_normal = np.einsum("nij,ni->nj", rot_a, np.asarray(normal, dtype=np.float64))
    out = np.empty((len(scale), N_CONTACT_OUTPUTS), np.float32)
    out[:, :3] = canonical.S * local_point / scale[:, None]
    out[:, 3:6] = canonical.S * local_normal
    out[:, 6] = np.asarray(depth, dtype=np.float64) / edge
    return out


def unit_normals(normal) -> np.ndarray:
    """Rows of ``normal`` (n, 3) scaled to unit length, float64; rows shorter than
    :data:`NORMAL_NORM_MIN` become :data:`FALLBACK_NORMAL`."""
    normal = np.asarray(normal, dtype=np.float64)
    norm = np.sqrt((normal * normal).sum(axis=1))
    short = norm < NORMAL_NORM_MIN
    unit = normal / np.where(short, 1.0, norm)[:, None]
    unit[short] = FALLBACK_NORMAL
    return unit


def from_canonical(outputs, S, half_a, half_b, position_a, quaternion_a):
    """World-frame contacts from ``contact-v1`` outputs (the inverse of :func:`contact_targets`).

    Parameters
    ----------
    outputs : array_like, shape (n, 7)
        Canonical ``point / L``, normal (renormalised here), ``depth / e``.
    S : array_like, shape (n, 3)
        Sign diagonals of the canonicalisation.
    half_a, half_b : array_like, shape (n, 3)
        Half-extents, metres.
    position_a, quaternion_a : array_like, shape (n, 3), (n, 4)
        A's world pose.

    Returns
    -------
    point : ndarray, shape (n, 3), metres, world frame
    normal : ndarray, shape (n, 3), unit, world frame
    depth : ndarray, shape (n,), metres, clipped at 0
    """
    outputs = np.asarray(outputs, dtype=np.float64)
    rot_a = world_rotation(quaternion_a)
    scale, edge = pair_lengths(half_a, half_b)
    local_point = S * outputs[:, :3] * scale[:, None]
    local_normal = S * unit_normals(outputs[:, 3:6])
    point = np.asarray(position_a, dtype=np.float64) + np.einsum("nij,nj->ni", rot_a,
                                                                 local_point)
    normal = np.einsum("nij,nj->ni", rot_a, local_normal)
    return point, normal, np.maximum(outputs[:, 6] * edge, 0.0)


def map_flip_features(flip_index, ids) -> np.ndarray:
    """Feature ids (n,) under the sign flips ``flip_index`` (n,) (0-7), -1 kept, int8.

    Sign flips are involutions: the same call maps original ids to canonical ones and back.
    """
    return FLIP_FEATURES[np.asarray(flip_index), np.asarray(ids, dtype=np.int64)]


def _field(contacts, name):
    return np.asarray(contacts[name] if isinstance(contacts, Mapping)
                      else getattr(contacts, name))


def canonical_labels(contacts, S, T) -> CanonicalLabels:
    """Canonical type, features and region keys of n contacts.

    Parameters
    ----------
    contacts : Contacts or Mapping
        With ``contact_type_code``, ``feature_a``, ``feature_b`` (n,) (e.g. a dataset dict).
    S, T : array_like, shape (n, 3)
        Sign diagonals of the rows' canonicalisation.
    """
    code = _field(contacts, "contact_type_code").astype(np.int8)
    fa = map_flip_features(bf.sign_flip_index(S), _field(contacts, "feature_a"))
    fb = map_flip_features(bf.sign_flip_index(T), _field(contacts, "feature_b"))
    return CanonicalLabels(code, fa, fb, region_keys(code, fa, fb))


def region_key(code: int, feature_a: int, feature_b: int) -> str:
    """``"<contact_type>:<feature_a>:<feature_b>"``, or ``"none"`` for code 0."""
    if int(code) == NONE:
        return NONE_KEY
    return f"{CONTACT_TYPES[int(code)]}:{int(feature_a)}:{int(feature_b)}"


def region_keys(code, feature_a, feature_b) -> np.ndarray:
    """Region keys (n,) str of n (code, feature_a, feature_b) triples (one format per distinct
    triple)."""
    code = np.asarray(code, dtype=np.int64).reshape(-1)
    packed = (code * _KEY_BASE + np.asarray(feature_a, dtype=np.int64).reshape(-1) + 1) \
        * _KEY_BASE + np.asarray(feature_b, dtype=np.int64).reshape(-1) + 1
    unique, inverse = np.unique(packed, return_inverse=True)
    names = [region_key(p // _KEY_BASE ** 2, p // _KEY_BASE % _KEY_BASE - 1, p % _KEY_BASE - 1)
             for p in unique.tolist()]
    return np.array(names, dtype=str)[inverse.reshape(-1)] if names else np.array([], str)


def parse_region_key(key: str) -> tuple[int, int, int]:
    """``(contact_type_code, feature_a, feature_b)`` of a region key; ValueError if malformed.

    ``"none"`` gives ``(0, -1, -1)``; a contact's features must exist (0-25) and be of the
    kinds its type names (``"face-vertex:4:18"``: A's face 4, B's vertex 18).
    """
    if key == NONE_KEY:
        return NONE, bf.NO_FEATURE, bf.NO_FEATURE
    parts = key.split(":") if isinstance(key, str) else []
    if len(parts) != 3 or parts[0] not in CONTACT_TYPE_CODES or parts[0] == NONE_KEY:
        raise ValueError(f"bad region key {key!r}: expected '<contact_type>:<a>:<b>' or 'none'")
    try:
        fa, fb = int(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(f"bad region key {key!r}: features must be integers") from None
    if not (0 <= fa < bf.N_FEATURES and 0 <= fb < bf.N_FEATURES):
        raise ValueError(f"bad region key {key!r}: feature ids must be in 0..25")
    kind_a, kind_b = parts[0].split("-")
    if (str(bf.feature_kind(fa)), str(bf.feature_kind(fb))) != (kind_a, kind_b):
        raise ValueError(f"bad region key {key!r}: features are not a {kind_a} and a {kind_b}")
    return CONTACT_TYPE_CODES[parts[0]], fa, fb


class LearningArrays(NamedTuple):
    """Inputs and targets of the learned models for n labelled rows."""

    features: np.ndarray  # (n, 12) float32, pose-v1
    targets: np.ndarray  # (n, 7) float32, contact-v1 (meaningless where keys == "none")
    keys: np.ndarray  # (n,) str, canonical region keys
    canonical: Canonical  # the canonical pose, to map predictions back
    points: tuple = ()  # (n, 3) float32 each: the ``points`` asked for, mapped as the point
    # target is (canonical A frame, / L)


def learning_arrays(rows: Mapping, points: tuple = ()) -> LearningArrays:
    """Features, targets and region keys of a labelled dataset (``impactnet.training.data.datagen``
    columns: the six inputs, ``point``, ``normal``, ``depth``, ``contact_type_code``, ``feature_a``,
    ``feature_b``), and each further world-frame point array of ``points`` (n, 3) in the point
    target's frame and scale (e.g. the region labeller's unclipped points)."""
    pose = relative_pose(*(rows[k] for k in ("size_a", "position_a", "quaternion_a", "size_b",
                                             "position_b", "quaternion_b")))
    canonical = canonicalize(pose.rotation, pose.translation)
    n = len(pose.half_a)
    position_a = np.broadcast_to(np.asarray(rows["position_a"], np.float64).reshape(-1, 3),
                                 (n, 3))
    quaternion_a = np.broadcast_to(np.asarray(rows["quaternion_a"], np.float64).reshape(-1, 4),
                                   (n, 4))
    mapped = [contact_targets(point, rows["normal"], rows["depth"], position_a, quaternion_a,
                              canonical, pose.half_a, pose.half_b)
              for point in (rows["point"], *points)]
    keys = canonical_labels(rows, canonical.S, canonical.T).keys
    return LearningArrays(pose_features(canonical, pose.half_a, pose.half_b), mapped[0], keys,
                          canonical, tuple(m[:, :3] for m in mapped[1:]))
