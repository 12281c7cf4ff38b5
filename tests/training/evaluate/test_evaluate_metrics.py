"""`impactnet evaluate`'s measures on hand-made cases: an exact copy has no error, a known
perturbation shows exactly that error, type and region mistakes are counted as such."""
import dataclasses

import numpy as np
import pytest

from impactnet.models.box.exact import box_box
from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.scenes import load_scene
from impactnet.training.evaluate import metrics as em
from impactnet.training.evaluate.data import (
    INPUTS,
    boundary_distance,
    datagen_config,
    held_out_rows,
)
from impactnet.training.evaluate.run import check_goals

ROWS = 600


@pytest.fixture(scope="module")
def cube_rows():
    scene = load_scene("quay_crane")
    index = [p.key for p in scene.pairs].index("cube/cube")
    return held_out_rows(scene, index, ROWS, seed=7, datagen=datagen_config({}))


def exact_answer(data):
    return box_box(*(data[k] for k in INPUTS))


def test_a_copy_of_the_exact_solver_has_no_error_and_full_accuracy(cube_rows):
    s = em.summaries(em.row_record(exact_answer(cube_rows), cube_rows, "exact"))
    assert s["type_accuracy"] == s["region_accuracy"] == 1.0
    assert s["missed_contacts"] == s["false_contacts"] == 0
    assert s["both_colliding"] == s["contacts"] == int(cube_rows["colliding"].sum())
    for key in ("normal_deg", "point_pct", "depth_pct", "depth_mm"):
        assert s[key]["max"] == 0.0
    assert s["fallback_share"] == 0.0


def _rotate_about_perpendicular(normal, angle):
    """Unit normals (n, 3) turned by ``angle`` radians about an axis perpendicular to each."""
    helper = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    axis = np.cross(normal, helper)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    return np.cos(angle) * normal + np.sin(angle) * np.cross(axis, normal)


def test_a_known_perturbation_shows_exactly_that_error(cube_rows):
    c = exact_answer(cube_rows)
    edge = cube_rows["edge"]
    shift = np.array([0.6, 0.0, 0.8])  # unit vector
    perturbed = dataclasses.replace(c, normal=_rotate_about_perpendicular(c.normal,
                                                                          np.radians(2.0)),
                                    point=c.point + 0.01 * edge * shift, depth=c.depth + 0.003)
    record = em.row_record(perturbed, cube_rows, "committee")
    s = em.summaries(record)
    assert s["normal_deg"]["median"] == pytest.approx(2.0, abs=1e-4)
    assert s["normal_deg"]["max"] == pytest.approx(2.0, abs=1e-4)
    assert s["point_pct"]["mean"] == pytest.approx(1.0, rel=1e-5)
    assert s["depth_mm"]["p99"] == pytest.approx(3.0, rel=1e-4)
    assert s["depth_pct"]["median"] == pytest.approx(100 * 0.003 / edge, rel=1e-4)
    assert s["region_accuracy"] == 1.0  # labels untouched


def test_contact_mistakes_are_type_errors_without_point_errors(cube_rows):
    c = exact_answer(cube_rows)
    colliding = c.colliding.copy()
    hit, miss = np.flatnonzero(colliding)[:10], np.flatnonzero(~colliding)[:4]
    colliding[hit] = False
    colliding[miss] = True
    code = c.contact_type_code.copy()
    code[hit] = 0
    code[miss] = CONTACT_TYPES.index("vertex-face")
    record = em.row_record(dataclasses.replace(c, colliding=colliding, contact_type_code=code),
                           cube_rows, "committee")
    s = em.summaries(record)
    assert (s["missed_contacts"], s["false_contacts"]) == (10, 4)
    assert s["both_colliding"] == int(cube_rows["colliding"].sum()) - 10
    assert s["type_accuracy"] == pytest.approx(1 - 14 / ROWS)
    assert s["normal_deg"]["max"] == 0.0
    matrix = np.array(em.type_confusion(record))
    assert matrix[1:, 0].sum() == 10 and matrix[0, 1] == 4


