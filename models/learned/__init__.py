"""Compiled inference of the learned predictors: the canonical frame of a pair, the region
labeller, frozen MLPs, per-pair runtimes, the dispatch of a request to a pair's models, and the
predictors ``single``, ``committee`` and ``auto``, one compiled row function for one pair and
for any batch (:mod:`impactnet.models.learned.kernels` lists the kernels).

May import NumPy, numba (through :mod:`impactnet.models.compiled`),
``impactnet.models.geometry``, ``impactnet.models.box`` (the exact fallback and the labeller's
separating-axis decision) and ``impactnet.models.bundle``; never torch.
"""
