"""The paper's four-angle metric of the learned predictors, on the paper's own protocol.

The poses, labels and measures are those of the reproduction (``impactnet reproduce-paper``):
:mod:`impactnet.training.paper.data` draws the external test set of each problem (with
discontinuities: every contact of the paper's stream; without: the one smooth region), and
:func:`impactnet.training.paper.metrics.evaluate` measures ME, MAE and RMSE of the four angles, raw
and with wrapped azimuths. A predictor's answer (world point and normal, A at the origin with
identity orientation) becomes the four angles by
:func:`impactnet.models.geometry.spherical.paper_angles`, as the exact labels do. The random stream
is ``default_rng([seed, problem index, PAPER_STREAM])``; the reproduction draws from
``[seed, problem index]``, so the sets are fresh.

A row the predictor calls separated still has a point and a normal (``committee``: the
centres' midpoint and the centre line) and enters the angles as it is; their number is
reported (``predicted_separated``).
"""
from __future__ import annotations

import time

import numpy as np

from impactnet.models.geometry.rotations import euler_to_matrix, matrix_to_quaternion
from impactnet.models.geometry.spherical import paper_angles
from impactnet.training.paper import data as pdata
from impactnet.training.paper import metrics as pm
from impactnet.training.paper.reproduce import paper_problems

#: Third entry of the seed list of the evaluation's paper sets (the reproduction uses none).
PAPER_STREAM = 4_000_001
#: Relative tolerance (dimensionless) of "the scene's body is the paper's cube".
CUBE_RTOL = 1e-9


def cube_pair(scene) -> str | None:
    """Key of the scene pair whose two bodies are the paper's cube (edge
    ``PaperDataConfig.edge``), or None."""
    edge = pdata.PaperDataConfig().edge
    for pair, (size_a, size_b) in zip(scene.pairs, scene.pair_sizes(), strict=True):
        if np.allclose(size_a, edge, rtol=CUBE_RTOL) and np.allclose(size_b, edge,
                                                                      rtol=CUBE_RTOL):
            return pair.key
    return None


def paper_sets(seed: int, rows: tuple[int, ...]) -> dict[str, pdata.PaperSet]:
    """The external test set of each of the paper's problems, ``rows[i]`` rows for problem i."""
    config = pdata.PaperDataConfig()
    sets = {}
    for index, (problem, n) in enumerate(zip(paper_problems(), rows, strict=True)):
        rng = np.random.default_rng([seed, index, PAPER_STREAM])
        if problem.region_only:
            sets[problem.key] = pdata.region_set(n, rng, config)[0]
        else:
            sets[problem.key] = pdata.stream(n, rng, config)
    return sets


def predict_angles(predictor, data: pdata.PaperSet) -> tuple[np.ndarray, int]:
    """The paper's four angles (n, 4) of a predictor's answers on ``data``, and how many rows
    it called separated."""
    n, edge = len(data), pdata.PaperDataConfig().edge
    cube = np.full((n, 3), edge)
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    quaternion_b = matrix_to_quaternion(euler_to_matrix(data.inputs[:, 3:]))
    contacts = predictor(cube, np.zeros((n, 3)), identity, cube, data.inputs[:, :3],
                         quaternion_b)
    angles = paper_angles(contacts.point, contacts.normal, np.zeros(3), np.eye(3))
    return angles, int((~contacts.colliding).sum())


def paper_metric(predictors: dict, seed: int, rows: tuple[int, ...]) -> dict:
    """ME, MAE, RMSE (raw and wrapped) and the geometric errors of each predictor on each
    problem; ``{"problems": {key: {"rows": n, "predictors": {name: ...}}}, "seconds": s}``.

    Parameters
    ----------
    predictors : dict
        Name -> predictor (``models.load_predictor``) that covers the paper's cube pair.
    seed : int
        Data seed (see the module docstring).
    rows : tuple of int
        Test rows of each problem, in the order of ``reproduce_paper.paper_problems()``.
    """
    start = time.perf_counter()
    size = np.full(3, pdata.PaperDataConfig().edge)
    out = {"problems": {}}
    for key, data in paper_sets(seed, rows).items():
        block = {"rows": len(data), "predictors": {}}
        for name, predictor in predictors.items():
            angles, separated = predict_angles(predictor, data)
            measured = pm.evaluate(angles, data.targets, size, data.point)
            block["predictors"][name] = {**measured, "predicted_separated": separated}
        out["problems"][key] = block
    out["seconds"] = time.perf_counter() - start
    return out
