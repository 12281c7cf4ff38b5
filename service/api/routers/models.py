"""GET /v1/models: what this server serves."""
from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, Response

from impactnet.models.contacts import CONTACT_TYPES, POINT_RULE, POINT_RULE_VERSION
from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry import box_features as bf
from impactnet.service.api.deps import RuntimeDep, ServingDep
from impactnet.service.api.routers import ERRORS
from impactnet.service.api.schemas import ModelsResponse

router = APIRouter(tags=["models"])

#: The settings that bound a request, listed in `limits` (each refusal names one of them).
LIMITS = ("max_body_bytes", "max_json_body_bytes", "max_pair_body_bytes", "body_timeout_s",
          "memory_budget_bytes", "max_batch_pairs", "max_concurrency", "compute_deadline_s",
          "max_batch_workers", "max_queued_large_work", "small_work_max",
          "max_candidates_per_pose", "max_candidates_per_request", "max_shape_pairs_per_request",
          "max_part_contacts_per_pose", "max_part_contacts_per_batch", "max_inline_parts",
          "max_frustum_sides", "max_hull_points", "max_section_points", "max_mesh_bytes",
          "max_mesh_vertices", "max_mesh_faces", "max_inline_vertices")
FEATURE_NAMES = {str(i): bf.feature_name(i) for i in range(-1, bf.N_FEATURES)}
#: The conventions of every answer, so that a client can check what it gets.
CONVENTIONS = {"point": {"rule": POINT_RULE, "version": POINT_RULE_VERSION},
               "normal": "from A towards B", "units": "metres, radians"}


@router.get("/v1/models", response_model=ModelsResponse, responses={503: ERRORS[503]},
            summary="Scene, bundle, versions and modes of this server")
async def models(runtime: RuntimeDep, state: ServingDep, response: Response) -> ModelsResponse:
    settings = runtime.settings
    response.headers["X-Model-Version"] = state.model_version
    return ModelsResponse(
        model_version=state.model_version,
        conventions=CONVENTIONS,
        modes={"available": state.modes, "unavailable": state.unavailable,
               "default": state.default_mode},
        scene=state.scene.describe() if state.scene.name else None,
        bundle=_without_path(state.bundle),
        versions=runtime.versions,
        limits={**{name: getattr(settings, name) for name in LIMITS},
                "position_max_m": POSITION_MAX_M, "size_min_m": SIZE_MIN_M,
                "size_max_m": SIZE_MAX_M},
        contact_types=list(CONTACT_TYPES),
        feature_names=FEATURE_NAMES,
        includes=["manifold", "paper_angles"],
        loaded_at=state.loaded_at,
        replica=runtime.replica,
        store=(_without_path(runtime.follower.describe())
               if runtime.follower is not None else None),
    )


def _without_path(described: dict | None) -> dict | None:
    """A bundle's or store's description with its folder named, not its path on the server
    (GET /v1/models answers anyone; the admin reload, behind its token, shows the path)."""
    if not described or "path" not in described:
        return described
    return {("name" if k == "path" else k): (Path(v).name if k == "path" else v)
            for k, v in described.items()}
