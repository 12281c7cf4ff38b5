"""The exact box-box solver: the public entries (exact), the compiled kernels that solve every
pair (kernels, with one module per stage: kernel_inputs, kernel_frame, kernel_sat,
kernel_face, kernel_pressure), their tolerances and tables (tolerances), and the solver's
intermediate answers for other callers (decision, over kernel_views).

May import NumPy, numba (through ``impactnet.models.compiled``), ``impactnet.models.geometry``
and ``impactnet.models.contacts`` / ``domain``; never the learned predictors.
"""