def test_a_relabelled_feature_is_a_region_error_listed_among_the_confusions(cube_rows):
    c = exact_answer(cube_rows)
    rows = np.flatnonzero(c.colliding)[:15]
    feature_b = c.feature_b.copy()
    feature_b[rows] = np.where(feature_b[rows] == 0, 1, 0)  # another feature, same type
    record = em.row_record(dataclasses.replace(c, feature_b=feature_b), cube_rows, "committee")
    s = em.summaries(record)
    assert s["type_accuracy"] == 1.0
    assert s["region_accuracy"] == pytest.approx(1 - 15 / ROWS)
    distance = boundary_distance(cube_rows)["distance"]
    breakdown = em.mismatch_breakdown(record, distance, (1.0, 2.0), 1e-3)
    assert breakdown["region_mismatches"] == breakdown["same_type_other_features"] == 15
    assert breakdown["benign_within_tolerance"] == 15  # same point and normal: a relabelling
    top = em.top_confusions(record)
    assert 0 < sum(t["rows"] for t in top) <= 15
    assert all(t["exact"] != t["predicted"] and t["exact"].split(":")[:2]
               == t["predicted"].split(":")[:2] for t in top)


def test_fallbacks_are_the_rows_a_learned_predictor_hands_to_exact(cube_rows):
    c = exact_answer(cube_rows)
    answered = np.where(np.arange(ROWS) % 4 == 0, "exact", "committee")
    record = em.row_record(dataclasses.replace(c, predictor=answered), cube_rows, "auto")
    assert em.summaries(record)["fallback_share"] == pytest.approx(0.25)
    assert em.summaries(em.row_record(c, cube_rows, "exact"))["fallback_share"] == 0.0


def test_a_predictor_without_types_has_no_accuracies(cube_rows):
    c = exact_answer(cube_rows)
    untyped = dataclasses.replace(c, colliding=np.ones(ROWS, bool),
                                  contact_type_code=np.zeros(ROWS, np.int8))
    record = em.row_record(untyped, cube_rows, "single")
    s = em.summaries(record)
    assert s["type_accuracy"] is None and s["region_accuracy"] is None
    assert em.type_confusion(record) is None and em.top_confusions(record) == []


def test_boundary_distance_of_a_face_resting_on_a_face():
    # Cubes of edge 2; B 1 cm deep on A's top face, offset (0.3, 0.1): overlaps 1.7, 1.9, 0.01
    # on the face axes, so the SAT margin is 1.69 m; B's four bottom vertices are 1 cm deep,
    # so the vertex gap (2nd / 3rd deepest) is 0.01 m; e = 2 m.
    size, identity = np.array([[2.0, 2.0, 2.0]]), np.array([[1.0, 0, 0, 0]])
    inputs = dict(zip(INPUTS, (size, np.zeros((1, 3)), identity, size,
                               np.array([[0.3, 0.1, 1.99]]), identity)))
    c = box_box(*inputs.values())
    data = {**inputs, **{k: getattr(c, k) for k in ("colliding", "normal", "axis")},
            "edge": 2.0}
    d = boundary_distance(data)
    assert d["sat_margin"][0] == pytest.approx(1.69 / 2)
    assert d["vertex_gap"][0] == pytest.approx(0.01 / 2)
    assert d["distance"][0] == pytest.approx(0.005)


def test_boundary_bins_are_decades_with_open_ends():
    index, labels = em.boundary_bins(np.array([0.0, 5e-7, 2e-6, 0.5, 3.0, np.nan]))
    assert index.tolist() == [0, 0, 1, 6, 7, -1]
    assert len(labels) == len(em.BOUNDARY_EDGES) + 1


def test_goals_compare_each_figure_with_its_bound():
    results = {"pooled": {"predictors": {"committee": {"region_accuracy": 0.99,
                                                       "normal_deg": {"median": 0.5}}}}}
    goals = {(g["goal"], g["predictor"]): g for g in check_goals(results)}
    assert goals[("region accuracy", "committee")]["met"] is True
    assert goals[("normal error median", "committee")]["met"] is False
    assert goals[("fallback share", "auto")] == {**goals[("fallback share", "auto")],
                                                 "value": None, "met": False}
