"""`impactnet show`: a touching pose of a pair drawn as a PNG and a GLB that load back."""
import argparse

import pytest

from impactnet.training.show import cli

SCENE = """[scene]
name = "stack"
depth_fraction = [0.0, 0.001]
[accuracy]
normal_deg = 1.0
point_fraction = 0.02
[bodies.box40]
generator = "container"
kind = "40ft"
[bodies.plate]
size = [3.0, 3.0, 0.2]
[[pairs]]
a = "box40"
b = "box40"
"""


def _run(tmp_path, *argv):
    scene = tmp_path / "stack.toml"
    scene.write_text(SCENE)
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    return cli.run(parser.parse_args(["--scene", str(scene), "--out", str(tmp_path / "out"),
                                      *argv]))


def test_show_draws_a_touching_pose_as_png_and_glb(tmp_path, capsys):
    matplotlib = pytest.importorskip("matplotlib")
    trimesh = pytest.importorskip("trimesh")
    assert _run(tmp_path, "--pair", "box40/box40", "--seed", "3") == cli.EXIT_OK
    printed = capsys.readouterr().out
    assert "part contacts, deepest 1.000 mm" in printed
    png = tmp_path / "out" / "box40_box40_seed3.png"
    image = matplotlib.image.imread(png)
    assert image.shape[0] > 100 and image.std() > 0
    loaded = trimesh.load(tmp_path / "out" / "box40_box40_seed3.glb")
    contacts = int(printed.split(": ")[-1].split(" part contacts")[0].split()[-1])
    assert len(loaded.geometry) == 2 * 9 + 2 * contacts  # parts, then a marker and a normal each


def test_the_same_seed_draws_the_same_pose(tmp_path, capsys):
    _run(tmp_path, "--pair", "box40/plate", "--seed", "5")
    first = capsys.readouterr().out
    _run(tmp_path, "--pair", "box40/plate", "--seed", "5")
    assert capsys.readouterr().out == first


def test_an_unknown_pair_is_a_usage_error(tmp_path, capsys):
    assert _run(tmp_path, "--pair", "box40/crane") == cli.EXIT_USAGE
    assert "crane" in capsys.readouterr().err


def test_labels_draw_a_body_s_part_groups_by_name(tmp_path, capsys):
    matplotlib = pytest.importorskip("matplotlib")
    assert _run(tmp_path, "--labels", "box40") == cli.EXIT_OK
    assert "9 part groups of box40" in capsys.readouterr().out  # body, 8 castings (detail 1)
    image = matplotlib.image.imread(tmp_path / "out" / "parts_box40.png")
    assert image.shape[0] > 100 and image.std() > 0


def test_labels_name_what_a_view_from_above_shows():
    from impactnet.models.compound import container
    from impactnet.training.show.labels import _visible_from_above, group_bounds

    shown = _visible_from_above(group_bounds(container("40ft", detail=2)))
    assert {"casting_top_fl", "casting_top_ar"} <= set(shown)
    assert not any(g.startswith("casting_bottom") for g in shown)  # hidden under the tops


def test_neither_a_pair_nor_labels_is_a_usage_error(tmp_path, capsys):
    assert _run(tmp_path) == cli.EXIT_USAGE
    assert "--pair" in capsys.readouterr().err
