"""/docs and /redoc in a real browser with nothing reachable but loopback: Debian's headless
Chromium (:mod:`tests.service.chromium`, installed with apt-get if missing) against
``impactnet serve`` on a free loopback port. The rendered DOM's text lists every operation of
the schema, and the page asked for nothing but the service's own URLs (Chromium's net log).

The README's screenshot comes from the last test: ``IMPACTNET_DOCS_SCREENSHOT=docs/images/
api_docs_offline.png pytest tests/service/test_docs_browser.py -k screenshot`` (one line).
"""
from __future__ import annotations

import json
import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.service import chromium
from tests.service.conftest import ServerProcess, get

pytestmark = pytest.mark.slow

#: Where the screenshot test also writes its PNG, when set (the README's image).
SCREENSHOT_ENV = "IMPACTNET_DOCS_SCREENSHOT"
#: Screenshot size in CSS pixels: tall enough for the description and every operation.
SCREENSHOT_SIZE = (1280, 1200)
#: Swagger UI's colours of the POST and GET badges (swagger-ui.css): present only when its
#: style sheet loaded and its script rendered the operations.
POST_GREEN, GET_BLUE = (73, 204, 144), (97, 175, 254)
#: Fewest pixels of a badge colour that count as "rendered" (one badge is ~4,400 pixels).
MIN_BADGE_PIXELS = 1000
#: What each page must have loaded from the service itself.
PAGE_ASSETS = {
    "/docs": {"/static/docs/swagger-ui-bundle.js", "/static/docs/swagger-ui.css",
              "/openapi.json"},
    "/redoc": {"/static/docs/redoc.standalone.js", "/openapi.json"},
}


@pytest.fixture(scope="module")
def browser() -> str:
    try:
        return chromium.find()
    except (chromium.Unavailable, OSError) as exc:
        pytest.skip(f"no headless Chromium: {exc}")


@pytest.fixture(scope="module")
def served():
    """``impactnet serve`` (the installed entry point) on a free loopback port, ready."""
    entry = Path(sys.executable).with_name("impactnet")
    command = [str(entry), "serve"] if entry.exists() else None
    proc = ServerProcess(args=["--no-access-log"], command=command)
    try:
        proc.wait_ready()
        yield proc
    finally:
        proc.cleanup()


def _operations(port: int) -> list[tuple[str, str]]:
    status, body = get(port, "/openapi.json")
    assert status == 200
    return [(method, path) for path, item in json.loads(body)["paths"].items()
            for method in item]


@pytest.mark.parametrize("page", sorted(PAGE_ASSETS))
def test_page_renders_every_operation_with_only_loopback_reachable(browser, served, page,
                                                                   tmp_path):
    net_log = tmp_path / "net.json"
    dom = chromium.dump_dom(browser, served.url + page, net_log=net_log)
    text = chromium.visible_text(dom).lower()
    operations = _operations(served.port)
    assert ("post", "/v2/contact/batch") in operations and ("get", "/healthz") in operations
    missing = [(method, path) for method, path in operations
               if not re.search(rf"\b{method} {re.escape(path)}(?![\w/])", text)]
    assert not missing, f"{page} rendered without {missing}: {text[:500]!r}"
    requested = chromium.page_requests(net_log, served.url)
    outside = [url for url in requested if not url.startswith(served.url + "/")]
    assert not outside, f"{page} asked for URLs outside the service: {outside}"
    loaded = {url.removeprefix(served.url) for url in requested}
    assert PAGE_ASSETS[page] <= loaded, loaded


def test_screenshot_of_docs_shows_the_styled_operations(browser, served, tmp_path):
    png = tmp_path / "docs.png"
    chromium.screenshot(browser, served.url + "/docs", png, *SCREENSHOT_SIZE)
    image = pytest.importorskip("PIL.Image", reason="Pillow (train extra) decodes the PNG")
    with image.open(png) as shot:
        assert shot.size == SCREENSHOT_SIZE
        pixels = np.asarray(shot.convert("RGB"))
    for colour in (POST_GREEN, GET_BLUE):
        assert (pixels == colour).all(axis=-1).sum() >= MIN_BADGE_PIXELS, colour
    if target := os.environ.get(SCREENSHOT_ENV):
        shutil.copyfile(png, target)
