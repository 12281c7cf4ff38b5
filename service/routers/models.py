"""GET /v1/models: what this server serves."""
from __future__ import annotations

from fastapi import APIRouter, Response

from models import box_features as bf
from models.contacts import CONTACT_TYPES
from service.deps import RuntimeDep, ServingDep
from service.pairs import PAPER_ANGLES_AVAILABLE
from service.routers import ERRORS
from service.schemas import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M, ModelsResponse

router = APIRouter(tags=["models"])

FEATURE_NAMES = {str(i): bf.feature_name(i) for i in range(-1, bf.N_FEATURES)}


@router.get("/v1/models", response_model=ModelsResponse, responses={503: ERRORS[503]},
            summary="Scene, bundle, versions and modes of this server")
async def models(runtime: RuntimeDep, state: ServingDep, response: Response) -> ModelsResponse:
    settings = runtime.settings
    response.headers["X-Model-Version"] = state.model_version
    return ModelsResponse(
        model_version=state.model_version,
        modes={"available": state.modes, "unavailable": state.unavailable,
               "default": state.default_mode},
        scene=state.scene.describe() if state.scene.name else None,
        scene_note=state.scene_note,
        bundle=state.bundle,
        versions=runtime.versions,
        limits={"max_body_bytes": settings.max_body_bytes,
                "max_batch_pairs": settings.max_batch_pairs,
                "max_concurrency": settings.max_concurrency,
                "position_max_m": POSITION_MAX_M, "size_min_m": SIZE_MIN_M,
                "size_max_m": SIZE_MAX_M},
        contact_types=list(CONTACT_TYPES),
        feature_names=FEATURE_NAMES,
        includes=["manifold"] + (["paper_angles"] if PAPER_ANGLES_AVAILABLE else []),
        loaded_at=state.loaded_at,
    )
