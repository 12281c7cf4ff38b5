"""Tests of impactnet.models.compound."""
