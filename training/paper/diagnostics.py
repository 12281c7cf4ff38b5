"""Diagnostic of the reproduction: how the error grows from one region to wider families.

Table 2 ("without discontinuities") is one region here, which the paper's network learns almost
exactly; the paper's Table 2 errors are two orders of magnitude larger. To show where such errors
could come from, the same network (the Table 2 architecture and learning rate/momentum) is
trained on wider families of the same stream, each a union of regions, so each with
discontinuities between its regions:

* ``b_corners_on_a_plus_x``: B's corners on A's +x face (face-vertex, feature_a = face +x;
  4 regions, one per B corner that can touch);
* ``a_positive_trihedron``: every contact on A's trihedron of the (+,+,+) corner (feature_a is
  face +x, +y or +z, one of the three edges between them, or the corner itself; any B
  feature), the paper's "trihedron" split applied to A;
* ``vertex_on_face``: every B corner on any A face (face-vertex, any A face, any B corner).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.geometry import box_features as bf
from impactnet.training.paper import data as pdata
from impactnet.training.paper import metrics as pm
from impactnet.training.paper.mlp import MLPConfig, PaperTrainConfig, train


@dataclass
class DiagnosticsConfig:
    enabled: bool = True  # run the diagnostic families after the two tables
    draws: int = 700_000  # pairs drawn from the paper's stream (seed [seed, 2])
    sizes: tuple[int, int, int] = (8_000, 5_000, 10_000)  # training / validation / test
    train: PaperTrainConfig = field(default_factory=lambda: PaperTrainConfig(
        max_epochs=200, patience=40, time_limit_s=40.0))  # budget (lr, momentum overridden)


def _positive_trihedron(ids: np.ndarray) -> np.ndarray:
    """True for features of the (+,+,+) trihedron: no negative coordinate sign."""
    valid = ids >= 0
    signs = bf.FEATURE_SIGNS[np.where(valid, ids, 0)]
    return valid & np.all(signs >= 0, axis=1)


def family_masks(data: pdata.PaperSet) -> dict[str, np.ndarray]:
    """Boolean row masks of the diagnostic families (see the module docstring)."""
    fa = data.feature_a.astype(np.int64)
    face_vertex = data.contact_type_code == ct.FACE_VERTEX
    return {"b_corners_on_a_plus_x": face_vertex & (fa == int(bf.face_id(0, False))),
            "a_positive_trihedron": _positive_trihedron(fa),
            "vertex_on_face": face_vertex}


FAMILY_TITLES = {
    "b_corners_on_a_plus_x": "B's corners on A's +x face",
    "a_positive_trihedron": "contacts on A's (+,+,+) trihedron",
    "vertex_on_face": "B's corners on any face of A",
}


def draw(config: DiagnosticsConfig, data_config: pdata.PaperDataConfig, seed: int):
    """The stream the families are cut from, drawn in chunks."""
    rng = np.random.default_rng([seed, 2])
    parts, left = [], config.draws
    while left > 0:
        parts.append(pdata.stream(min(left, data_config.chunk), rng, data_config))
        left -= len(parts[-1])
    return pdata.PaperSet.concat(parts)


def run_diagnostics(config: DiagnosticsConfig, data_config: pdata.PaperDataConfig, seed: int,
                    hidden, learning_rate: float, momentum: float, log=print) -> list[dict]:
    """Train and evaluate the network on each family; one row of results per family."""
    start = time.perf_counter()
    data = draw(config, data_config, seed)
    log(f"diagnostics: {len(data):,} pairs drawn in {time.perf_counter() - start:.1f} s")
    size = np.full(3, data_config.edge)
    tc = dataclasses.replace(config.train, learning_rate=learning_rate, momentum=momentum,
                             seed=seed)
    rows = []
    for name, mask in family_masks(data).items():
        family = data.take(np.flatnonzero(mask))
        sets = pdata.split(family, config.sizes)
        tr, va, te = (sets[k] for k in ("training", "cross_validation", "external_validation"))
        model = train(tr.inputs, tr.targets, va.inputs, va.targets, MLPConfig(hidden=hidden), tc)
        m = pm.evaluate(model.predict(te.inputs), te.targets, size, te.point)
        regions = len(set(zip(family.contact_type_code.tolist(), family.feature_a.tolist(),
                              family.feature_b.tolist())))
        rows.append({"family": name, "title": FAMILY_TITLES[name],
                     "share": float(mask.mean()), "regions": regions,
                     "raw": m["raw"], "wrapped": m["wrapped"],
                     "per_output_mae_wrapped": [v["MAE"] for v in
                                                m["per_output_wrapped"].values()],
                     "normal_error_deg_mean": m["normal_error_deg"]["mean"],
                     "point_error_percent_mean": m["point_error_percent_of_edge"]["mean"],
                     "best_epoch": model.best_epoch, "epochs_run": model.epochs_run,
                     "stopped_by": model.stopped_by, "seconds": model.seconds})
        log(f"diagnostics: {name}: external MAE {m['raw']['MAE']:.4f} "
            f"({model.epochs_run} epochs, {model.seconds:.1f} s)")
    return rows
