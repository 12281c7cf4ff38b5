"""NumPy inference of the learned predictors: the canonical frame of a pair, pose columns, the
region labeller, frozen MLPs, per-pair runtimes, the dispatch of a request to a pair's models,
and the predictors ``single``, ``committee`` and ``auto`` (batch and one-pair paths).

May import NumPy, ``impactnet.models.geometry``, ``impactnet.models.box`` (the exact fallback and
the labeller's separating-axis decision) and ``impactnet.models.bundle``; never torch.
"""
