"""Training jobs: every pair of a scene into a bundle (``impactnet train``), retraining into a
versioned bundle store, and the reuse of unchanged pairs.

May import ``impactnet.models`` and the other training wings; never fastapi.
"""
