"""Wire formats of the service: pairs from JSON, columns and ``.npz`` batches in, answers
out, with the streaming JSON scanner that checks keys and row counts before decoding.

May import NumPy, orjson and ``impactnet.models``; never FastAPI routing, never torch.
"""
