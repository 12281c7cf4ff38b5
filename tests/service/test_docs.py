"""GET /docs and /redoc offline (service/api/routers/docs.py): every script, style sheet and icon
that the pages name is served by the service itself, with its media type; no page names an
outside URL; the browser is told to load nothing from elsewhere. The pages in a real browser:
test_docs_browser.py."""
from __future__ import annotations

from html.parser import HTMLParser
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient

from impactnet.service.api.routers.docs import ASSETS, STATIC_PREFIX
from impactnet.service.app import create_app
from tests.service.conftest import assert_error, test_settings

#: Media type expected of each asset, by file extension.
MEDIA_TYPES = {".js": "text/javascript", ".css": "text/css", ".png": "image/png"}
#: Behind a reverse proxy that serves the app under a prefix (``root_path``).
PROXY_PREFIX = "/impactnet"


class _Links(HTMLParser):
    """Every ``src`` and ``href`` of a page, and the spec URL of ReDoc's element."""

    def __init__(self) -> None:
        super().__init__()
        self.urls: list[str] = []

    def handle_starttag(self, tag, attrs) -> None:
        self.urls += [value for name, value in attrs if name in ("src", "href", "spec-url")]


def links(html: str) -> list[str]:
    parser = _Links()
    parser.feed(html)
    return parser.urls


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_page_names_only_local_urls_and_each_answers_with_its_media_type(client, page):
    response = client.get(page)
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("text/html")
    assert "http://" not in response.text and "https://" not in response.text
    urls = links(response.text)
    assert any(url.endswith(".js") for url in urls), urls
    for url in urls:
        parts = urlsplit(url)
        assert not parts.scheme and not parts.netloc and url.startswith("/"), url
        if url.startswith(STATIC_PREFIX):
            asset = client.get(url)
            assert asset.status_code == 200, url
            media_type = asset.headers["content-type"].split(";")[0]
            assert media_type == MEDIA_TYPES[url[url.rindex("."):]], (url, media_type)
            assert len(asset.content) > 1000, url
    assert "'/openapi.json'" in response.text or '"/openapi.json"' in response.text


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_page_forbids_the_browser_to_load_from_elsewhere(client, page):
    policy = client.get(page).headers["content-security-policy"]
    directives = dict(d.strip().split(" ", 1) for d in policy.split(";"))
    assert directives["default-src"] == "'self'"
    for directive in ("script-src", "style-src", "img-src", "connect-src", "font-src"):
        assert "http" not in directives[directive] and "*" not in directives[directive]


def test_redoc_loads_no_google_fonts(client):
    assert "fonts.googleapis" not in client.get("/redoc").text


def test_every_served_asset_is_a_file_of_the_package(client):
    for name in ASSETS:
        response = client.get(f"{STATIC_PREFIX}/{name}")
        assert response.status_code == 200, name
        assert response.headers["cache-control"].startswith("public")


@pytest.mark.parametrize("path", [f"{STATIC_PREFIX}/nope.js", f"{STATIC_PREFIX}/..%2Fcore.py",
                                  f"{STATIC_PREFIX}/", "/docs/oauth2-redirect"])
def test_unknown_asset_and_fastapis_oauth_page_are_404_in_the_envelope(client, path):
    assert_error(client.get(path), 404)


def test_pages_behind_a_proxy_prefix_name_prefixed_urls():
    app = create_app(test_settings())
    with TestClient(app, root_path=PROXY_PREFIX) as client:
        for page in ("/docs", "/redoc"):
            urls = links(client.get(page).text)
            assert urls and all(url.startswith(PROXY_PREFIX + "/") for url in urls), urls
        assert f"{PROXY_PREFIX}/openapi.json" in client.get("/docs").text


def test_schema_does_not_list_the_docs_routes(client):
    paths = client.get("/openapi.json").json()["paths"]
    assert not any(path in ("/docs", "/redoc") or path.startswith(STATIC_PREFIX)
                   for path in paths)
