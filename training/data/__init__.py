"""Training data: seeded first-contact poses, labelled pair datasets (generation, caching and
pickle-free storage) and the ``impactnet datagen`` command.

May import ``impactnet.models``, NumPy and SciPy; never fastapi.
"""
