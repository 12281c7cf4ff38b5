"""Issue 23, item 7: manifold depths are clamped to >= 0 like ``depth``.

Reproducer: exactly touching boxes gave manifold depths of -1e-17 (round-off) while ``depth``
was clamped to 0. The service clamps them in every answer (single pair, JSON and npz batches);
a predictor that returns such depths stands in for the solver, whatever its round-off today.
"""
from __future__ import annotations

import dataclasses
import io

import numpy as np

from impactnet.models.box.exact import box_box
from tests.service.conftest import PAIR, serve_exact_with
from tests.service.test_batch import as_json, poses

ROUND_OFF_DEPTH = -1e-17


class _NegativeDepths:
    """The exact solver, with its manifold's depths replaced by tiny negatives."""

    mode = "exact"

    def __call__(self, *args):
        contacts = box_box(*args)
        depths = np.where(np.arange(8) < contacts.manifold_count[:, None], ROUND_OFF_DEPTH, 0.0)
        return dataclasses.replace(contacts, manifold_depths=depths)


def test_manifold_depths_are_never_negative(make_client):
    client = make_client()
    serve_exact_with(client.app, _NegativeDepths())
    single = client.post("/v2/contact", json=PAIR | {"include": ["manifold"]})
    assert single.status_code == 200
    depths = single.json()["contacts"][0]["manifold"]["depths"]
    assert depths and all(d == 0.0 and str(d) == "0.0" for d in depths)

    columns = as_json(poses(20, seed=5), include=["manifold"])
    text = client.post("/v2/contact/batch", json=columns)
    assert text.status_code == 200
    assert np.min(text.json()["contacts"]["manifold_depths"]) == 0.0
    assert "-" not in str(text.json()["contacts"]["manifold_depths"])  # no -0.0 either

    binary = client.post("/v2/contact/batch", json=columns,
                         headers={"Accept": "application/x-npz"})
    assert binary.status_code == 200
    with np.load(io.BytesIO(binary.content)) as npz:
        assert (npz["contact_manifold_depths"] == 0.0).all()
        assert not np.signbit(npz["contact_manifold_depths"]).any()
