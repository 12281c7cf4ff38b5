"""Tests of impactnet.training.jobs."""
