"""The HTTP surface of the service: routers per resource, their dependencies, the pydantic
schemas, the error model and the middleware.

May import FastAPI, ``impactnet.models`` and the rest of ``impactnet.service``; never torch.
"""
