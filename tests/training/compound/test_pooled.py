"""One classifier for the four corners of mirror-symmetric bodies (the default): the corner
groups share one MLP, each seen through its mirror and naming its own part pairs (the shared
labels mapped through the mirror); the bundle reads back and its chain answers held-out rows;
bodies without the symmetry keep one classifier per group."""
import functools

import numpy as np

from impactnet.models.learned.bundle_loader import bundle_in_memory
from impactnet.models.learned.compound import chain_of
from impactnet.models.learned.compound.groups import CORNER_MIRRORS, mirror_map, part_groups
from impactnet.models.scenes import load_scene
from impactnet.training.compound.classify import pooled_maps
from impactnet.training.compound.pair import train_compound_pair
from impactnet.training.compound.rows import split_rows
from impactnet.training.compound.settings import compound_config
from impactnet.training.data.compound_data import compound_rows

PAIR = "container40/container40"


@functools.lru_cache(maxsize=1)
def _stacking():
    scene = load_scene("quay_crane_detail")
    pair = scene.pairs[[p.key for p in scene.pairs].index(PAIR)]
    parts = scene.body("container40").parts
    edge = scene.smaller_shortest_edge(pair)
    data = compound_rows(parts, parts, 300, tuple(edge * f for f in scene.depth_fraction),
                         np.random.default_rng(3))
    entry, tensors, specs = train_compound_pair(scene, pair, data, compound_config(0, True),
                                                log=lambda m: None)
    return scene, parts, data, entry, tensors, specs


def test_the_four_corners_share_one_classifier_each_through_its_mirror():
    _, parts, _, entry, _, specs = _stacking()
    corners = entry["groups"][:4]
    assert [g["name"] for g in corners] == list(CORNER_MIRRORS)
    assert {g["classifier"] for g in corners} == {"container40__container40.classifier_corners"}
    assert [tuple(g["mirror"]) for g in corners] == list(CORNER_MIRRORS.values())
    assert "container40__container40.classifier_corners" in specs
    fl = np.array(corners[0]["labels"])
    for g in corners[1:]:
        mapping = mirror_map(parts, g["mirror"])
        np.testing.assert_array_equal(np.array(g["labels"]), mapping[fl])


def test_the_pooled_bundle_reads_back_and_its_chain_answers_the_held_out_rows():
    scene, parts, data, entry, tensors, specs = _stacking()
    manifest = {"version": "p", "scene": {"name": scene.name, "hash": scene.hash()},
                "mlps": specs, "pairs": {}, "compound_pairs": {PAIR: entry}}
    models = bundle_in_memory(manifest, tensors).compound[PAIR]
    chain = chain_of(models, parts, parts)
    rows = split_rows(data, 0)
    answer = chain.answer(np.zeros(3), [1.0, 0, 0, 0], rows.position[rows.test],
                          rows.quaternion[rows.test])
    assert len(answer.predictor) == len(rows.test)
    assert entry["decision"]["figures"]["rows"] == len(rows.test)


def test_bodies_without_the_symmetry_keep_one_classifier_per_group():
    scene = load_scene("quay_crane_detail")
    guide, box = scene.body("cell_guide").parts, scene.body("container40").parts
    assert pooled_maps(guide, box, part_groups(guide, box)) is None
