"""Tests of `impactnet bench`: the quick run end to end, errors against the exact solver,
the polygon method, the learned predictors picked up from a bundle, and the CLI glue."""
from __future__ import annotations

import argparse
import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.box.exact import box_box
from impactnet.training.bench.accuracy import errors as er
from impactnet.training.bench.cli import add_arguments, run
from impactnet.training.bench.measure import QUICK, with_overrides
from impactnet.training.bench.methods import (
    Answer,
    exact_method,
    learned_methods,
    predictor_method,
)
from impactnet.training.bench.paper import grid_estimate as paper
from impactnet.training.bench.paper.polygon import PolygonConfig, PolygonMethod, grid_mesh
from impactnet.training.bench.pose_sets import figure2_poses, figure2_tilts
from impactnet.training.bench.runner import run_bench

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
#: The perturbation of the test predictor: the point moved by 1 cm, the normal turned by 1 deg.
SHIFT_M = 0.01
TURN_DEG = 1.0
#: Round-off allowance of the error arithmetic (degrees, per cent).
ROUNDOFF = 1e-9
#: A tiny plan for programmatic runs (seconds); the speed section is left out (the quick run
#: and tests/training/bench/test_speed_vs_mujoco.py cover it).
TINY = replace(with_overrides(QUICK, scene_poses=600, figure2_tilts=6, figure2_per_tilt=10,
                              single_calls=20, loop_single_calls=5, single_warmup=2,
                              batch_repeats=1, fcl_poses=60, polygon_poses=12,
                              polygon_figure2_poses=6, grid_sizes=(1, 4)), speed=None)


