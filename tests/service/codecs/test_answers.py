"""The answer's writers (service/codecs/answers.py): a single pair's JSON object (and a frame's
rows) carry exactly what the batch's columnar JSON carries for that row, key for key, for box
and compound pairs, in contact, within a margin and beyond it, with every ``include``."""
from __future__ import annotations

import numpy as np
import orjson
import pytest

from impactnet.models.dispatch import Dispatcher, Pairs
from impactnet.models.dispatch.shapes import scene_shapes
from impactnet.models.scenes import load_scene
from impactnet.service.codecs.answers import batch_json, row_json, rows_json

#: Rows of each seeded set.
ROWS = 24


def _random_unit(rng, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _pairs(scene: str, a: str, b: str, height: float, seed: int) -> Pairs:
    """``ROWS`` poses of body ``b`` over body ``a``: touching, near (within the margin) and
    far apart, about random axes."""
    rng = np.random.default_rng(seed)
    shapes = scene_shapes(load_scene(scene))
    names = list(shapes)
    position_b = np.column_stack([rng.uniform(-0.3, 0.3, (ROWS, 2)),
                                  height + rng.uniform(-0.05, 0.6, ROWS)])
    position_b[-3:, 2] += 50.0  # beyond any margin: distance null, closest points null
    tilt = _random_unit(rng, ROWS)
    tilt[:, 1:] *= 0.02  # small tilts about random axes
    tilt /= np.linalg.norm(tilt, axis=1, keepdims=True)
    return Pairs(tuple(shapes.values()), np.array([names.index(a)]),
                 np.array([names.index(b)]), np.zeros((1, 3)), np.array([[1.0, 0, 0, 0]]),
                 position_b, tilt)


def _transposed(batch: dict) -> list[dict]:
    """The batch's columnar JSON as one object per row (the single pair's layout)."""
    def at(column, i):
        return {k: at(v, i) for k, v in column.items()} if isinstance(column, dict) else \
            column[i]

    contacts = batch["contacts"]
    offsets = contacts["offsets"]
    keys = [k for k in batch if k not in ("n", "mode", "model_version", "contacts")]
    rows = []
    for i in range(batch["n"]):
        row = {k: at(batch[k], i) for k in keys}
        listed = []
        for j in range(offsets[i], offsets[i + 1]):
            contact = {k: at(v, j) for k, v in contacts.items()
                       if k != "offsets" and not k.startswith("manifold_")}
            if "manifold_count" in contacts:
                count = contacts["manifold_count"][j]
                contact["manifold"] = {"count": count,
                                       "points": contacts["manifold_points"][j][:count],
                                       "depths": contacts["manifold_depths"][j][:count]}
            listed.append(contact)
        row["contacts"] = listed
        rows.append(row)
    return rows


def _keys(value):
    """Every object's keys, in order, through the whole value."""
    if isinstance(value, dict):
        return [(k, _keys(v)) for k, v in value.items()]
    if isinstance(value, list):
        return [_keys(v) for v in value]
    return None


@pytest.mark.parametrize("scene, a, b, height", [
    ("quay_crane", "container40", "container40", 2.59),
    ("quay_crane", "container40", "cube", 2.29),
    ("quay_crane_detail", "container40", "spreader", 1.70),
    ("quay_crane_detail", "container40", "container40", 2.59)])
@pytest.mark.parametrize("include", [(), ("manifold",), ("manifold", "paper_angles")])
def test_each_row_written_alone_is_the_batch_row_key_for_key(scene, a, b, height, include):
    pairs = _pairs(scene, a, b, height, seed=len(scene) + len(b))
    answers = Dispatcher().answer(pairs, "exact", include, margin=0.4)
    batch = orjson.loads(b"".join(batch_json(answers, pairs, include, "exact", "v")))
    expected = _transposed(batch)
    got = orjson.loads(orjson.dumps(rows_json(answers, pairs, include)))
    assert got == expected
    assert _keys(got) == _keys(expected)  # the same keys in the same order
    assert orjson.loads(orjson.dumps(row_json(answers, pairs, include))) == expected[0]
    touching = [row for row in got if row["colliding"]]
    near = [row for row in got if not row["colliding"] and row["distance"] is not None]
    far = [row for row in got if row["distance"] is None]
    assert touching and near and far  # every branch of the writer is exercised
