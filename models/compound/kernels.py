"""The compound solver's compiled kernels (named in
:data:`impactnet.models.compiled.KERNEL_MODULES`): importing this module imports every module
of kernels, so that their warm-ups register (:func:`impactnet.models.compiled.warm_up`).

* :mod:`impactnet.models.compound.convex_contact`: the convex part solver (separating-axis
  test of :mod:`~impactnet.models.compound.convex_sat`, face contact of
  :mod:`~impactnet.models.compound.convex_face`), one warm-up for all three;
* :mod:`impactnet.models.compound.warm`: the compiled oracle (broadphase, narrowphase,
  covered-surface filter and summary of :mod:`~impactnet.models.compound.kernel_pipeline`,
  launched by :mod:`~impactnet.models.compound.pipeline`): every entry, serial and parallel.
"""
from impactnet.models.compound import (
    convex_contact,  # noqa: F401 - registers its warm-up
    warm,  # noqa: F401 - registers its warm-up
)
