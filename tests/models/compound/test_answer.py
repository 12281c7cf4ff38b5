"""The library entry: one call gives the summary and the named part contacts of each pose."""
import numpy as np

from impactnet.models.compound import compound_answer, container, spreader
from impactnet.models.compound import crane_bodies as cb


def test_a_spreader_landing_off_centre_names_the_heads_and_castings_it_touches():
    box = container("40ft", detail=2)
    lift = cb.CONTAINERS["40ft"][2] / 2 + cb.SPREADER_FRAME_HEIGHT_ASSUMED / 2 + 0.005
    shifts = np.array([[0.0, 0.0, lift], [0.0, 0.0045, lift]])  # centred; 0.75 mm onto a flat
    answer = compound_answer(box, np.zeros(3), [1.0, 0, 0, 0], spreader("40ft", sides=32),
                             shifts, [1.0, 0, 0, 0])
    assert len(answer) == 2
    assert not answer.summary.colliding[0] and answer.contacts_of(0) == []
    found = answer.contacts_of(1)
    assert {c["part_b"] for c in found} == {"head_fl", "head_fr", "head_al", "head_ar"}
    assert all(c["part_a"].startswith("casting_top_") for c in found)
    depths = [c["depth"] for c in found]
    assert depths == sorted(depths, reverse=True)
    np.testing.assert_allclose(answer.summary.depth[1], depths[0])
    np.testing.assert_allclose(depths[0], 0.0045 - 0.00375, rtol=1e-6)
