"""Tests of impactnet.training.data."""
