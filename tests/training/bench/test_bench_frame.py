"""`impactnet bench frame` (issue #34, items 4 and 5): its yards have the bodies they name and
stacks that stand; its MuJoCo harness answers what a direct MuJoCo call answers; the sweep's
candidates and the fit are what they say; every stage of the profile runs; the quick run writes
its report, and over HTTP the server answers the frame's pairs."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from impactnet.models.dispatch import Dispatcher
from impactnet.models.frame import answer_frame
from impactnet.training.bench.frame import scaling, section, speed, worlds

mujoco = pytest.importorskip("mujoco")

#: Contacts of two MuJoCo calls on the same world agree to this (m): the same model and poses,
#: qpos written by the harness or set by the model's own body poses (rounding of the pose).
CONTACT_TOL_M = 1e-9
#: The spreader's lowest point below the stack's top (m) in the harness's test: its frame, 9 cm
#: above its twistlock heads' tips, then presses 1 cm into the top container at every detail.
SPREADER_PRESS_M = 0.1
#: The yard's pitch across and along (m): a stack's place on the grid.
PITCH = np.array([12.192 + 0.6, 2.438 + 0.4])
TINY_FRAME = replace(speed.QUICK_FRAME, containers=20, guided_stacks=1, rows=2, budget_s=0.05,
                     min_calls=2, max_calls=5, profile_repeats=1)
TINY_SCALING = scaling.ScalingPlan(frame_sizes=(10, 60), broadphase_sizes=(10, 60, 200, 400),
                                   frame_variants=("boxes",), frame_budget_s=0.01,
                                   frame_calls=(2, 3), broadphase_budget_s=0.01,
                                   broadphase_calls=(3, 5))


@pytest.mark.parametrize("bodies, rows", [(10, 1), (57, 3), (209, 4), (1000, 8)])
def test_a_counted_yard_has_the_bodies_it_names_and_stacks_that_stand(bodies, rows):
    found = worlds.counted_yard(worlds.variant_shapes("boxes"), bodies, rows, seed=bodies,
                                guided_stacks=1 if bodies < 30 else 2)
    frame = found.frame(False)
    assert len(frame) == bodies and len(found.moving) == 1
    assert sum(i.startswith("g") for i in frame.ids) == (4 if bodies < 30 else 8)
    containers = np.array([i.startswith("c") for i in frame.ids])
    position = frame.position[containers]
    cell = np.rint(position[:, :2] / PITCH).astype(int)
    pitch_z = 2.591 - 0.002
    for key in {tuple(c) for c in cell}:  # every stack's levels are 0, 1, ..., top
        z = np.sort(position[(cell == key).all(axis=1), 2])
        np.testing.assert_allclose(np.diff(z), pitch_z, atol=1e-9)
        assert abs(z[0] - 0.5 * 2.591) < 1e-9 and len(z) <= 6


def _direct_contacts(bodies):
    """MuJoCo on the harness's world with each free body placed by its own ``pos`` / ``quat``
    (qpos0), then ``mj_forward``: (dist (k,), geom (k, 2)) sorted."""
    from impactnet.training.bench.frame.mujoco_world import world_xml

    xml = world_xml(bodies)
    for i in np.flatnonzero(~bodies.static):
        pose = (f' pos="{" ".join(map(repr, bodies.position[i].tolist()))}" quat="'
                f'{" ".join(map(repr, bodies.quaternion[i].tolist()))}"')
        xml = xml.replace(f'<body name="b{i}"><freejoint/>', f'<body name="b{i}"{pose}>'
                          '<freejoint/>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    geom = np.array(data.contact.geom).reshape(-1, 2)
    order = np.lexsort((geom[:, 1], geom[:, 0], np.array(data.contact.dist)))
    return np.array(data.contact.dist)[order], geom[order]


@pytest.mark.parametrize("variant", worlds.VARIANTS)
@pytest.mark.parametrize("static_world", [False, True])
def test_the_mujoco_frame_call_answers_what_a_direct_call_does(variant, static_world):
    from impactnet.training.bench.frame.mujoco_world import body_pairs_of, frame_call, world_model

    found = worlds.counted_yard(worlds.variant_shapes(variant), 40, 2, seed=5,
                                spreader_gap=-SPREADER_PRESS_M)
    bodies = found.frame(static_world)
    model, data, free = world_model(bodies)
    _, _, dist, geom = frame_call(model, data, free).checked(bodies.position,
                                                            bodies.quaternion)
    order = np.lexsort((geom[:, 1], geom[:, 0], dist))
    expected_dist, expected_geom = _direct_contacts(bodies)
    assert len(dist) == len(expected_dist) > 0
    np.testing.assert_array_equal(geom[order], expected_geom)
    np.testing.assert_allclose(dist[order], expected_dist, atol=CONTACT_TOL_M)
    pairs = body_pairs_of(model, geom)  # the frame's pairs at margin 0: the test module's claim
    assert pairs == {tuple(p) for p in answer_frame(Dispatcher(), bodies).index.tolist()}


def test_the_candidates_are_the_pairs_that_overlap_on_the_sweep_axis():
    from impactnet.models.frame import broadphase as bp

    found = worlds.counted_yard(worlds.variant_shapes("detail 2"), 300, 6, seed=2)
    bodies = found.frame(False)
    centre, half = bodies.envelopes
    n = len(bodies)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    bp.world_bounds(centre, half, bodies.position, bodies.rotation, 0.0, lo, hi)
    axis = bp._sweep_axis(lo, hi)
    i, j = np.triu_indices(n, 1)
    overlap = (lo[j, axis] <= hi[i, axis]) & (lo[i, axis] <= hi[j, axis])
    assert scaling.candidates(bodies) == int(overlap.sum())
    assert scaling.candidates(bodies) >= len(bp.body_pairs(centre, half, bodies.position,
                                                           bodies.rotation))


def test_the_fit_recovers_a_known_cost_law():
    rng = np.random.default_rng(3)
    n = np.array([100, 300, 1000, 3000, 10000, 30000], float)
    x = rng.uniform(1, 20, len(n)) * n
    t = 5e-6 + 3e-9 * n * np.log2(n) + 2e-9 * x
    points = [{"bodies": a, "ms": 1e3 * b, "pairs": c} for a, b, c in zip(n, t, x)]
    got = scaling.fit(points, "pairs", 100)
    assert got["c_us"] == pytest.approx(5.0, rel=1e-6)
    assert got["a_ns"] == pytest.approx(3.0, rel=1e-6)
    assert got["b_ns"] == pytest.approx(2.0, rel=1e-6)
    assert got["max_rel_residual"] < 1e-9 and got["points"] == 6


def test_every_frame_stage_runs_and_the_whole_is_the_frame():
    from impactnet.training.bench.frame.stages import frame_stages

    found = worlds.counted_yard(worlds.variant_shapes("detail 2"), 40, 2, seed=1)
    bodies = found.frame(False)
    stages, whole = frame_stages(bodies, Dispatcher())
    assert len(stages) == 8
    for stage in stages.values():
        stage()
    expected = answer_frame(Dispatcher(), bodies)
    np.testing.assert_array_equal(whole().index, expected.index)
    # every container rests on the one beneath it: each such pair is among the frame's pairs
    found_pairs = {tuple(sorted(pair)) for pair in expected.index.tolist()}
    containers = np.flatnonzero([i.startswith("c") for i in bodies.ids])
    cell = np.rint(bodies.position[containers, :2] / PITCH).astype(int)
    z = bodies.position[containers, 2]
    stacked = {tuple(sorted((int(containers[i]), int(containers[j]))))
               for i in range(len(containers)) for j in range(len(containers))
               if (cell[i] == cell[j]).all() and abs(z[j] - z[i] - (2.591 - 0.002)) < 1e-9}
    assert stacked and stacked <= found_pairs


def test_a_quick_frame_bench_writes_its_report(tmp_path, monkeypatch):
    monkeypatch.setattr(section, "QUICK_SCALING", TINY_SCALING)
    monkeypatch.setattr(section, "QUICK_FRAME", TINY_FRAME)
    figure = tmp_path / "images" / "frame_scaling.png"
    assert section.run(True, tmp_path / "out", figure, seed=0, http=False,
                       command="impactnet bench frame --quick", log=lambda m: None) == 0
    text = (tmp_path / "out" / "frame.md").read_text(encoding="utf-8")
    assert "Command: `impactnet bench frame --quick`" in "\n".join(text.splitlines()[:8])
    assert "](../images/frame_scaling.png)" in text and figure.stat().st_size > 10_000
    assert text.count("(goal <= 2x)") == 3  # one per variant, in process
    figures = json.loads((tmp_path / "out" / "frame.json").read_text(encoding="utf-8"))
    for variant in worlds.VARIANTS:
        free = figures["speed"]["variants"][variant]["free"]
        assert free["pairs"]["same"] and free["ratio"] == free["ours_ms"] / free["mujoco_ms"]
    assert [r["bodies"] for r in figures["scaling"]["frames"]] == [10, 60]


@pytest.mark.slow
def test_over_http_the_server_answers_the_frames_pairs():
    from impactnet.training.bench.frame.frame_http import measure_http

    yards = {"detail 1": worlds.counted_yard(worlds.variant_shapes("detail 1"), 29, 2,
                                             seed=3, guided_stacks=1)}
    out = measure_http(yards, TINY_FRAME)
    assert "error" not in out, out.get("error")
    for kind in ("everything", "spreader"):
        entry = out["variants"]["detail 1"][kind]
        assert entry["same_pairs"] and entry["pairs"] >= 1
        assert entry["ratio"] == entry["http_ms"] / entry["mujoco_ms"]
        assert "stages" in entry["profile"], entry["profile"].get("note")
