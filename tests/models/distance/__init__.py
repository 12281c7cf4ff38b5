"""Tests of impactnet.models.distance."""
