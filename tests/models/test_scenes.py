"""Scenes: the shipped files load, every validation fault is named, the hash is canonical."""
import copy
import random

import numpy as np
import pytest

from impactnet.models.scenes import (
    DEFAULT_SCENE,
    SCENES_DIR_ENV,
    Accuracy,
    BodyPair,
    SceneError,
    available_scenes,
    load_scene,
    parse_scene,
)

#: ISO 668 external sizes, metres.
ISO_20 = (6.058, 2.438, 2.591)
ISO_40 = (12.192, 2.438, 2.591)
ISO_40HC = (12.192, 2.438, 2.896)

VALID = {
    "scene": {"name": "tiny", "description": "two boxes", "depth_fraction": [0.0, 0.01]},
    "accuracy": {"normal_deg": 1.0, "point_fraction": 0.02},
    "bodies": {"box": {"size": [1.0, 2.0, 3.0]},
               "plate": {"size": [4.0, 4.0, 0.1], "description": "thin"}},
    "pairs": [{"a": "box", "b": "plate"}, {"a": "box", "b": "box", "description": "self"}],
}


def variant(edit):
    """A deep copy of VALID changed in place by ``edit``."""
    data = copy.deepcopy(VALID)
    edit(data)
    return data


def test_default_scene_is_the_quay_crane_with_iso_containers():
    scene = load_scene()
    assert scene.name == DEFAULT_SCENE == "quay_crane"
    sizes = {b.name: b.size for b in scene.bodies}
    assert sizes["container20"] == ISO_20
    assert sizes["container40"] == ISO_40
    assert sizes["container40hc"] == ISO_40HC
    assert sizes["cube"] == (2.0, 2.0, 2.0)
    assert "box" in scene.body("spreader").description.lower()
    keys = {frozenset((p.a, p.b)) for p in scene.pairs}
    for container in ("container20", "container40", "container40hc"):
        assert frozenset(("spreader", container)) in keys
    assert frozenset(("cube",)) in keys
    assert 8 <= len(scene.pairs) <= 10
    assert all(p.description for p in scene.pairs)
    assert scene.depth_fraction == (0.0, 0.01)
    assert scene.accuracy == Accuracy(normal_deg=1.0, point_fraction=0.02)


def test_paper_scene_is_the_cube_pair_only():
    scene = load_scene("paper")
    assert [(p.a, p.b) for p in scene.pairs] == [("cube", "cube")]
    np.testing.assert_array_equal(scene.size("cube"), [2.0, 2.0, 2.0])
    assert {"paper", "quay_crane"} <= set(available_scenes())


def test_load_by_path_and_by_name_in_env_folder(tmp_path, monkeypatch):
    source = load_scene("paper")
    text = (tmp_path / "mine.toml")
    text.write_text(
        '[scene]\nname = "mine"\ndepth_fraction = [0, 0.02]\n'
        '[accuracy]\nnormal_deg = 2\npoint_fraction = 0.05\n'
        '[bodies.cube]\nsize = [2, 2, 2]\n[[pairs]]\na = "cube"\nb = "cube"\n')
    by_path = load_scene(text)
    monkeypatch.setenv(SCENES_DIR_ENV, str(tmp_path))
    by_name = load_scene("mine")
    assert by_path == by_name
    assert by_name.depth_fraction == (0.0, 0.02)
    assert by_name.pair_sizes().tolist() == source.pair_sizes().tolist()
    with pytest.raises(SceneError, match="no such scene file.*mine"):
        load_scene("quay_crane")  # not in the overriding folder


def test_duplicate_body_table_is_refused_with_the_file_named(tmp_path):
    path = tmp_path / "dup.toml"
    path.write_text('[bodies.box]\nsize = [1, 1, 1]\n[bodies.box]\nsize = [2, 2, 2]\n')
    with pytest.raises(SceneError, match=r"dup\.toml: invalid TOML"):
        load_scene(path)


