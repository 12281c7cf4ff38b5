"""Compound bodies in scene files: generators, explicit parts, meshes, errors naming the field,
and box-only scenes unchanged."""
import warnings

import numpy as np
import pytest

from impactnet.models.compound.meshes import HullWarning
from impactnet.models.compound.parts import BoxPart, ConvexPart
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
