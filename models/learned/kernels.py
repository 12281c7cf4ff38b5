"""The learned runtime's compiled kernels: where they live, and their warm-up (the one-pair entry
that it compiles first is :mod:`impactnet.models.learned.pair_entry`).

Every hot stage of the learned predictors is one numba kernel, written as scalar loops over one
row, the same for N = 1 and any batch (:mod:`impactnet.models.compiled`):

* :mod:`~impactnet.models.learned.kernel_mlp`: every layer of an MLP with its activation (the
  single MLP, the committees' members, the compound classifiers), the weights as arguments;
* :mod:`~impactnet.models.learned.kernel_frame`: the canonical frame (B in A's frame, the
  symmetry fold) and its inverse;
* :mod:`~impactnet.models.learned.region_label`: the exact labeller and its unclipped point;
* :mod:`~impactnet.models.learned.kernel_pair`: a box pair's answer in each mode, the chain's
  decision (region, unsure rows, fallback) and the exact fallback;
* :mod:`~impactnet.models.learned.compound.kernel_classify`: a compound pair's classifiers
  (features, MLPs, probabilities, candidates, regions, the rows outside the domain).

:func:`warm_up` (registered with :func:`impactnet.models.compiled.on_warm_up`; this module is
one of :data:`impactnet.models.compiled.KERNEL_MODULES`) compiles or loads every kernel for the
one set of argument types the Python wrappers pass, whatever the bundle: the weights are arrays
(read-only, float64), so layer widths and committee sizes are values, not types.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.box import kernels as box_kernels
from impactnet.models.compiled import PARALLEL_MIN_ROWS, on_warm_up
from impactnet.models.learned.batch import CommitteePredictor, SinglePredictor
from impactnet.models.learned.bundle_loader import Bundle, bundle_in_memory
from impactnet.models.learned.chain import FallbackChain
from impactnet.models.learned.compound.classifier import warm_up as warm_compound
from impactnet.models.learned.mlp import MLP, MLPSpec
from impactnet.models.learned.pair_entry import one_pair_entry
from impactnet.models.learned.region_label import label_block


def example_bundle() -> Bundle:
    """A bundle of one cube pair with every model (tiny random MLPs), in memory: what the
    warm-up runs the predictors on."""
    rng = np.random.default_rng(0)

    def mlp(outputs):
        spec = MLPSpec("tanh", (12, 4, 7), outputs=outputs)
        return MLP(spec, [rng.normal(size=(4, 12)), rng.normal(size=(7, 4))],
                   [np.zeros(4), np.zeros(7)], np.zeros(12), np.ones(12), np.zeros(7),
                   np.full(7, 0.01))

    models = {"s": mlp("contact-v1"), "e0": mlp("contact-residual-v1"),
              "e1": mlp("contact-residual-v1")}
    region = "face-vertex:4:18"
    manifest = {"version": "warm-up", "mlps": {k: m.spec.to_dict() for k, m in models.items()},
                "pairs": {"a/b": {
                    "size_a": [1.0, 1.0, 1.0], "size_b": [1.0, 1.0, 1.0],
                    "depth_fraction": [0.0, 0.01], "single": "s",
                    "classifier": {"labeller": "exact-sat-v1", "regions": ["none", region]},
                    "experts": {region: ["e0", "e1"]},
                    "auto": {"confidence_min": 0.5, "normal_spread_max_deg": 5.0,
                             "point_spread_max": 0.05, "depth_margin": 0.002}}}}
    tensors = {k: v for name, m in models.items() for k, v in m.to_tensors(name).items()}
    return bundle_in_memory(manifest, tensors)


@on_warm_up
def warm_up() -> None:
    """Compile (or load from the cache) every kernel of the learned runtime for every argument
    type its wrappers pass: the MLP forward (one row, serial and parallel batches), the
    labeller, the predictors in every mode (the one-pair entry, then closed; serial and
    parallel batches), and the compound classifiers."""
    one_pair_entry()
    bundle = example_bundle()
    pair = box_kernels.example_pair()
    committee = CommitteePredictor(bundle)
    for predictor in (SinglePredictor(bundle), committee, FallbackChain(committee)):
        for n in (1, 2, PARALLEL_MIN_ROWS):
            predictor.predict(*(v if n == 1 else np.repeat(v[None], n, axis=0) for v in pair))
    mlp = bundle.mlps["s"]
    for n in (1, PARALLEL_MIN_ROWS):
        mlp.forward(np.zeros((n, 12)))
        label_block(tuple(np.repeat(v[None], n, axis=0) for v in pair))
    warm_compound()
