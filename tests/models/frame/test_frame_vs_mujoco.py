"""A frame against MuJoCo 4's ``mj_collision`` on the same world (issue #34, item 2): on seeded
yards, the pairs of bodies the frame answers (touching, or within the margin) are the pairs of
which MuJoCo reports a contact, and each frame pair answers what the pairwise dispatcher
answers for that pair alone.

The worlds (:func:`_yard`): stacks one to six high on a 3 x 3 grid (10 x 16, ~570 bodies, in
the slow test), a spreader pressed :data:`SPREADER_PRESS_M` into the last stack (so that a
frame whose yard is static still holds a contact), and cell guides at the corners of two
stacks, in two variants:

* ``boxes``: the containers and the spreader of scene ``quay_crane`` (boxes); that scene has no
  cell guide, so the guides are scene ``quay_crane_detail``'s (two leg boxes, two convex entry
  plates);
* ``castings``: 40 ft containers at detail 1 (the body box and eight solid corner castings,
  ``crane_bodies.container("40ft", detail=1)``), scene ``quay_crane_detail``'s spreader (its
  twistlocks' heads 32-sided frustums) and cell guide.

The MuJoCo world is tests/models/frame/mujoco_world.py: one MuJoCo body per frame body, one
geom per part, every body on a free joint except those the frame marks static (welded to the
world body, so that MuJoCo skips the pairs inside the world as the frame does), every filter
that could hide a pair opened (contype/conaffinity 1, the parent filter off, no ``<exclude>``;
see that module), the geoms' margins summing to the frame's. A pair within
:data:`TOUCHING_BAND_M` of the boundary (its distance, ``-depth`` in contact, within that of
the margin) is left out: there the answer is a tie, not a disagreement.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest

from impactnet.models.compound import crane_bodies
from impactnet.models.dispatch import Dispatcher, Pairs
from impactnet.models.dispatch.shapes import Shape, scene_shapes
from impactnet.models.frame import Bodies, answer_frame
from impactnet.models.frame.yard import YardLayout, yard
from impactnet.models.scenes import load_scene

pytest.importorskip("mujoco")

from tests.models.frame.mujoco_world import touching_pairs  # noqa: E402 (needs mujoco)

#: A pair whose distance lies within this of the margin (m) is at the boundary of touching and
#: is left out of the comparison: there a rounding decides either way, in either solver.
TOUCHING_BAND_M = 1e-9
#: MuJoCo keeps mesh vertices as float32: a box part of 12.192 m given as a mesh about its
#: centre has its corners rounded by up to 2.4e-7 m (half a float32 step at 6 m). A pair within
#: this of the boundary (m) could be decided by that rounding; the seeded yards must hold none
#: outside :data:`TOUCHING_BAND_M` (checked), so that no comparison rests on it.
FLOAT32_BAND_M = 1e-6
#: The spreader's lowest point below the last stack's top (m): it presses into the stack, so
#: that a frame over a static yard has a moving-static contact to compare.
SPREADER_PRESS_M = 0.002
#: Margins of the comparison (m): 0.5 takes in the neighbouring stacks 0.4 m apart across the
#: rows, and not the ones 0.6 m apart along them.
MARGINS = (0.0, 0.5)
SMALL = YardLayout(rows=3, cols=3, spreader_gap=-SPREADER_PRESS_M)
LARGE = YardLayout(rows=10, cols=16, guided_stacks=8, spreader_gap=-SPREADER_PRESS_M)


@functools.cache
def _shapes(variant: str) -> dict[str, Shape]:
    """The named shapes of a variant (module docstring)."""
    detail = scene_shapes(load_scene("quay_crane_detail"))
    if variant == "boxes":
        return {**scene_shapes(load_scene("quay_crane")), "cell_guide": detail["cell_guide"]}
    castings = Shape(crane_bodies.container("40ft", detail=1), "container40")
    return {"container40": castings, "spreader": detail["spreader"],
            "cell_guide": detail["cell_guide"]}


def _yard(variant: str, seed: int, static_world: bool, layout: YardLayout = SMALL) -> Bodies:
    return yard(_shapes(variant), layout, seed).frame(static_world)


def _stacked(bodies: Bodies, layout: YardLayout) -> int:
    """The containers that rest on another one (each such pair touches)."""
    return sum(k.startswith("c") for k in bodies.ids) - layout.rows * layout.cols


def _pairs(index: np.ndarray) -> set[tuple[int, int]]:
    return {(int(i), int(j)) for i, j in index}


def _near_boundary(bodies: Bodies, margin: float, band: float) -> set[tuple[int, int]]:
    """The pairs whose distance (m; ``-depth`` in contact) lies within ``band`` of ``margin``,
    from a frame answered with the margin grown by ``band``."""
    wider = answer_frame(Dispatcher(), bodies, margin=margin + band)
    distance = wider.answers.body["distance"]
    return _pairs(wider.index[np.abs(distance - margin) <= band])


def _compare(bodies: Bodies, margin: float) -> tuple[set, set]:
    """(the frame's pairs, MuJoCo's pairs), both without the pairs at the boundary; fails if a
    pair lies within float32 rounding of the boundary (module docstring)."""
    ours = _pairs(answer_frame(Dispatcher(), bodies, margin=margin).index)
    theirs = touching_pairs(bodies, margin)
    tied = _near_boundary(bodies, margin, TOUCHING_BAND_M)
    rounded = _near_boundary(bodies, margin, FLOAT32_BAND_M) - tied
    assert not rounded, f"pairs within MuJoCo's float32 rounding of the boundary: {rounded}"
    return ours - tied, theirs - tied


@pytest.mark.parametrize("variant", ["boxes", "castings"])
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("static_world", [False, True])
@pytest.mark.parametrize("margin", MARGINS)
def test_a_small_yard_has_the_pairs_mujoco_finds(variant, seed, static_world, margin):
    bodies = _yard(variant, seed, static_world)
    ours, theirs = _compare(bodies, margin)
    assert ours == theirs, (f"only the frame: {sorted(ours - theirs)}; only MuJoCo: "
                            f"{sorted(theirs - ours)}")
    spreader = len(bodies) - 1
    assert any(spreader in pair for pair in ours)  # the pressed spreader is compared
    if not static_world:  # every stacked container rests on the one below it
        assert len(ours) >= _stacked(bodies, SMALL)


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["boxes", "castings"])
@pytest.mark.parametrize("margin", MARGINS)
def test_a_large_free_yard_has_the_pairs_mujoco_finds(variant, margin):
    bodies = _yard(variant, 7, False, LARGE)
    ours, theirs = _compare(bodies, margin)
    assert ours == theirs, (f"only the frame: {sorted(ours - theirs)}; only MuJoCo: "
                            f"{sorted(theirs - ours)}")
    assert len(ours) >= _stacked(bodies, LARGE)


def _named(answers, column: str) -> list:
    """A part column's codes as part names (codes index a table that each answer builds in its
    own order; the names are what the codes mean)."""
    codes = answers.body[column]
    return [str(answers.part_names[c]) if c >= 0 else None for c in codes]


def _alone(bodies: Bodies, i: int, j: int, margin: float):
    """The dispatcher's answer of the pair (i, j) sent alone, A = i."""
    pairs = Pairs(bodies.shapes, bodies.shape[[i]], bodies.shape[[j]], bodies.position[[i]],
                  bodies.quaternion[[i]], bodies.position[[j]], bodies.quaternion[[j]])
    return Dispatcher().answer(pairs, "exact", (), margin)


@pytest.mark.parametrize("variant", ["boxes", "castings"])
@pytest.mark.parametrize("margin", MARGINS)
def test_each_frame_pair_answers_what_the_dispatcher_answers_for_it_alone(variant, margin):
    bodies = _yard(variant, 4, False)
    frame = answer_frame(Dispatcher(), bodies, margin=margin)
    assert len(frame.index) >= _stacked(bodies, SMALL) > 0
    for row, (i, j) in enumerate(frame.index):
        alone = _alone(bodies, int(i), int(j), margin)
        for name, column in frame.answers.body.items():
            if name in ("part_a", "part_b"):
                assert _named(frame.answers, name)[row] == _named(alone, name)[0], name
            else:  # bit for bit (NaN where both have none)
                np.testing.assert_array_equal(column[row], alone.body[name][0], err_msg=name)
        assert frame.answers.predictor_of(row) == alone.predictor_of(0)
        assert frame.answers.offsets[row + 1] - frame.answers.offsets[row] == \
            alone.offsets[1] - alone.offsets[0]
