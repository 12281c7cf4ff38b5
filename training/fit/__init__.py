"""Fitting the learned models in PyTorch: the stacked MLPs and their training loop, the single
MLP and the per-region committees of one pair, the calibration of ``auto`` and the validation
gate of a new bundle.

May import ``impactnet.models``, ``impactnet.training.data`` and torch; never fastapi.
"""
