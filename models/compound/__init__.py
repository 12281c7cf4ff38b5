"""Compound bodies: bodies made of convex parts (boxes and convex polyhedra) in the body's
frame, their validation, and generators of the harbour's bodies (ISO containers with corner
castings, a spreader with twistlocks, a cell guide). Issue #20; the compound contact oracle
builds on these.

May import NumPy and the rest of ``impactnet.models``; never the learned predictors.
"""
