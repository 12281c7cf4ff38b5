"""Geometry, the exact box-box solver, NumPy inference of the learned predictors, scenes, bundles.

Imports neither `training` nor `service`, nor torch, nor fastapi (see DESIGN.md). Submodules are
imported explicitly (``from models.exact import box_box``) so that importing this package is cheap.
"""
