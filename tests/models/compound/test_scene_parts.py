"""Compound bodies in scene files: generators, explicit parts, meshes, errors naming the field,
and box-only scenes unchanged."""
import copy
import warnings

import numpy as np
import pytest

from impactnet.models.compound.meshes import HullWarning
from impactnet.models.compound.parts import BoxPart, ConvexPart
from impactnet.models.compound.scene_parts import check_not_inside_convex
from impactnet.models.scenes import SceneError, load_scene, parse_scene

#: Scene hashes of the box-only scenes before compound bodies existed (commit 710755e).
BOX_ONLY_HASHES = {
    "quay_crane": "9f1cc4da4f68e4c920644d04e4703d00daa57d3d961f3e02317d9bba41fcf3f8",
    "paper": "1ed37b9856eac224ab08147d2d9d0b77dccff7470896755e235c670ef9ca3b82",
}


def _scene(bodies, pairs=(("a", "a"),)):
    return {"scene": {"name": "t", "depth_fraction": [0.0, 0.01]},
            "accuracy": {"normal_deg": 1.0, "point_fraction": 0.02}, "bodies": bodies,
            "pairs": [{"a": a, "b": b} for a, b in pairs]}


def _write_toml(tmp_path, body_lines):
    path = tmp_path / "s.toml"
    path.write_text('[scene]\nname = "t"\ndepth_fraction = [0.0, 0.01]\n[accuracy]\n'
                    'normal_deg = 1.0\npoint_fraction = 0.02\n' + body_lines
                    + '[[pairs]]\na = "a"\nb = "a"\n')
    return path


@pytest.mark.parametrize("name", sorted(BOX_ONLY_HASHES))
def test_box_only_scenes_keep_their_hash(name):
    assert load_scene(name).hash() == BOX_ONLY_HASHES[name]
    assert not any(b.is_compound for b in load_scene(name).bodies)


def test_the_detailed_quay_crane_scene_loads_its_generated_bodies():
    scene = load_scene("quay_crane_detail")
    forty = scene.body("container40")
    assert forty.is_compound and len(forty.parts) == 71
    np.testing.assert_allclose(forty.size, (12.192, 2.438, 2.591))
    assert any(isinstance(p, ConvexPart) for p in scene.body("spreader").parts)
    assert parse_scene(scene.to_dict()).hash() == scene.hash()


def test_explicit_parts_of_every_shape_parse():
    body = {"parts": [
        {"name": "block", "box": {"size": [0.2, 0.2, 0.1], "centre": [0.0, 0.0, 0.05]}},
        {"name": "ramp", "points": [[0, 0, 0.1], [0.2, 0, 0.1], [0, 0.2, 0.1], [0, 0, 0.2]]},
        {"name": "cone", "frustum": {"sides": 16, "base": [0.1, 0.06], "tip_scale": 0.5,
                                     "height": -0.05, "centre": [0, 0, 0]}}]}
    parts = parse_scene(_scene({"a": body})).body("a").parts
    assert [type(p) for p in parts] == [BoxPart, ConvexPart, ConvexPart]
    assert len(parts[2].points) == 32


def test_a_generator_parameter_changes_the_hash():
    first = parse_scene(_scene({"a": {"generator": "spreader", "sides": 8}}))
    second = parse_scene(_scene({"a": {"generator": "spreader", "sides": 16}}))
    assert first.hash() != second.hash()


