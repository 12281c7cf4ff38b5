"""Training of the learned path of compound pairs (issue #21): the group classifiers, the
per-region expert choice, the held-out figures and the per-pair decision (learned or
exact-only), written into the bundle's ``compound_pairs``.
"""
