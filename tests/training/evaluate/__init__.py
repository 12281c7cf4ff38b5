"""Tests of impactnet.training.evaluate."""
