"""Tests of impactnet.models.bundle."""
