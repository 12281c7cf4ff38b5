"""The learned path of compound pairs (issue #21): a classifier of the touching part pairs per
part group (a corner), an expert per contact region (a committee of MLPs, or the exact
part-pair solver), and the exact compound oracle for the rows the classifier is unsure of.

Served by compiled kernels (:mod:`impactnet.models.learned.compound.kernel_classify`); trained
by :mod:`impactnet.training.compound`. May import the rest of ``impactnet.models``; never
training or the service.
"""
from impactnet.models.learned.compound.chain import CompoundChain, chain_of

__all__ = ["CompoundChain", "chain_of"]
