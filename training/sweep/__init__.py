"""Hyper-parameter sweeps with Optuna (``impactnet sweep``): the search space, the runner
(SQLite or PostgreSQL storage) and the report.

May import ``impactnet.models`` and the other training wings; never fastapi.
"""
