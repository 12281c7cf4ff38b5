"""``impactnet bench frame`` (issue #34, items 4 and 5): a frame in one call, how its cost grows
with the bodies, and its speed against MuJoCo called from Python, in process and over HTTP,
measured in one run.

Modules
-------
worlds        the yard variants (boxes, detail 1, detail 2), yards of an exact body count, the
              bench scene the HTTP server serves, a frame's npz columns
mujoco_world  MuJoCo's model of a frame's world and its timed call (qpos in, contacts out)
stages        ``answer_frame``'s stages for the profile, and the timed frame call
scaling       ``answer_frame`` on yards of 10 to 10,000 bodies, the broadphase alone, its fit
speed         one 200-container yard against MuJoCo in process: ratios, pairs, profile
frame_http    the same yard over POST /v2/frame (npz), everything sent or the world
              registered and the spreader sent, against MuJoCo, with the server's steps
plot          the scaling figure (docs/images/frame_scaling.png)
report        the Markdown (docs/benchmarks/frame.md)
section       ``run``: measure, write frame.md, frame.json and the figure

Timing follows :mod:`impactnet.training.bench.timing` (BLAS pinned to one thread, the collector
paused, medians, warm-up calls not counted, ours and MuJoCo in alternating slices); MuJoCo is
imported lazily (the dev extra).
"""
