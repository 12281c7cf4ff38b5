"""Evaluation of a bundle on held-out rows (``impactnet evaluate``): test data, per-row
metrics, the paper's four-angle metric, figures and the Markdown report.

May import ``impactnet.models`` and the other training wings; never fastapi.
"""
