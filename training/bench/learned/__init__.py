"""The learned paths against the exact answers: where a learned model is worth serving, how
accurate and fast it is, and probes of designs for the compound classifiers.

Modules
-------
decide             ``impactnet bench decide``: per pair of a box scene, exact-only or learned
                   (issue #21's rule, also the training jobs' decision)
moe                ``impactnet bench moe``: the compound learned path against the oracle, pair
                   by pair, and its cost against detail
moe_report         its Markdown tables and plot
classifier_probe   can an MLP name the touching part pairs of a compound pair?
classifier_pooled  one classifier pooled over the mirror-symmetric corners, against one each
"""
