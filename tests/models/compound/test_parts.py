"""Validation of compound parts: clear errors naming the part."""
import numpy as np
import pytest

from impactnet.models.compound.parts import BoxPart, ConvexPart, PartError, validate_parts

CUBE = tuple((x, y, z) for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0))


def test_overlapping_parts_are_allowed():
    parts = validate_parts("b", [BoxPart("body", (2, 1, 1)), BoxPart("lug", (0.5, 0.5, 0.5),
                                                                       (1.0, 0.0, 0.5))])
    assert [p.name for p in parts] == ["body", "lug"]


def test_a_part_wholly_inside_another_is_refused_by_name():
    with pytest.raises(PartError, match="'inner'.*wholly inside part 'outer'") as info:
        validate_parts("b", [BoxPart("outer", (2, 2, 2)), BoxPart("inner", (1, 1, 1))])
    assert info.value.part == "inner"


def test_a_part_sharing_only_a_face_is_not_inside():
    validate_parts("b", [BoxPart("a", (1, 1, 1)), BoxPart("b", (1, 1, 1), (1.0, 0.0, 0.0))])


@pytest.mark.parametrize("points", [
    tuple((x, y, 0.0) for x in (0.0, 1.0) for y in (0.0, 1.0)),  # a square: flat
    ((0.0, 0, 0), (1.0, 0, 0), (2.0, 0, 0), (3.0, 0, 0)),  # a line
])
def test_a_flat_polyhedron_is_refused(points):
    with pytest.raises(PartError, match="flat"):
        validate_parts("b", [ConvexPart("plate", points)])


def test_too_few_points_and_bad_sizes_are_refused():
    with pytest.raises(PartError, match=">= 4 points"):
        validate_parts("b", [ConvexPart("tri", ((0, 0, 0), (1, 0, 0), (0, 1, 1)))])
    with pytest.raises(PartError, match="outside"):
        validate_parts("b", [BoxPart("huge", (2e6, 1, 1))])
    with pytest.raises(PartError, match="finite"):
        validate_parts("b", [BoxPart("nan", (np.nan, 1, 1))])
    with pytest.raises(PartError, match="unique"):
        validate_parts("b", [BoxPart("x", (1, 1, 1)), ConvexPart("x", CUBE)])
