"""The paper's polygon method, measured: both boxes as triangle meshes collided by FCL, and the
paper's Section II estimate of the grid it needs checked against the measured sweep over n.

Modules
-------
polygon        the polygon method (grid-triangulated boxes, FCL BVH meshes) and its reductions
grid_estimate  the Section II estimate of the grid, against the measurement
"""
