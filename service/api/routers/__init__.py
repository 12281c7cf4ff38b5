"""One router per resource: contact, batch, frame, models, health, metrics, docs, admin."""
from __future__ import annotations

from impactnet.service.api.schemas import ErrorResponse
from impactnet.service.errors import ServiceError

#: OpenAPI error responses shared by the contact routes.
ERRORS = {
    409: {"model": ErrorResponse, "description": "The mode is known but not served (no "
          "learned bundle loaded)."},
    413: {"model": ErrorResponse, "description": "Body, batch, geometry or work above a limit "
          "(`limit` names the setting)."},
    422: {"model": ErrorResponse, "description": "Invalid input: `detail` names the field "
          "and the reason (and, in a batch, the rows); or `unsupported_pair`: a strict "
          "learned mode (single, committee) has no model for the pair's box sizes."},
    503: {"model": ErrorResponse, "description": "Not ready, draining, or too much work in "
          "flight, refused before any work (Retry-After)."},
    504: {"model": ErrorResponse, "description": "The request computed past "
          "compute_deadline_s; its work was stopped (never retried by a front)."},
}


def MOVED(old: str, new: str) -> ServiceError:  # noqa: N802 - an error's name, like a class
    """410 ``moved``: a path of the answer shape before 0.2.0 (CHANGELOG.md)."""
    return ServiceError(410, "moved", f"{old} was replaced by {new} in impactnet 0.2.0: the "
                        "answer has one shape for boxes and bodies made of parts "
                        "(CHANGELOG.md)", new_path=new)
