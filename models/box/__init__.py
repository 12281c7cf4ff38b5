"""The exact box-box solver: the batch path (exact), the one-pair path (exact_one), the local
frame, the separating-axis test with its tie rule (sat), the incident-face clip (clip, manifold)
and the centre of pressure (pressure, pressure_one).

May import NumPy, ``impactnet.models.geometry`` and ``impactnet.models.contacts`` / ``domain``;
never the learned predictors.
"""