def test_a_mesh_part_is_its_convex_hull_and_a_dented_mesh_warns(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.box(extents=(0.2, 0.1, 0.05)).export(tmp_path / "lid.stl")
    lines = '[[bodies.a.parts]]\nname = "lid"\nmesh = "lid.stl"\n'
    with warnings.catch_warnings():
        warnings.simplefilter("error", HullWarning)
        part = load_scene(_write_toml(tmp_path, lines)).body("a").parts[0]
    assert isinstance(part, ConvexPart) and len(part.points) == 8
    dented = trimesh.creation.annulus(r_min=0.05, r_max=0.1, height=0.05)
    dented.export(tmp_path / "lid.stl")
    with pytest.warns(HullWarning, match="not convex"):
        load_scene(_write_toml(tmp_path, lines))


@pytest.mark.parametrize("body, field", [
    ({"generator": "crane"}, r"bodies\.a\.generator: unknown generator"),
    ({"generator": "container", "sides": 8}, r"bodies\.a: sides do not apply"),
    ({"generator": "container", "detail": 3}, r"bodies\.a: container detail"),
    ({"parts": [{"name": "p", "points": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]}]},
     r"bodies\.a\.parts\[0\]: part 'p': the points are flat"),
    ({"parts": [{"name": "big", "box": {"size": [1, 1, 1]}},
                {"name": "in", "box": {"size": [0.1, 0.1, 0.1]}}]},
     r"bodies\.a\.parts\[1\]: part 'in': lies wholly inside part 'big'"),
    ({"parts": [{"name": "p", "box": {"size": [1, 1, 1]}, "points": [[0, 0, 0]] * 4}]},
     r"bodies\.a\.parts\[0\]: give exactly one shape"),
    ({"parts": [{"name": "p", "mesh": "missing.stl"}]},
     r"bodies\.a\.parts\[0\]\.mesh: no such mesh file"),
    ({"size": [1, 1, 1], "generator": "spreader"}, r"bodies\.a: a compound body takes no"),
])
def test_a_bad_compound_body_is_refused_naming_its_field(body, field):
    with pytest.raises(SceneError, match=field):
        parse_scene(_scene({"a": body}))


def test_a_mesh_that_does_not_load_is_refused_naming_its_field(tmp_path):
    pytest.importorskip("trimesh")
    (tmp_path / "lid.stl").write_bytes(b"not a mesh at all")
    lines = '[[bodies.a.parts]]\nname = "lid"\nmesh = "lid.stl"\n'
    with pytest.raises(SceneError, match=r"bodies\.a\.parts\[0\]\.mesh: "):
        load_scene(_write_toml(tmp_path, lines))


def test_wedge_prism_and_regular_frustum_parts_parse_to_their_hulls():
    body = {"parts": [
        {"name": "block", "box": {"size": [0.2, 0.2, 0.1]}},
        {"name": "chamfer", "wedge": {"size": [0.1, 0.2, 0.05], "centre": [0.15, 0, 0],
                                      "high": "-x", "low_height": 0.01}},
        {"name": "rail", "prism": {"section": [[0, 0], [0.04, 0], [0.02, 0.03]],
                                   "height": 1.0, "axis": "x", "centre": [0, 0, 0.1]}},
        {"name": "pin", "frustum": {"sides": 12, "base": 0.05, "height": 0.08,
                                    "centre": [0, 0, 0.05]}}]}
    scene = parse_scene(_scene({"a": body}))
    block, chamfer, rail, pin = scene.body("a").parts
    assert isinstance(block, BoxPart)
    assert [len(p.points) for p in (chamfer, rail, pin)] == [8, 6, 24]
    np.testing.assert_allclose(scene.body("a").size, (1.0, 0.2, 0.18))  # z: -0.05 .. 0.13
    edited = copy.deepcopy(body)
    edited["parts"][1]["wedge"]["low_height"] = 0.02
    assert parse_scene(_scene({"a": edited})).hash() != scene.hash()


@pytest.mark.parametrize("detail", [1, 2])
def test_a_temp_scene_of_every_generator_loads_at_each_container_detail(tmp_path, detail):
    lines = (f'[bodies.a]\ngenerator = "container"\nkind = "20ft"\ndetail = {detail}\n'
             '[bodies.s]\ngenerator = "spreader"\nkind = "20ft"\nsides = 8\n'
             '[bodies.g]\ngenerator = "cell_guide"\nentry_angle_deg = 45.0\n')
    scene = load_scene(_write_toml(tmp_path, lines))
    container = scene.body("a")
    assert container.is_compound and scene.is_compound_pair(0)
    np.testing.assert_allclose(container.size, (6.058, 2.438, 2.591))
    assert (len(container.parts) > 20) == (detail == 2)
    assert len(scene.body("s").parts) == 9 and len(scene.body("g").parts) == 4


