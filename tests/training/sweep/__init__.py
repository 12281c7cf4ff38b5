"""Tests of impactnet.training.sweep."""