def perturbed(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """The exact solver, with every point moved by SHIFT_M and every normal turned by TURN_DEG."""
    contacts = box_box(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    normal = np.atleast_2d(contacts.normal)
    helper = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    axis = np.cross(normal, helper)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    contacts.normal = Rotation.from_rotvec(np.radians(TURN_DEG) * axis).apply(normal)
    contacts.point = contacts.point + SHIFT_M * axis  # any unit direction will do
    return contacts


def _parse(argv):
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    return parser.parse_args(argv)


@pytest.fixture(scope="module")
def quick_cli(tmp_path_factory):
    """`impactnet bench --quick` through the CLI glue, as `make` / the smoke test runs it."""
    out = tmp_path_factory.mktemp("bench")
    return run(_parse(["--quick", "--out", str(out)])), out


@pytest.fixture(scope="module")
def tiny_with_perturbed():
    methods = [exact_method(), predictor_method("perturbed", perturbed)]
    return run_bench(TINY, methods=methods, log=lambda message: None)


# ------------------------------------------------------------------ the quick run, end to end


def _table_rows(markdown: str, header_start: str) -> list[list[str]]:
    """Cells of the Markdown table whose header starts with ``header_start``."""
    lines = markdown.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    table = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        table.append([c.strip() for c in line.strip().strip("|").split("|")])
    return table


def test_quick_run_writes_well_formed_table_json_and_pngs(quick_cli):
    rc, out = quick_cli
    assert rc == 0
    markdown = (out / "results.md").read_text(encoding="utf-8")
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    assert results["mode"] == "quick" and results["seconds"] < 60
    for key in ("cpu", "cores", "numpy", "python-fcl", "python"):
        assert results["machine"][key]
    names = {r["method"] for r in results["rows"]}
    assert {"exact", "fcl box-box", "single", "committee", "auto"} <= names
    assert {f"polygon n={n}" for n in (1, 2, 4, 8, 16, 32, 64)} <= names
    table = _table_rows(markdown, "| method |")
    assert all(len(cells) == len(table[0]) for cells in table)  # every row as wide as the head
    assert {cells[0] for cells in table[2:]} == names
    for row in results["rows"]:
        assert row["status"] == "ok" or row["status"].startswith("not available: ")
        if row["family"] in ("exact", "fcl", "polygon"):
            assert row["status"] == "ok"
            assert row["us_n1"] > 0 and row["pairs_per_s"] > 0 and row["batch_n"] >= 1
    for name in ("pareto.png", "polygon_grid.png", "figure2_tilt.png"):
        data = (out / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 10_000


def test_quick_run_reports_subsamples_and_never_extrapolates(quick_cli):
    _, out = quick_cli
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    markdown = (out / "results.md").read_text(encoding="utf-8")
    for row in results["rows"]:
        if row["status"] == "ok" and row["family"] in ("fcl", "polygon"):
            assert row["batch_n"] <= row["set_size"]
            assert math.isclose(row["pairs_per_s"] * row["us_per_pair"], 1e6, rel_tol=1e-9)
    assert "(subsample)" in markdown


def test_quick_run_ends_with_the_speed_section_against_mujoco_from_python(quick_cli):
    pytest.importorskip("mujoco")
    _, out = quick_cli
    markdown = (out / "results.md").read_text(encoding="utf-8")
    speed = json.loads((out / "results.json").read_text(encoding="utf-8"))["speed"]
    assert "## Speed against MuJoCo called from Python (issue #32)" in markdown
    for head in ("| pose set | calls | box_box | MuJoCo from Python | box_box / MuJoCo "
                 "(goal <= 1.5x) |", "| pose set | N | threads | box_box | box_box, 1 thread | "
                 "MuJoCo mj_collision |", "| solver | stage | µs per unit |"):
        assert head in markdown
    assert [f["pose_set"] for f in speed["families"]] == ["scene", "stacking"]
    for family in speed["families"]:
        one, batch = family["one"], family["batch"]
        assert one["ratio"] == pytest.approx(one["ours_us"] / one["mujoco_us"], rel=1e-12)
        assert batch["ratio"] == pytest.approx(batch["ours_us"] / batch["mujoco_us"], rel=1e-12)
        assert f"| {family['pose_set']} | {batch['n']:,} | {batch['threads']} |" in markdown
    solvers = [p["solver"] for p in speed["profiles"]]
    assert solvers[0] == "box_box" and len(solvers) == 4
    assert all("stages" in p or "note" in p for p in speed["profiles"])


def test_exact_row_is_the_reference(quick_cli):
    _, out = quick_cli
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    for row in (r for r in results["rows"] if r["method"] == "exact"):
        e = row["errors"]
        assert e["normal_deg_p99"] == 0 and e["point_pct_p99"] == 0 and e["missed"] == 0
        assert e["type_accuracy"] == 1.0 and e["within_tolerance"] == 1.0
        assert row["n1_vs_exact"] == 1.0 and row["per_pair_vs_exact"] == 1.0


# ------------------------------------------------------------------ errors against exact


def test_perturbed_predictor_shows_its_perturbation_exactly():
    rng = np.random.default_rng(4)
    from impactnet.models.geometry.poses import first_contact_poses

    poses = first_contact_poses(300, [2.0, 2.0, 2.0], [1.0, 1.5, 0.5], rng)
    args = [poses[k] for k in ("size_a", "position_a", "quaternion_a", "size_b",
                               "position_b", "quaternion_b")]
    reference = Answer.from_contacts(box_box(*args))
    scale = np.minimum(poses["size_a"].min(1), poses["size_b"].min(1))
    errors = er.row_errors(Answer.from_contacts(perturbed(*args)), reference, scale)
    assert errors.counted.all() and not errors.missed.any()
    np.testing.assert_allclose(errors.normal_deg, TURN_DEG, atol=ROUNDOFF)
    np.testing.assert_allclose(errors.point_pct, 100 * SHIFT_M / scale, rtol=1e-9)
    same = er.row_errors(reference, reference, scale)
    assert np.all(same.normal_deg == 0) and np.all(same.point_pct == 0)


def test_perturbed_predictor_scores_worse_than_exact_in_a_run(tiny_with_perturbed):
    rows = {(r["method"], r["pose_set"]): r for r in tiny_with_perturbed["rows"]}
    for pose_set in ("scene", "figure2"):
        exact, bad = rows["exact", pose_set]["errors"], rows["perturbed", pose_set]["errors"]
        assert exact["normal_deg_median"] == 0 and exact["point_pct_median"] == 0
        assert bad["normal_deg_median"] == pytest.approx(TURN_DEG, abs=ROUNDOFF)
        assert bad["point_pct_median"] > 100 * SHIFT_M / 2.6  # 1 cm of edges <= 2.6 m
        assert bad["type_accuracy"] == 1.0  # the types are untouched


def test_missed_contacts_count_in_the_miss_rate_not_the_angles():
    reference = Answer(np.array([True, True, False]), np.zeros((3, 3)),
                       np.tile([0.0, 0.0, 1.0], (3, 1)), np.array([1, 3, 0]))
    answer = Answer(np.array([True, False, False]), np.zeros((3, 3)),
                    np.tile([0.0, 0.0, 1.0], (3, 1)), np.array([1, 0, 0]))
    summary = er.method_summary(er.row_errors(answer, reference, np.ones(3)), tolerance=(1.0, 2.0))
    assert (summary.contacts, summary.missed, summary.miss_rate) == (2, 1, 0.5)
    assert summary.normal_deg_p99 == 0 and summary.type_accuracy == 0.5
    assert summary.within_tolerance == 0.5  # the miss is outside the tolerance


def test_angle_error_is_accurate_for_tiny_angles():
    angle = 1e-9  # radians: arccos(cos(1e-9)) would round to 0
    a = np.array([[0.0, 0.0, 1.0]])
    b = np.array([[np.sin(angle), 0.0, np.cos(angle)]])
    assert er.angle_deg(a, b)[0] == pytest.approx(np.degrees(angle), rel=1e-6)


# ------------------------------------------------------------------ polygon method


def test_grid_mesh_covers_the_box_with_outward_triangles():
    vertices, triangles = grid_mesh([2.0, 1.0, 0.5], 3)
    assert len(triangles) == 12 * 3 * 3
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    assert np.all(np.einsum("ij,ij->i", normal, (a + b + c) / 3) > 0)  # outward
    area = np.sum(np.linalg.norm(normal, axis=1)) / 2
    assert area == pytest.approx(2 * (2 * 1 + 1 * 0.5 + 0.5 * 2))  # the box's whole surface


def test_polygon_n1_face_face_gives_a_sensible_point():
    """A 1 m cube 1 cm deep on a 2 m cube's top face, faces parallel: face-face."""
    depth, offset = 0.01, np.array([0.2, -0.1])
    size_a, size_b = np.full(3, 2.0), np.full(3, 1.0)
    q = np.array([1.0, 0.0, 0.0, 0.0])
    position_b = np.array([*offset, 1.0 + 0.5 - depth])
    hit, point, normal, count = PolygonMethod(PolygonConfig(1)).one(
        size_a, np.zeros(3), q, size_b, position_b, q)
    exact = box_box(size_a, np.zeros(3), q, size_b, position_b, q)
    assert exact.contact_type[0] == "face-face"
    assert hit and count > 0
    np.testing.assert_allclose(normal, [0.0, 0.0, 1.0], atol=1e-12)
    assert np.all(np.abs(point[:2] - offset) <= 0.5)  # inside B's footprint on A's face
    assert abs(point[2] - 1.0) <= depth  # within the overlap's depth of A's face
    assert np.linalg.norm(point - exact.point[0]) <= 0.5 * size_b[0]


def test_polygon_misses_are_reported_not_invented():
    q = np.array([1.0, 0.0, 0.0, 0.0])
    cube = np.full(3, 2.0)
    hit, point, normal, count = PolygonMethod(PolygonConfig(2)).one(
        cube, np.zeros(3), q, cube, np.array([0.0, 0.0, 2.5]), q)
    assert not hit and count == 0 and np.all(normal == 0)
    np.testing.assert_allclose(point, [0.0, 0.0, 1.25])


def test_paper_estimate_reading():
    assert paper.grid_needed(0.02) == 71  # E[sqrt(2) / 0.02] + 1 = E[70.7] + 1
    assert paper.grid_needed(0.1) == 15
    assert paper.bound_pct(1) == pytest.approx(100 * math.sqrt(2))


def test_polygon_rows_carry_the_paper_check(tiny_with_perturbed):
    assert tiny_with_perturbed["paper_estimate"]["by_n"] == []  # no polygon in that run
    rows = run_bench(TINY, log=lambda m: None, methods=None)["paper_estimate"]
    assert {(b["pose_set"], b["n"]) for b in rows["by_n"]} == {
        (s, n) for s in ("scene", "figure2") for n in (1, 4)}
    assert all(0.0 <= b["within_cell_diagonal"] <= 1.0 for b in rows["by_n"])


# ------------------------------------------------------------------ pose sets


def test_figure2_poses_put_a_vertex_of_b_on_a_top_face():
    from impactnet.models.scenes import load_scene

    poses = figure2_poses(load_scene("quay_crane"), 5, 4, seed=1)
    tilts = figure2_tilts(5)
    assert tilts[0] == pytest.approx(np.radians(10)) and tilts[-1] == pytest.approx(1e-6)
    exact = box_box(*poses.args())
    assert exact.colliding.all()
    np.testing.assert_allclose(exact.normal[:, 2], 1.0, atol=1e-3)  # A's top face (+z)
    steep = poses.tilt > 0.05
    assert set(exact.contact_type[steep]) == {"face-vertex"}


# ------------------------------------------------------------------ learned predictors


def test_learned_methods_say_why_they_are_not_available(tmp_path):
    methods = learned_methods(("single", "auto"), bundle=str(tmp_path / "missing"))
    assert [m.name for m in methods] == ["single", "auto"]
    assert all(m.unavailable and m.batch is None for m in methods)


def test_learned_methods_are_picked_up_from_a_bundle(tmp_path):
    learned_fixtures = pytest.importorskip("tests.models.learned.learned_fixtures")
    bundle = learned_fixtures.write_test_bundle(tmp_path / "bundle")
    scene = tmp_path / "benchtest.toml"
    bodies = {"brick": [1.0, 0.6, 0.4], "slab": [2.0, 1.5, 0.3], "cube": [1.0, 1.0, 1.0]}
    scene.write_text(
        '[scene]\nname = "benchtest"\ndepth_fraction = [0.0, 0.01]\n'
        "[accuracy]\nnormal_deg = 1.0\npoint_fraction = 0.02\n"
        + "".join(f"[bodies.{k}]\nsize = {v}\n" for k, v in bodies.items())
        + '[[pairs]]\na = "brick"\nb = "slab"\n[[pairs]]\na = "cube"\nb = "cube"\n')
    config = with_overrides(TINY, scene=str(scene), bundle=str(bundle), grid_sizes=())
    results = run_bench(config, log=lambda m: None)
    learned = [r for r in results["rows"] if r["family"] == "learned"]
    assert {r["method"] for r in learned} == {"single", "committee", "auto"}
    assert all(r["status"] == "ok" and r["errors"]["contacts"] > 0 for r in learned)
    single = next(r for r in learned if r["method"] == "single")
    assert single["errors"]["type_accuracy"] is None  # single gives no contact types
    auto = next(r for r in learned if r["method"] == "auto" and r["pose_set"] == "scene")
    assert set(auto["info"]["answered_by"]) <= {"committee", "exact"}


# ------------------------------------------------------------------ CLI glue


def test_cli_defaults_and_exact_subcommand():
    args = _parse([])
    assert (args.quick, args.out, args.seed, args.http, args.bench_command) == (
        False, "bench_results", 0, False, None)
    args = _parse(["exact", "--quick", "--json", "x.json"])
    assert (args.bench_command, args.quick, args.json) == ("exact", True, "x.json")
    assert _parse(["--grids", "1,8"]).grids == (1, 8)
    with pytest.raises(SystemExit):
        _parse(["--grids", "0"])


def test_bench_cli_imports_nothing_heavy():
    import subprocess
    import sys

    code = ("import sys, impactnet.training.bench.cli; "
            "print(sorted(m for m in ('numpy', 'fcl', 'torch', 'matplotlib') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_markdown_reports_the_reason_of_an_unavailable_method(quick_cli):
    _, out = quick_cli
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    markdown = (out / "results.md").read_text(encoding="utf-8")
    for row in results["rows"]:
        if row["status"] != "ok":
            assert re.search(re.escape(f"| {row['method']} | {row['status']} |"), markdown)