@pytest.mark.parametrize("fmt", ["stl", "obj", "glb"])
def test_a_mesh_file_of_each_format_loads_and_a_changed_mesh_changes_the_hash(tmp_path, fmt):
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.box(extents=(0.2, 0.1, 0.05)).export(tmp_path / f"lid.{fmt}")
    path = _write_toml(tmp_path, f'[[bodies.a.parts]]\nname = "lid"\nmesh = "lid.{fmt}"\n')
    first = load_scene(path)
    np.testing.assert_allclose(first.body("a").size, (0.2, 0.1, 0.05))
    trimesh.creation.box(extents=(0.2, 0.1, 0.06)).export(tmp_path / f"lid.{fmt}")
    assert load_scene(path).hash() != first.hash()


def test_a_hull_within_the_volume_tolerance_does_not_warn(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.icosphere(subdivisions=2, radius=0.05).export(tmp_path / "ball.stl")
    lines = '[[bodies.a.parts]]\nname = "ball"\nmesh = "ball.stl"\n'
    with warnings.catch_warnings():
        warnings.simplefilter("error", HullWarning)
        assert len(load_scene(_write_toml(tmp_path, lines)).body("a").parts[0].points) == 162


@pytest.mark.parametrize("part, field", [
    ({"box": {"size": [1e-7, 1, 1]}}, r"parts\[0\]: part 'p': extents .* outside"),
    ({"box": {"size": [2e6, 1, 1]}}, r"parts\[0\]: part 'p': extents .* outside"),
    ({"box": {"size": [1, 0, 1]}}, r"parts\[0\]\.box\.size\[1\]: must be > 0"),
    ({"box": {"size": [1, 1, 1], "spin": 1}}, r"parts\[0\]\.box: unknown key"),
    ({"wedge": {"size": [1, 1, 1], "high": "up"}}, r"parts\[0\]\.wedge\.high: expected one"),
    ({"wedge": {"size": [1, 1, 1], "low_height": 2}}, r"parts\[0\]\.wedge\.low_height: need"),
    ({"prism": {"section": [[0, 0], [1, 0], [0.2, 0.2], [0, 1]], "height": 1}},
     r"parts\[0\]\.prism\.section\[2\]: does not turn"),
    ({"prism": {"section": [[0, 0], [1, 0], [0, 1]], "height": 1, "axis": "w"}},
     r"parts\[0\]\.prism\.axis: expected one of x, y, z"),
    ({"prism": {"section": [[0, 0], [1, 0], [0, "1"]], "height": 1}},
     r"parts\[0\]\.prism\.section\[2\]\[1\]: expected a finite number"),
    ({"frustum": {"sides": 7, "base": [0.1, 0.05], "height": 0.1}},
     r"parts\[0\]\.frustum\.sides: a stadium needs an even number"),
    ({"frustum": {"sides": 8.0, "base": 0.1, "height": 0.1}},
     r"parts\[0\]\.frustum\.sides: expected an integer"),
    ({"frustum": {"sides": 8, "base": 0.1, "height": 0.0}},
     r"parts\[0\]\.frustum\.height: must not be 0"),
    ({"frustum": {"sides": 8, "base": [0.1], "height": 0.1}},
     r"parts\[0\]\.frustum\.base: expected 2 numbers"),
    ({"cone": {}}, r"parts\[0\]: unknown key\(s\) 'cone'"),
])
def test_a_bad_part_is_refused_naming_its_field(part, field):
    with pytest.raises(SceneError, match=r"^t: bodies\.a\." + field):
        parse_scene(_scene({"a": {"parts": [{"name": "p", **part}]}}), source="t")


def test_a_part_inside_a_convex_part_is_refused_naming_it():
    hull = [[-1, -1, -1], [1, -1, -1], [0, 1, -1], [0, 0, 1]]
    body = {"parts": [{"name": "hull", "points": hull},
                      {"name": "in", "box": {"size": [0.1, 0.1, 0.1], "centre": [0, 0, -0.5]}},
                      {"name": "out", "box": {"size": [0.1, 0.1, 0.1], "centre": [0, 0, 0.9]}}]}
    with pytest.raises(SceneError, match=r"bodies\.a\.parts\[1\]: part 'in': lies wholly "
                                         r"inside part 'hull'"):
        parse_scene(_scene({"a": body}))
    body["parts"].pop(1)
    assert len(parse_scene(_scene({"a": body})).body("a").parts) == 2  # 'out' pokes out


def test_generated_bodies_keep_no_part_inside_another():
    scene = load_scene("quay_crane_detail")
    for body in scene.bodies:
        assert check_not_inside_convex(body.name, body.parts) == body.parts
