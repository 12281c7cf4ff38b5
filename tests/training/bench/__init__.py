"""Tests of impactnet.training.bench."""
