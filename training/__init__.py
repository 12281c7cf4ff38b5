"""Data generation, PyTorch training, sweeps, evaluation, benchmarks and the paper reproduction.

May import `models` and torch (the `train` extra); never imports fastapi or `service`.
"""
