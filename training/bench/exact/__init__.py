"""Speed of the exact solver on one thread: against python-fcl (``impactnet bench exact``) and
against an earlier checkout of this repository (same session, same poses).

Modules
-------
vs_fcl          ``impactnet bench exact``: the exact solver next to python-fcl's Box-Box
baseline        N = 1 speed of the exact solver against an earlier checkout (``--baseline``)
baseline_modes  every predictor mode of this checkout against an earlier one, N = 1 and batch
                (``python -m impactnet.training.bench.exact.baseline_modes``)
"""
