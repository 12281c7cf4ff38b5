"""The FastAPI service: request/response schemas, routers, settings.

May import `models`; never imports torch or `training`. Arrives with the service issue.
"""
