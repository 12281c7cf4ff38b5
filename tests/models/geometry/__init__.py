"""Tests of impactnet.models.geometry."""
