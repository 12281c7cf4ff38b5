"""Geometry, the exact box-box solver, NumPy inference of the learned predictors, scenes, bundles.

Imports neither `training` nor `service`, nor torch, nor fastapi (see docs/design.md).
Submodules are imported explicitly (``from impactnet.models.box.exact import box_box``) so that
importing this package is cheap; :func:`load_predictor` (:mod:`impactnet.models.predictors`)
is the one name exported here, imported on first use.
"""
from __future__ import annotations

__all__ = ["load_predictor"]


def load_predictor(name: str = "auto", bundle=None):
    """The predictor ``name`` ("exact", "single", "committee", "auto"); see
    :func:`impactnet.models.predictors.load_predictor`."""
    from impactnet.models.predictors import load_predictor as load

    return load(name, bundle)
