"""Tests of impactnet.models.learned."""
