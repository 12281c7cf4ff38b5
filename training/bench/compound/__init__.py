"""``impactnet bench compound``: the compound oracle's cost against detail, next to FCL
(mesh-mesh, ``Convex``) and MuJoCo on the same parts, with their errors against the oracle.

Modules
-------
detail        the run: every detail level, the oracle and each reference timed and scored
detail_one    detail 1: container stacking, the oracle next to python-fcl's Box-Box
              (``python -m impactnet.training.bench.compound.detail_one``)
references    the references (FCL mesh-mesh, FCL Convex / Box, MuJoCo), each timed alike
mujoco_model  MuJoCo's model of two compound bodies (one geom per part)
report        the Markdown report and the cost-against-detail plot
"""
