"""GET /docs (Swagger UI) and GET /redoc (ReDoc), offline: no page names an outside URL.

FastAPI's own pages load their script, style sheet and favicon from a CDN, and ReDoc its fonts
from Google Fonts, so on a network without the internet they stay blank. These pages are the
same HTML (:func:`fastapi.openapi.docs.get_swagger_ui_html` and ``get_redoc_html``) pointed at
the copies that the ``fastapi-offline`` package ships (Swagger UI 5's bundle and CSS, ReDoc 2's
standalone bundle, FastAPI's favicon), which this router serves under :data:`STATIC_PREFIX`.
The app is built with ``docs_url=None, redoc_url=None`` so that FastAPI adds no CDN pages of
its own. A headless Chromium that reaches nothing but loopback renders both pages
(tests/service/test_docs_browser.py).
"""
from __future__ import annotations

from pathlib import Path

import fastapi_offline
from fastapi import APIRouter, Request
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from starlette.responses import FileResponse, HTMLResponse

from impactnet.service.errors import ServiceError

router = APIRouter(tags=["docs"])

#: Where the assets are served (under the app's ``root_path`` behind a proxy).
STATIC_PREFIX = "/static/docs"
#: The folder of assets in the installed fastapi-offline (``fastapi_offline/static``; the
#: requirement pins its major version, and a test fetches every asset).
ASSET_DIR = Path(fastapi_offline.__file__).resolve().parent / "static"
#: The only files served, and their media types: nothing else of that folder is reachable.
ASSETS = {
    "swagger-ui-bundle.js": "text/javascript",
    "swagger-ui.css": "text/css",
    "redoc.standalone.js": "text/javascript",
    "favicon.png": "image/png",
}
#: Browsers may keep an asset an hour: its URL carries no version, and the files change only
#: when fastapi-offline is upgraded.
ASSET_CACHE_CONTROL = "public, max-age=3600"
#: Content-Security-Policy of both pages: the browser loads nothing from elsewhere, whatever the
#: bundles try (ReDoc 2 renders an ``<img>`` of Redocly's logo from its CDN in the side menu,
#: and hides it when that load fails). Inline scripts and styles: FastAPI's Swagger UI starter
#: script, and the styles that both bundles inject; ``data:`` images: Swagger UI's icons;
#: ``blob:`` workers: ReDoc's search.
CONTENT_SECURITY_POLICY = ("default-src 'self'; script-src 'self' 'unsafe-inline'; "
                           "style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
                           "font-src 'self' data:; worker-src 'self' blob:; connect-src 'self'; "
                           "base-uri 'self'; form-action 'self'; frame-ancestors 'self'")
#: Swagger UI settings on top of FastAPI's defaults. ``validatorUrl: null``: no badge that
#: would send the schema to swagger.io's online validator.
SWAGGER_UI_PARAMETERS = {"validatorUrl": None}


def _asset_url(request: Request, name: str) -> str:
    return f"{request.scope.get('root_path', '')}{STATIC_PREFIX}/{name}"


def _openapi_url(request: Request) -> str:
    return f"{request.scope.get('root_path', '')}{request.app.openapi_url}"


@router.get("/docs", include_in_schema=False)
async def swagger_ui(request: Request) -> HTMLResponse:
    """Swagger UI: the operations, their schemas, and "Try it out"."""
    page = get_swagger_ui_html(
        openapi_url=_openapi_url(request),
        title=f"{request.app.title} - Swagger UI",
        swagger_js_url=_asset_url(request, "swagger-ui-bundle.js"),
        swagger_css_url=_asset_url(request, "swagger-ui.css"),
        swagger_favicon_url=_asset_url(request, "favicon.png"),
        oauth2_redirect_url=None,  # no OAuth2: no redirect page either
        swagger_ui_parameters=SWAGGER_UI_PARAMETERS,
    )
    page.headers["content-security-policy"] = CONTENT_SECURITY_POLICY
    return page


@router.get("/redoc", include_in_schema=False)
async def redoc(request: Request) -> HTMLResponse:
    """ReDoc: the same schema as one long page, in the browser's own fonts."""
    page = get_redoc_html(
        openapi_url=_openapi_url(request),
        title=f"{request.app.title} - ReDoc",
        redoc_js_url=_asset_url(request, "redoc.standalone.js"),
        redoc_favicon_url=_asset_url(request, "favicon.png"),
        with_google_fonts=False,
    )
    page.headers["content-security-policy"] = CONTENT_SECURITY_POLICY
    return page


@router.get(STATIC_PREFIX + "/{name}", include_in_schema=False)
async def asset(name: str) -> FileResponse:
    """One of :data:`ASSETS`; any other name is 404."""
    media_type = ASSETS.get(name)
    if media_type is None:
        raise ServiceError(404, "not_found", f"no such docs asset: {name!r}")
    return FileResponse(ASSET_DIR / name, media_type=media_type,
                        headers={"cache-control": ASSET_CACHE_CONTROL})
