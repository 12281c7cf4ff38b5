"""Errors of a way of answering against references, on the same poses.

Modules
-------
errors            errors against the exact solver (missed contacts, normal, point, depth)
vs_mujoco         errors against MuJoCo's box-box and the grid centre of pressure
                  (the report's "vs MuJoCo" column; the tests comparing the exact solver with
                  MuJoCo)
mujoco_reference  MuJoCo's box-box collider in impactnet conventions
cop_reference     an independent centre of pressure: a midpoint grid over the reference face
cop_frame         its geometry: which face, and where to integrate
stacking_table    ``python -m impactnet.training.bench.accuracy.stacking_table``: how a box
                  resting on another is answered, per tilt, against MuJoCo and the grid
"""
