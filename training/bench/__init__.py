"""`impactnet bench`: the speed-accuracy trade of every way of answering, measured in one run.

Modules
-------
timing      one-core timing helpers and the machine record (shared with ``bench exact``)
pose_sets   the scene's first-contact poses and the paper's Figure 2 hard case
polygon     the paper's polygon method (grid-triangulated boxes, FCL BVH meshes)
methods     every method behind one interface: exact, FCL Box-Box, polygon n, learned
errors      errors against the exact solver on the same poses
vs_mujoco   errors against MuJoCo's box-box and the grid centre of pressure ("vs MuJoCo")
mujoco_reference, cop_reference, cop_frame
            the two independent references (MuJoCo wrapper; centre of pressure on a grid)
contact_sets  stacking and edge-on-edge pose recipes; stacking_table  the per-tilt table
measure     the measurement plan (BenchConfig) and one method on one pose set
runner      the run: pose sets, every method on each, the paper check, optional HTTP
paper       the paper's Section II grid estimate, checked against the polygon sweep
report      Markdown tables and JSON
plots       the Pareto plot, the polygon sweep against n, Figure 2 errors against the tilt
http        the same through the HTTP service (``--http``), on loopback
speed/      speed as ratios against MuJoCo called from Python, and the per-stage profile
            (issue #32; the speed section of the report, ``impactnet bench speed`` alone, and
            the MuJoCo columns of ``impactnet bench compound``)

Nothing here is imported by the package itself, so importing ``impactnet.training.bench`` stays
cheap.
"""
