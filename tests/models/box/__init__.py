"""Tests of impactnet.models.box."""
