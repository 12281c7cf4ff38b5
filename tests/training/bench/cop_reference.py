"""Test helper: an independent centre-of-pressure reference (a grid over the reference face).

Not a test module. The implementation lives in
:mod:`impactnet.training.bench.accuracy.cop_reference` (it imports nothing from ``models``: no
manifold, no clipping) so that ``impactnet bench`` and the tests share it.
:func:`centre_of_pressure` takes the poses and a contact normal, picks the face of A or B best
aligned with it (A's with +normal, B's with -normal), samples the footprint of the incident box's
part beyond that face on a midpoint grid (the cells on the footprint's edge resampled finer),
measures the depth at each sample by a ray / slab intersection with the incident box along the face
normal, and returns the depth-weighted mean of ``y - n d(y) / 2``, with an estimate of the
discretisation error (the answer on a grid of half the resolution). The accuracy of each grid is
measured in ``tests/training/bench/test_centre_of_pressure_reference.py``.
"""
from impactnet.training.bench.accuracy.cop_reference import (
    DEFAULT_GRID,
    DEFAULT_REFINE,
    CentreOfPressure,
    centre_of_pressure,
    reference_faces,
)

__all__ = ["DEFAULT_GRID", "DEFAULT_REFINE", "CentreOfPressure", "centre_of_pressure",
           "reference_faces"]
