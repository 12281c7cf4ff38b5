"""Tests of impactnet.models."""
