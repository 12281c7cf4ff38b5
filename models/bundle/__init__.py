"""Learned bundles on disk: the format (safetensors weights and a JSON manifest with
checksums, never pickle) and the versioned store that training writes and serving follows.

May import NumPy and safetensors; the bundle reads and writes tensors and manifests as plain
data and knows no predictor (never ``impactnet.models.learned`` nor the exact solver: the
learned side builds its models from a bundle, :mod:`impactnet.models.learned.bundle_loader`).
"""
