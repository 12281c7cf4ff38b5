"""Compound bodies: bodies made of convex parts (boxes and convex polyhedra) in the body's
frame, their validation, generators of the harbour's bodies (ISO containers with corner
castings, a spreader with twistlocks, a cell guide), and the exact compound contact oracle
(broadphase over part bounds, the box solver and the convex part solver, the body-level
summary). Issue #20.

The library entry is :func:`compound_answer` (and :func:`compound_touching` where only
"do they touch" is asked); the generators are :func:`container`, :func:`spreader` and
:func:`cell_guide`.

May import NumPy, SciPy (hulls) and the rest of ``impactnet.models``; never the learned
predictors.
"""
from impactnet.models.compound.answer import CompoundAnswer, compound_answer
from impactnet.models.compound.crane_bodies import cell_guide, container, spreader
from impactnet.models.compound.oracle import compound_touching

__all__ = ["CompoundAnswer", "cell_guide", "compound_answer", "compound_touching", "container",
           "spreader"]
