"""A frame of the simulation in one call (issue #34): every contact among many bodies, and the
gap before contact. The broadphase over bodies (:mod:`impactnet.models.frame.broadphase`) finds
the pairs that may touch or lie within a margin; each pair is then answered by the pairwise
solvers."""
