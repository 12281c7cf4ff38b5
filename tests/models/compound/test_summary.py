"""The body-level summary of compound contacts (docs/design.md's rule)."""
import numpy as np

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.oracle import compound_contacts
from impactnet.models.compound.parts import BoxPart, validate_parts
from impactnet.models.compound.summary import summarise

IDENTITY = [1.0, 0.0, 0.0, 0.0]
FORTY = cb.container("40ft")
HEIGHT = cb.CONTAINERS["40ft"][2]


def test_aligned_stacking_sums_four_equal_casting_contacts_to_the_middle():
    found = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, [0, 0, HEIGHT - 1e-3],
                              IDENTITY)
    s = summarise(found)
    assert s.colliding[0] and s.cluster_size[0] == 4
    np.testing.assert_allclose(s.normal[0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(s.depth[0], 1e-3, rtol=1e-9)
    np.testing.assert_allclose(s.point[0], [0, 0, HEIGHT / 2 - 0.5e-3], atol=1e-9)


def test_the_summary_weights_each_casting_by_its_pressure_integral():
    """B tilted about y: one end deeper; the point moves towards the deeper castings, between
    the shallow and the deep end, by the pressure integrals, not halfway."""
    tilt = 2e-4
    q = [np.cos(tilt / 2), 0.0, np.sin(tilt / 2), 0.0]
    found = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, [0, 0, HEIGHT - 2e-3], q)
    s = summarise(found)
    c = found.contacts
    expected = (c.pressure[:, None] * c.point).sum(axis=0) / c.pressure.sum()
    np.testing.assert_allclose(s.point[0], expected, atol=1e-12)
    deep = c.depth.argmax()
    assert np.sign(s.point[0, 0]) == np.sign(c.point[deep, 0])


def test_opposing_contacts_follow_the_deeper_side_and_flip_where_the_depths_swap():
    """A box wedged between two walls, touching both (as a twistlock in its aperture): the
    summary takes the deeper side's normal alone and flips as the box crosses the middle."""
    walls = validate_parts("slot", [BoxPart("left", (0.2, 1, 1), (-0.6, 0, 0)),
                                    BoxPart("right", (0.2, 1, 1), (0.6, 0, 0))])
    block = validate_parts("block", [BoxPart("block", (1.004, 0.5, 0.5))])
    shifts = np.array([-1e-3, -1e-6, 1e-6, 1e-3])
    found = compound_contacts(walls, np.zeros(3), IDENTITY, block,
                              np.c_[shifts, np.zeros((4, 2))], IDENTITY)
    s = summarise(found)
    assert (np.diff(found.offsets) == 2).all()  # both walls touch in every pose
    assert (s.cluster_size == 1).all()
    np.testing.assert_allclose(s.normal[:, 0], [1, 1, -1, -1], atol=1e-12)
    np.testing.assert_allclose(s.depth, 2e-3 + np.abs(shifts), rtol=1e-9)


def test_poses_without_contact_summarise_to_nothing():
    found = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY,
                              [[0, 0, HEIGHT + 1e-3], [0, 0, HEIGHT - 1e-3]], IDENTITY)
    s = summarise(found)
    np.testing.assert_array_equal(s.colliding, [False, True])
    assert not s.normal[0].any() and s.depth[0] == 0.0


def test_a_turned_twistlock_presses_both_flats_and_the_summary_flips_with_the_deeper_side():
    """A twistlock head turned 10 degrees in its aperture reaches across both flats (its caps
    at 24 sin 10 deg + 28 = 32.2 mm from the axis, the flats at 31.75): two opposed contacts.
    Moved 0.1 mm across, one side is deeper; the summary follows it and flips sign."""
    head = validate_parts("twistlock", [cb.twistlock_head((0.0, 0.0), 0.0, 32, "head")])
    box = cb.container("40ft", detail=2)
    centre = cb.aperture_centres("40ft")[0]  # the front-left (+x, +y) aperture
    yaw = np.radians(10.0)
    q = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    shifts = np.array([-1e-4, 1e-4])
    position = np.c_[np.full(2, centre[0]), centre[1] + shifts, np.full(2, HEIGHT / 2 - 0.005)]
    found = compound_contacts(box, np.zeros(3), IDENTITY, head, position, q)
    s = summarise(found)
    for pose in range(2):
        normals = found.contacts.normal[found.of_pose(pose)]
        assert normals[:, 1].max() > 0.9 and normals[:, 1].min() < -0.9  # both flats
    # the head moved towards -y presses the -y flat harder: pushed back along +y, and v.v.
    assert s.normal[0, 1] > 0.9 and s.normal[1, 1] < -0.9
