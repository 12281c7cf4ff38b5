"""Tests of the project's documents: figures named by their commands, examples that run."""
