"""Learned bundles on disk: the format (safetensors weights and a JSON manifest with
checksums, never pickle) and the versioned store that training writes and serving follows.

May import NumPy, safetensors and what a bundle holds (the frozen MLPs and the canonical
frame's versions of ``impactnet.models.learned``); never the exact solver.
"""
