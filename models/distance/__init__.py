"""The gap before contact (issue #34, item 3): the distance between two convex polytopes (a
box is a polytope of 8 corners, a compound body's convex part is its hull), their closest
points and the unit direction from A towards B, so that a landing spreader is told how far its
twistlocks are above the castings before they touch.

Where the closest points are not unique (parallel faces, parallel edges) the answer is the
centroid of the closest region, as the centre of pressure is for a contact, so that the point
moves continuously with the pose. Touching or overlapping pairs answer distance 0 (the contact
solver gives the depth).

* :func:`~impactnet.models.distance.query.polytope_gaps`: N poses of one pair (the entry);
* :func:`~impactnet.models.distance.kernels.gap_row`: the compiled row function other kernels
  call, on the flat tables of :func:`~impactnet.models.distance.tables.hull_tables`;
* :mod:`~impactnet.models.distance.gjk`, :mod:`~impactnet.models.distance.region`: the stages;
  :mod:`~impactnet.models.distance.tolerances`: their tolerances.

Imports NumPy, numba (through :mod:`impactnet.models.compiled`) and the hulls of
:mod:`impactnet.models.compound.hull`.
"""
