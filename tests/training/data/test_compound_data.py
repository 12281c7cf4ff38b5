"""First-contact rows of compound pairs: every family touches, flat contacts at about the
pushed depth, and the ragged labels are consistent and reproducible."""
import numpy as np
import pytest

from impactnet.models.compound import crane_bodies as cb
from impactnet.training.data.compound_data import compound_rows, pair_families
from impactnet.training.data.compound_poses import FAMILIES

#: A push along the approach gives about that depth: tilts of at most 1e-2 rad change it by a
#: few per cent at most.
DEPTH_OF_PUSH_REL = 0.05
DEPTHS_M = (2e-4, 2e-3)


def _pairs():
    container, detail = cb.container("40ft"), cb.container("40ft", detail=2)
    return {"stacking": (container, container), "apertures": (detail, detail),
            "twistlocks": (detail, cb.spreader("40ft", sides=8)),
            "guide": (cb.cell_guide(), container)}


@pytest.mark.parametrize("name", ["stacking", "apertures", "twistlocks", "guide"])
def test_every_family_touches_at_about_the_pushed_depth(name):
    parts_a, parts_b = _pairs()[name]
    rows = compound_rows(parts_a, parts_b, 40, DEPTHS_M, np.random.default_rng(3))
    k = len(rows["push"])
    assert k >= 36  # a first contact is found for nearly every pose
    assert rows["colliding"].all()
    assert len(rows["contact_offsets"]) == k + 1
    assert rows["contact_offsets"][-1] == len(rows["contact_depth"])
    assert (rows["depth"] <= (1 + DEPTH_OF_PUSH_REL) * rows["push"] + 1e-6).all()
    if name != "twistlocks":  # flat contacts; a head's sloped side takes a share of the push
        near = np.abs(rows["depth"] - rows["push"]) <= DEPTH_OF_PUSH_REL * rows["push"] + 1e-6
        assert near.mean() > 0.9
    families = {FAMILIES[f] for f in rows["family"]}
    assert families == set(pair_families(parts_a, parts_b))
    for column in ("normal", "point", "contact_point", "contact_normal"):
        assert np.isfinite(rows[column]).all()


def test_the_same_seed_gives_the_same_rows():
    parts_a, parts_b = _pairs()["stacking"]
    first = compound_rows(parts_a, parts_b, 20, DEPTHS_M, np.random.default_rng(9))
    second = compound_rows(parts_a, parts_b, 20, DEPTHS_M, np.random.default_rng(9))
    for name, column in first.items():
        np.testing.assert_array_equal(column, second[name], err_msg=name)


def test_datagen_writes_the_compound_dataset_of_a_scene(tmp_path, capsys):
    import argparse
    import json

    from impactnet.training.data import cli

    scene = tmp_path / "stack.toml"
    scene.write_text('[scene]\nname = "stack"\ndepth_fraction = [0.0, 0.001]\n[accuracy]\n'
                     'normal_deg = 1.0\npoint_fraction = 0.02\n[bodies.box40]\n'
                     'generator = "container"\nkind = "40ft"\ndetail = 1\n'
                     '[[pairs]]\na = "box40"\nb = "box40"\n')
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    args = parser.parse_args(["--scene", str(scene), "--n-per-pair", "12", "--out",
                              str(tmp_path / "data"), "--no-progress"])
    assert cli.run(args) == cli.EXIT_OK
    manifest = json.loads((tmp_path / "data" / "stack.compound.json").read_text())
    assert manifest["pairs"][0]["rows"] >= 10
    with np.load(tmp_path / "data" / "stack.compound.npz") as data:
        assert data["pair0.contact_offsets"][-1] == manifest["pairs"][0]["part_contacts"]
    assert "box40/box40" in capsys.readouterr().out
