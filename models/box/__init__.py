"""The exact box-box solver: the batch path (exact), the local frame, the separating-axis test
with its tie rule (sat), the incident-face clip (clip, manifold) and the centre of pressure
(pressure); the one-pair path mirrors them in plain floats (exact_one, sat_one, pressure_one,
with its inputs validated by scalar_inputs).

May import NumPy, ``impactnet.models.geometry`` and ``impactnet.models.contacts`` / ``domain``;
never the learned predictors.
"""
