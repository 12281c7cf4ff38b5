"""Tests of impactnet.training.paper."""
