"""One router per resource: contact, batch, models, health, metrics, docs, admin."""
from __future__ import annotations

from impactnet.service.api.schemas import ErrorResponse

#: OpenAPI error responses shared by the /v1 routes.
ERRORS = {
    409: {"model": ErrorResponse, "description": "The mode is known but not served (no "
          "learned bundle loaded)."},
    413: {"model": ErrorResponse, "description": "Body or batch above the limit."},
    422: {"model": ErrorResponse, "description": "Invalid input: `detail` names the field "
          "and the reason (and, in a batch, the rows); or `unsupported_pair`: a strict "
          "learned mode (single, committee) has no model for the pair's box sizes."},
    503: {"model": ErrorResponse, "description": "Not ready, draining, or too many requests "
          "in flight (Retry-After)."},
}
