"""The bodies' mirror symmetries that let the four corners share one classifier: the crane
bodies map part for part onto their mirror images (an involution), a body without the
symmetry gets no map, and a corner's features seen through its mirror are corner fl's
features of the mirrored pose."""
import numpy as np
import pytest

from impactnet.models.compound import cell_guide, container, spreader
from impactnet.models.geometry.rotations import quaternion_to_matrix, random_quaternions
from impactnet.models.learned.compound.groups import (
    CORNER_MIRRORS,
    group_features,
    mirror_features,
    mirror_map,
    part_groups,
)


@pytest.mark.parametrize("parts", [container("40ft", detail=2), container("20ft", detail=1),
                                   spreader("40ft", sides=32)], ids=["40ft-d2", "20ft-d1",
                                                                      "spreader"])
@pytest.mark.parametrize("corner", ["fr", "al", "ar"])
def test_the_crane_bodies_map_part_for_part_onto_their_mirror_images(parts, corner):
    mapping = mirror_map(parts, CORNER_MIRRORS[corner])
    assert mapping is not None
    np.testing.assert_array_equal(mapping[mapping], np.arange(len(parts)))  # an involution
    names = [p.name for p in parts]
    for k, name in enumerate(names):  # a corner's part maps onto a part of corner fl's group
        group = name.split("/")[0]  # (pieces of a casting may be numbered round the other way)
        if group.endswith(f"_{corner}"):
            assert names[mapping[k]].split("/")[0] == group.replace(f"_{corner}", "_fl")


def test_a_body_without_the_symmetry_gets_no_map():
    assert mirror_map(cell_guide(), CORNER_MIRRORS["fr"]) is None


@pytest.mark.parametrize("corner", ["fr", "al", "ar"])
def test_a_corner_seen_through_its_mirror_is_corner_fl_of_the_mirrored_pose(corner):
    groups = {g.name: g for g in part_groups(container("40ft", detail=2),
                                             spreader("40ft", sides=16))}
    rng = np.random.default_rng(5)
    position = rng.normal(scale=0.05, size=(20, 3)) + [0, 0, 1.7]
    rotation = quaternion_to_matrix(random_quaternions(20, rng))
    m = np.asarray(CORNER_MIRRORS[corner])
    seen = mirror_features(group_features(groups[corner], position, rotation), m)
    mirrored = group_features(groups["fl"], position * m, rotation * m[:, None] * m[None, :])
    np.testing.assert_allclose(seen, mirrored, atol=1e-12)
