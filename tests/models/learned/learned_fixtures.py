"""Tiny learned bundles for the tests (not a test module).

The MLPs are fitted in closed form so that their answers mean something: one random tanh
hidden layer (fixed), then a ridge least-squares output layer ("extreme learning machine"),
on exact-solver data of small box pairs. The region classifier is the exact labeller (nothing
to fit); each region's K experts regress ``contact-v1`` with different random hidden layers,
so that their spread is real; they learn the residual of the point from the labeller's
unclipped point, as trained experts do.
"""
from __future__ import annotations

import copy

import numpy as np

from impactnet.models.learned import canonical as cn
from impactnet.models.learned.bundle_loader import write_bundle
from impactnet.models.learned.mlp import MLP, MLPSpec
from impactnet.models.learned.region_label import unclipped_points
from tests.models.helpers import KEYS as INPUT_KEYS
from tests.models.helpers import labelled_rows

#: Pairs of the test bundle: distinct sizes (so that swapped requests occur) and a cube pair.
PAIRS = {"brick/slab": ([1.0, 0.6, 0.4], [2.0, 1.5, 0.3]),
         "cube/cube": ([1.0, 1.0, 1.0], [1.0, 1.0, 1.0])}
ROWS = 12000  # labelled rows per pair
HIDDEN = 48  # random hidden units per network
K = 3  # experts per region
MIN_REGION_ROWS = 40  # rarer regions get no committee (the exact solver answers them)
RIDGE = 1e-3  # ridge penalty of the least-squares fits (dimensionless, inputs normalised)
AUTO = {"confidence_min": 0.6, "normal_spread_max_deg": 8.0, "point_spread_max": 0.05,
        "depth_margin": 0.02}


def _elm(x, targets, seed, hidden=HIDDEN, outputs=cn.OUTPUTS_VERSION):
    """A 12-hidden-out tanh MLP: random first layer, ridge least-squares second layer."""
    rng = np.random.default_rng(seed)
    in_mean, in_scale = x.mean(0), x.std(0) + 0.05
    w0 = rng.normal(size=(hidden, x.shape[1])) * 0.7
    b0 = rng.normal(size=hidden) * 0.3
    h = np.tanh(((x - in_mean) / in_scale) @ w0.T + b0)
    h1 = np.column_stack([h, np.ones(len(h))])
    out_mean, out_scale = targets.mean(0), targets.std(0) + 1e-3
    t = (targets - out_mean) / out_scale
    solution = np.linalg.solve(h1.T @ h1 + RIDGE * len(h1) * np.eye(hidden + 1), h1.T @ t)
    spec = MLPSpec("tanh", (x.shape[1], hidden, targets.shape[1]), cn.FEATURES_VERSION,
                   outputs)
    return MLP(spec, [w0, solution[:-1].T], [b0, solution[-1]], in_mean, in_scale, out_mean,
               out_scale)


def fit_pair(key, size_a, size_b, seed=0):
    """(manifest pair entry, {name: MLP}) of one pair."""
    rows = labelled_rows(size_a, size_b, ROWS, seed)
    data = cn.learning_arrays(rows, (unclipped_points(*(rows[k] for k in INPUT_KEYS))[0],))
    x, keys = data.features.astype(np.float64), data.keys
    names, counts = np.unique(keys, return_counts=True)
    frequent = [str(k) for k, c in sorted(zip(names, counts), key=lambda kc: -kc[1])
                if c >= MIN_REGION_ROWS and k != cn.NONE_KEY
                and not str(k).startswith("edge-edge:")]  # edge-edge: the point is exact
    regions = [cn.NONE_KEY] + frequent
    tag = key.replace("/", "_")
    mlps = {}
    hit = rows["colliding"]
    mlps[f"{tag}.single"] = _elm(x[hit], data.targets[hit].astype(np.float64), seed + 2)
    residual = data.targets.astype(np.float64)
    residual[:, :3] -= data.points[0]
    experts = {}
    for r, region in enumerate(frequent):
        mine = keys == region
        experts[region] = []
        for k in range(K):
            name = f"{tag}.expert{r}.{k}"
            mlps[name] = _elm(x[mine], residual[mine], seed + 100 + 10 * r + k, hidden=24,
                              outputs=cn.EXPERT_OUTPUTS_VERSION)
            experts[region].append(name)
    entry = {"size_a": list(size_a), "size_b": list(size_b), "depth_fraction": [0.0, 0.01],
             "single": f"{tag}.single",
             "classifier": {"labeller": cn.REGION_LABELLER, "regions": regions},
             "experts": experts, "auto": dict(AUTO), "validation": {}}
    return entry, mlps


def bundle_content(seed=0):
    """(manifest, tensors) of the test bundle."""
    manifest = {"version": f"test-{seed}", "scene": {"name": "test", "hash": "0" * 64},
                "created_utc": "2026-01-01T00:00:00Z", "impactnet_version": "0.1.0",
                "rebuild_command": "tests/models/learned/learned_fixtures.py",
                "seeds": {"data": seed},
                "training": {"method": "random tanh layer + ridge least squares"},
                "mlps": {}, "pairs": {}}
    tensors = {}
    for i, (key, (size_a, size_b)) in enumerate(PAIRS.items()):
        entry, mlps = fit_pair(key, size_a, size_b, seed + 1000 * i)
        manifest["pairs"][key] = entry
        for name, model in mlps.items():
            manifest["mlps"][name] = model.spec.to_dict()
            tensors.update(model.to_tensors(name))
    return manifest, tensors


def with_auto(manifest, **auto):
    """A copy of ``manifest`` whose pairs all use the given auto thresholds."""
    manifest = copy.deepcopy(manifest)
    for entry in manifest["pairs"].values():
        entry["auto"] = {**entry["auto"], **auto}
    return manifest


def write_test_bundle(folder, seed=0, content=None):
    """Write the test bundle (or given (manifest, tensors)) into ``folder``; returns it."""
    manifest, tensors = content or bundle_content(seed)
    return write_bundle(folder, manifest, tensors)
