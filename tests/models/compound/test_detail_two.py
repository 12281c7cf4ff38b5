"""Detail level 2: the top castings' apertures as convex pieces. Analytic cases: stacking
presses at the centre of pressure of the ring around each aperture; a twistlock centred in
its aperture touches nothing, one pushed against its side touches the pieces there."""
import numpy as np
import pytest

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.casting_detail import aperture_polygon
from impactnet.models.compound.oracle import compound_contacts
from impactnet.models.compound.summary import summarise

FORTY = cb.container("40ft", detail=2)
HEIGHT = cb.CONTAINERS["40ft"][2]
IDENTITY = [1.0, 0.0, 0.0, 0.0]
#: Spreader frame's underside above the containers' top (m): the heads hang in the apertures.
HOVER_M = 0.005


def _polygon_area_centroid(points):
    x, y = points[:, 0], points[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = 0.5 * cross.sum()
    return area, np.array([((x + np.roll(x, -1)) * cross).sum(),
                           ((y + np.roll(y, -1)) * cross).sum()]) / (6 * area)


def _ring_centre(casting_centre, aperture_centre):
    """The area centroid of a casting's top face without its aperture (x, y), metres."""
    length, width = cb.CASTING[:2]
    outer = length * width
    hole_area, hole_centroid = _polygon_area_centroid(
        aperture_polygon(cb.APERTURE_DIAMETER, cb.APERTURE_FLATS))
    return (outer * casting_centre - hole_area * (aperture_centre + hole_centroid)) / (
        outer - hole_area)


def test_aligned_stacking_presses_at_the_centre_of_pressure_of_each_ring():
    push = 1e-3
    found = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, [0, 0, HEIGHT - push],
                              IDENTITY)
    c = found.contacts
    np.testing.assert_allclose(c.depth, push, rtol=1e-9)
    names = [FORTY[k].name for k in found.part_a]
    assert all(name.split("/")[0].startswith("casting_top") for name in names)
    length, width, _ = cb.CONTAINERS["40ft"]
    for (sx, sy, corner), aperture in zip(cb._corners(), cb.aperture_centres("40ft")):
        rows = [k for k, name in enumerate(names) if name.startswith(f"casting_top_{corner}/")]
        assert len(rows) == 10  # every piece of the ring
        weight = c.pressure[rows]
        point = (weight[:, None] * c.point[rows]).sum(axis=0) / weight.sum()
        casting = np.array([sx * (length - cb.CASTING[0]) / 2, sy * (width - cb.CASTING[1]) / 2])
        np.testing.assert_allclose(point[:2], _ring_centre(casting, aperture), atol=1e-9)
        np.testing.assert_allclose(point[2], HEIGHT / 2 - push / 2, atol=1e-12)
    summary = summarise(found)
    np.testing.assert_allclose(summary.normal[0], [0, 0, 1.0], atol=1e-12)
    np.testing.assert_allclose(summary.point[0, :2], 0.0, atol=1e-9)


@pytest.mark.parametrize("sides", [8, 32, 128, 256])
def test_a_twistlock_centred_in_its_aperture_touches_nothing(sides):
    spreader = cb.spreader("40ft", sides=sides)
    lift = HEIGHT / 2 + cb.SPREADER_FRAME_HEIGHT_ASSUMED / 2 + HOVER_M
    found = compound_contacts(FORTY, np.zeros(3), IDENTITY, spreader, [0, 0, lift], IDENTITY)
    assert len(found.pose) == 0


def test_a_twistlock_pushed_across_touches_the_aperture_side_with_opposed_normals():
    spreader = cb.spreader("40ft", sides=32)
    lift = HEIGHT / 2 + cb.SPREADER_FRAME_HEIGHT_ASSUMED / 2 + HOVER_M
    clearance = (cb.APERTURE_FLATS - cb.TWISTLOCK_HEAD_ASSUMED[1]) / 2
    found = compound_contacts(FORTY, np.zeros(3), IDENTITY, spreader,
                              [0, clearance + 1e-4, lift], IDENTITY)
    c = found.contacts
    assert len(found.pose) >= 4  # each head on its aperture's +y flat
    heads = {spreader[k].name for k in found.part_b}
    assert heads == {"head_fl", "head_fr", "head_al", "head_ar"}
    # the flat pushes the head back: the normal from the casting towards the head is -y
    assert (c.normal[:, 1] < -0.99).all()
    np.testing.assert_allclose(c.depth.max(), 1e-4, rtol=1e-6)
