"""Tests of impactnet.training.fit."""