def test_sizes_pairs_and_shortest_edges():
    scene = parse_scene(VALID)
    np.testing.assert_array_equal(scene.size("plate"), [4.0, 4.0, 0.1])
    sizes = scene.pair_sizes()
    assert sizes.shape == (2, 2, 3) and sizes.dtype == np.float64
    for (size_a, size_b), pair in zip(sizes, scene.pairs, strict=True):
        np.testing.assert_array_equal(size_a, scene.size(pair.a))
        np.testing.assert_array_equal(size_b, scene.size(pair.b))
    assert scene.smaller_shortest_edge(0) == 0.1
    assert scene.smaller_shortest_edge(("box", "box")) == 1.0
    assert scene.smaller_shortest_edge(BodyPair("plate", "box")) == 0.1
    assert scene.pairs[0].key == "box/plate"
    with pytest.raises(SceneError, match="unknown body 'crate'"):
        scene.size("crate")


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["pairs"][0].update(b="crate"), r"pairs\[0\]\.b: unknown body 'crate'"),
    (lambda d: d["bodies"]["box"].update(size=[1.0, 0.0, 3.0]), r"bodies\.box\.size\[1\]: .*> 0"),
    (lambda d: d["bodies"]["box"].update(size=[1.0, -2.0, 3.0]), r"bodies\.box\.size\[1\]"),
    (lambda d: d["bodies"]["box"].update(size=[1.0, 2.0]), r"bodies\.box\.size: expected 3"),
    (lambda d: d["bodies"]["box"].update(size=[1, "2", 3]), r"bodies\.box\.size\[1\]: .*number"),
    (lambda d: d["bodies"]["box"].update(size=[1, True, 3]), r"bodies\.box\.size\[1\]"),
    (lambda d: d["bodies"]["box"].update(size=[1, float("nan"), 3]), r"size\[1\]: .*finite"),
    (lambda d: d["pairs"].append({"a": "plate", "b": "box"}), r"pairs\[2\]: duplicate pair"),
    (lambda d: d["pairs"].append({"a": "box", "b": "box"}), r"pairs\[2\]: duplicate pair"),
    (lambda d: d["scene"].update(depth_fraction=[-0.01, 0.01]), r"scene\.depth_fraction: need"),
    (lambda d: d["scene"].update(depth_fraction=[0.02, 0.01]), r"scene\.depth_fraction: need"),
    (lambda d: d["scene"].update(depth_fraction=[0.0, 1.0]), r"scene\.depth_fraction: need"),
    (lambda d: d["scene"].update(depth_fraction=[0.0]), r"scene\.depth_fraction: expected"),
    (lambda d: d["accuracy"].update(normal_deg=0), r"accuracy\.normal_deg: must be > 0"),
    (lambda d: d["accuracy"].update(point_fraction=-0.1), r"accuracy\.point_fraction: must"),
    (lambda d: d.pop("accuracy"), r"\(top level\): missing accuracy"),
    (lambda d: d.pop("pairs"), r"\(top level\): missing pairs"),
    (lambda d: d["scene"].pop("name"), r"scene: missing scene\.name"),
    (lambda d: d["bodies"]["box"].pop("size"), r"bodies\.box: missing bodies\.box\.size"),
    (lambda d: d["pairs"][1].pop("a"), r"pairs\[1\]: missing pairs\[1\]\.a"),
    (lambda d: d.update(extra={}), r"\(top level\): unknown key\(s\) 'extra'"),
    (lambda d: d["scene"].update(seed=1), r"scene: unknown key\(s\) 'seed'"),
    (lambda d: d["bodies"]["box"].update(mass=1), r"bodies\.box: unknown key\(s\) 'mass'"),
    (lambda d: d["pairs"][0].update(c="box"), r"pairs\[0\]: unknown key\(s\) 'c'"),
    (lambda d: d["accuracy"].update(depth=1), r"accuracy: unknown key\(s\) 'depth'"),
    (lambda d: d.update(bodies={}), r"bodies: expected at least one"),
    (lambda d: d.update(pairs=[]), r"pairs: expected at least one"),
    (lambda d: d["scene"].update(name="../etc"), r"scene\.name: bad name"),
    (lambda d: d["bodies"].update({"two words": {"size": [1, 1, 1]}}), r"bad name 'two words'"),
    (lambda d: d.update(scene="quay"), r"scene: expected a table"),
])
def test_each_fault_is_refused_with_its_field_named(edit, message):
    with pytest.raises(SceneError, match=message):
        parse_scene(variant(edit), source="test.toml")


def test_error_is_a_value_error_prefixed_by_the_source():
    with pytest.raises(ValueError, match=r"^test\.toml: pairs\[0\]\.b"):
        parse_scene(variant(lambda d: d["pairs"][0].update(b="crate")), source="test.toml")


def test_round_trip_through_to_dict():
    for scene in (parse_scene(VALID), load_scene(), load_scene("paper")):
        again = parse_scene(scene.to_dict())
        assert again == scene
        assert again.hash() == scene.hash()


def shuffled(data, rng):
    """The same scene with every dict's keys and the bodies / pairs in a random order."""
    if isinstance(data, dict):
        items = list(data.items())
        rng.shuffle(items)
        return {k: shuffled(v, rng) for k, v in items}
    if isinstance(data, list) and data and isinstance(data[0], dict):
        items = [shuffled(v, rng) for v in data]
        rng.shuffle(items)
        return items
    return data


def test_hash_is_stable_under_reordering_and_descriptions():
    rng = random.Random(0)
    base = load_scene().to_dict()
    reference = parse_scene(base).hash()
    for _ in range(20):
        assert parse_scene(shuffled(base, rng)).hash() == reference
    reworded = copy.deepcopy(base)
    reworded["scene"]["description"] = "another text"
    reworded["bodies"]["spreader"]["description"] = "another text"
    assert parse_scene(reworded).hash() == reference


