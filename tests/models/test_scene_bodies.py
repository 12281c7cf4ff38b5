"""Scene bodies: boxes and compound bodies, part groups and the extents that tolerances use."""
import numpy as np
import pytest

from impactnet.models.compound.parts import BoxPart
from impactnet.models.scene_bodies import Body, group_extents, part_group
from impactnet.models.scenes import load_scene


def test_generated_pieces_group_under_their_part():
    assert part_group("casting_top_fl/ring_6") == "casting_top_fl"
    assert part_group("casting_bottom_fl") == "casting_bottom_fl"


def test_a_detail_two_casting_counts_with_its_full_bounds_not_a_piece():
    forty = load_scene("quay_crane_detail").body("container40")
    extents = group_extents(forty.parts)
    np.testing.assert_allclose(extents["casting_top_fl"], (0.178, 0.162, 0.118), atol=1e-12)
    assert forty.touching_extent("casting_top_fl/ring_6") == pytest.approx(0.118)
    assert forty.touching_extent("casting_bottom_ar") == pytest.approx(0.118)
    assert forty.touching_extent("body") == pytest.approx(min(extents["body"]))
    assert forty.touching_extent() == pytest.approx(0.118)  # the tightest of the body


def test_a_box_body_counts_with_its_shortest_edge_whatever_part_is_named():
    box = Body("plate", (4.0, 4.0, 0.1))
    assert not box.is_compound
    assert box.touching_extent() == box.touching_extent("anything") == 0.1


def test_an_unknown_part_is_a_key_error_naming_the_body():
    body = Body("b", (1.0, 1.0, 1.0), parts=(BoxPart("p", (1.0, 1.0, 1.0)),))
    assert body.is_compound
    with pytest.raises(KeyError, match="body 'b' has no part 'q'"):
        body.touching_extent("q")
