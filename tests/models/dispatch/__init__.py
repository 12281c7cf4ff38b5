"""Tests of impactnet.models.dispatch."""
