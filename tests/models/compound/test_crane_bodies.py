"""The harbour's compound bodies against the standards' figures (ISO 668, 1161, 1496-1)."""
import numpy as np
import pytest

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.parts import bounds

MM = 1e-3


def _part(parts, name):
    return next(p for p in parts if p.name == name)


def _envelope(parts):
    lo = np.min([bounds(p)[0] for p in parts], axis=0)
    hi = np.max([bounds(p)[1] for p in parts], axis=0)
    return lo, hi


@pytest.mark.parametrize("kind", sorted(cb.CONTAINERS))
def test_container_fills_its_iso_668_envelope_with_castings_flush(kind):
    parts = cb.container(kind)
    length, width, height = cb.CONTAINERS[kind]
    lo, hi = _envelope(parts)
    np.testing.assert_allclose(hi - lo, [length, width, height], atol=1e-12)
    np.testing.assert_allclose(lo + hi, 0.0, atol=1e-12)  # centred
    castings = [p for p in parts if p.name.startswith("casting_")]
    assert len(castings) == 8
    for casting in castings:
        np.testing.assert_allclose(casting.size, (0.178, 0.162, 0.118))
        c_lo, c_hi = bounds(casting)
        # flush: each casting reaches the envelope on three faces
        flush = np.isclose(c_lo, lo, atol=1e-12) | np.isclose(c_hi, hi, atol=1e-12)
        assert flush.all(), casting.name


@pytest.mark.parametrize("kind", sorted(cb.CONTAINERS))
def test_container_body_clears_the_castings_by_the_iso_1496_figures(kind):
    parts = cb.container(kind)
    _, _, height = cb.CONTAINERS[kind]
    body_lo, body_hi = bounds(_part(parts, "body"))
    assert np.isclose(height / 2 - body_hi[2], 6 * MM)  # roof 6 mm below the top castings
    assert np.isclose(body_lo[2] + height / 2, 12.5 * MM)  # base 12.5 mm above the bottom


def test_stacked_containers_touch_on_their_castings_alone():
    """Lower container's top at z = H/2; the upper one set down on it: only castings reach
    the interface plane, so stacking is castings on castings."""
    parts = cb.container("40ft")
    height = cb.CONTAINERS["40ft"][2]
    at_top = [p.name for p in parts if np.isclose(bounds(p)[1][2], height / 2)]
    at_bottom = [p.name for p in parts if np.isclose(bounds(p)[0][2], -height / 2)]
    assert sorted(at_top) == sorted(n for n in (p.name for p in parts) if "top" in n)
    assert sorted(at_bottom) == sorted(n for n in (p.name for p in parts) if "bottom" in n)


def test_apertures_sit_where_iso_1161_puts_them():
    length, width, _ = cb.CONTAINERS["20ft"]
    centres = cb.aperture_centres("20ft")
    np.testing.assert_allclose(np.sort(np.abs(centres[:, 0])), length / 2 - 0.1015)
    np.testing.assert_allclose(np.sort(np.abs(centres[:, 1])), width / 2 - 0.089)


@pytest.mark.parametrize("sides", [8, 32, 256])
def test_a_twistlock_centred_in_its_aperture_clears_the_oval(sides):
    """The head's widest stadium lies inside the aperture's oval (Ø 124.5 mm cut by flats
    63.5 mm apart) at every one of its vertices, so a centred twistlock touches nothing."""
    section = cb.stadium(*cb.TWISTLOCK_HEAD_ASSUMED, sides)
    radius, flats = cb.APERTURE_DIAMETER / 2, cb.APERTURE_FLATS / 2
    assert (np.hypot(section[:, 0], section[:, 1]) < radius).all()
    assert (np.abs(section[:, 1]) < flats).all()
    np.testing.assert_allclose(np.ptp(section, axis=0), cb.TWISTLOCK_HEAD_ASSUMED)


def test_spreader_twistlocks_hang_below_the_frame_at_the_apertures():
    parts = cb.spreader("40ft", sides=16)
    frame_lo, _ = bounds(_part(parts, "frame"))
    heads = [p for p in parts if p.name.startswith("head_")]
    assert len(heads) == 4 and all(len(h.points) == 32 for h in heads)
    centres = np.array([bounds(h)[0][:2] + bounds(h)[1][:2] for h in heads]) / 2
    np.testing.assert_allclose(np.sort(centres, axis=0),
                               np.sort(cb.aperture_centres("40ft"), axis=0), atol=1e-12)
    assert all(bounds(h)[1][2] < frame_lo[2] for h in heads)


def test_cell_guide_entry_leans_away_from_the_cell_at_its_angle():
    parts = cb.cell_guide(entry_angle_deg=30.0)
    entry = _part(parts, "entry_x").vertices()
    bottom, top = entry[entry[:, 2] < entry[:, 2].max()], entry[entry[:, 2] == entry[:, 2].max()]
    lean = bottom[:, 1].max() - top[:, 1].max()
    np.testing.assert_allclose(np.degrees(np.arctan2(lean, cb.ENTRY_RISE_ASSUMED)), 30.0)
    with pytest.raises(ValueError, match="entry angle"):
        cb.cell_guide(entry_angle_deg=90.0)


def test_every_assumed_figure_is_named():
    for name in cb.ASSUMPTIONS:
        assert name.startswith("the ") or hasattr(cb, name), name


def _in_cell(gap_along, gap_across, z=0.0):
    """A 40 ft container in the cell, its corner ``gap_along`` (x) and ``gap_across`` (y)
    from the guide's inner faces, its centre at height ``z``."""
    from impactnet.models.compound.oracle import compound_contacts

    length, width, _ = cb.CONTAINERS["40ft"]
    t = cb.GUIDE_THICKNESS
    centre = [t + gap_along + length / 2, t + gap_across + width / 2, z]
    guide = cb.cell_guide()
    found = compound_contacts(guide, np.zeros(3), [1.0, 0, 0, 0], cb.container("40ft"), centre,
                              [1.0, 0, 0, 0])
    return guide, found


def test_a_container_in_its_cell_clears_the_guide_by_the_issue_clearances():
    _, found = _in_cell(cb.GUIDE_CLEARANCE_ALONG, cb.GUIDE_CLEARANCE_ACROSS)
    assert len(found.pose) == 0
    guide, found = _in_cell(cb.GUIDE_CLEARANCE_ALONG, -0.1 * MM)  # pushed across onto the angle
    assert {guide[k].name for k in found.part_a} == {"leg_x"}
    np.testing.assert_allclose(found.contacts.normal, np.tile([0, 1.0, 0], (len(found.pose), 1)),
                               atol=1e-12)


def test_the_entry_guide_steers_a_container_lowered_off_line_into_the_cell():
    """Lowered 60 mm too far across, the container's bottom edge lands on the chamfered entry:
    the normal pushes it back across and up, at the chamfer's angle."""
    height = cb.CONTAINERS["40ft"][2]
    top = cb.GUIDE_HEIGHT_ASSUMED / 2 + cb.ENTRY_RISE_ASSUMED / 2
    guide, found = _in_cell(cb.GUIDE_CLEARANCE_ALONG, -60 * MM, z=top + height / 2 - 0.05)
    names = {guide[k].name for k in found.part_a}
    assert names == {"entry_x"}, names
    normal = found.contacts.normal[np.argmax(found.contacts.depth)]
    assert normal[1] > 0.5 and normal[2] > 0.3  # back across and up
    np.testing.assert_allclose(np.degrees(np.arctan2(normal[2], normal[1])), 30.0, atol=1e-6)