def test_hash_changes_with_any_size_or_setting():
    rng = np.random.default_rng(1)
    base = load_scene().to_dict()
    reference = parse_scene(base).hash()
    seen = {reference}
    for name in base["bodies"]:
        for axis in range(3):
            changed = copy.deepcopy(base)
            size = changed["bodies"][name]["size"]
            size[axis] = float(np.nextafter(size[axis], np.inf) + rng.uniform(0, 1e-3))
            seen.add(parse_scene(changed).hash())
    edits = [lambda d: d["scene"].update(depth_fraction=[0.0, 0.02]),
             lambda d: d["scene"].update(name="other"),
             lambda d: d["accuracy"].update(normal_deg=0.5),
             lambda d: d["accuracy"].update(point_fraction=0.01),
             lambda d: d["pairs"].pop(),
             lambda d: d["pairs"][0].update(a=d["pairs"][0]["b"], b=d["pairs"][0]["a"])]
    for edit in edits:
        changed = copy.deepcopy(base)
        edit(changed)
        seen.add(parse_scene(changed).hash())
    assert len(seen) == 1 + 3 * len(base["bodies"]) + len(edits)


#: VALID with a compound body: a 20 ft container at detail 1 beside the boxes.
MIXED = variant(lambda d: (d["bodies"].update(crate={"generator": "container", "kind": "20ft"}),
                           d["pairs"].append({"a": "crate", "b": "box"})))


def test_compound_and_box_pairs_split_in_file_order():
    scene = parse_scene(MIXED)
    assert [p.key for p in scene.box_pairs()] == ["box/plate", "box/box"]
    assert [p.key for p in scene.compound_pairs()] == ["crate/box"]
    assert scene.is_compound_pair(2) and scene.is_compound_pair(("box", "crate"))
    assert not scene.is_compound_pair(BodyPair("box", "plate"))


def test_box_paths_refuse_a_compound_pair_naming_it():
    scene = parse_scene(MIXED)
    with pytest.raises(SceneError, match=r"^tiny: pairs: Scene\.pair_sizes .* crate/box has a "
                                         r"compound body"):
        scene.pair_sizes()
    with pytest.raises(SceneError, match=r"impactnet train handles pairs of boxes only; "
                                         r"crate/box has"):
        scene.require_box_pairs("impactnet train")
    scene.require_box_pairs("impactnet train", [0, 1])  # the box pairs alone pass
    envelopes = scene.pair_sizes(envelopes=True)
    np.testing.assert_allclose(envelopes[2, 0], ISO_20)
    assert scene.smaller_shortest_edge(2) == 1.0  # the box's; the crate's envelope is wider


def test_detail_scene_refuses_every_box_path_with_all_its_pairs_named():
    scene = load_scene("quay_crane_detail")
    assert scene.compound_pairs() == scene.pairs and scene.box_pairs() == ()
    with pytest.raises(SceneError, match="container40/container40, container40/container20, "
                                         "container40/spreader, cell_guide/container40 have"):
        scene.pair_sizes()


def test_point_tolerance_of_box_pairs_and_of_touching_parts():
    scene = parse_scene(MIXED)
    assert scene.point_tolerance_m(0) == pytest.approx(0.02 * 0.1)
    assert scene.point_tolerance_m(2, "casting_top_fl", None) == pytest.approx(0.02 * 0.118)
    assert scene.point_tolerance_m(2, "body", None) == pytest.approx(0.02 * 1.0)  # the box
    detail = load_scene("quay_crane_detail")
    assert detail.accuracy.part_point_fraction == 0.02
    casting = detail.point_tolerance_m(0, "casting_bottom_fl", "casting_top_fl/ring_3")
    assert casting == pytest.approx(0.00236)  # the 2.4 mm on a casting
    assert detail.point_tolerance_m(2, "casting_top_fl/ring_3", "head_fl") == pytest.approx(
        0.02 * 0.056)
    coarser = copy.deepcopy(MIXED)
    coarser["accuracy"]["part_point_fraction"] = 0.04
    assert parse_scene(coarser).point_tolerance_m(2, "casting_top_fl") == pytest.approx(
        0.04 * 0.118)


def test_part_point_fraction_is_optional_validated_hashed_and_round_trips():
    with pytest.raises(SceneError, match=r"accuracy\.part_point_fraction: must be > 0"):
        parse_scene(variant(lambda d: d["accuracy"].update(part_point_fraction=0)))
    given = parse_scene(variant(lambda d: d["accuracy"].update(part_point_fraction=0.02)))
    plain = parse_scene(VALID)
    assert plain.accuracy == Accuracy(1.0, 0.02) and plain.accuracy.part_point_fraction is None
    assert given.hash() != plain.hash()
    for scene in (given, parse_scene(MIXED), load_scene("quay_crane_detail")):
        again = parse_scene(scene.to_dict())
        assert again == scene and again.hash() == scene.hash()
