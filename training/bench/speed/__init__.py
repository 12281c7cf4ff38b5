"""Speed as ratios against MuJoCo 4 called from Python, measured in one run (issue #32 items 3
and 8), and the per-stage profile of the box solver and the compound oracle.

Modules
-------
mujoco_calls   MuJoCo called the way a user must to get an answer: one pair or pose from
               Python (qpos in, contacts' arrays out), and 1,000 explicit box pairs per
               ``mj_collision`` (MuJoCo's own C rate)
ratios         the ratio arithmetic (ours / MuJoCo, time per pair or pose) and the goals
box_pairs      ``box_box`` against MuJoCo on the scene's first contacts and the stacking
               families: N = 1 from Python, and a batch against MuJoCo's C rate (all cores and
               one thread)
compound_speed ``compound_answer`` at N = 1 and in a batch against MuJoCo's one pose from
               Python, per level of ``impactnet bench compound``
stages         the stage profile's interface: name -> zero-argument callable, each timed
stage_sources  the stages of today's solvers (the single places to switch to kernel stages)
section        the box-pair columns and the profile as one section of ``impactnet bench``
               (and ``impactnet bench speed`` alone): measure, Markdown

Timing follows :mod:`impactnet.training.bench.timing`: BLAS pinned to one thread, the
collector paused, medians, warm-up calls not counted; the kernels' threads are set with
:func:`impactnet.models.compiled.set_threads`. MuJoCo is imported lazily (the dev extra).
"""
