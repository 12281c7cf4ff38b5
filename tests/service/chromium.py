"""Headless Chromium for the docs-page tests, with nothing reachable but loopback.

:func:`find` looks for Debian's ``chromium`` on PATH and installs the package with apt-get where
it is missing and we are root (as :mod:`tests.training.postgres_server` does for PostgreSQL);
anything that prevents a browser raises :class:`Unavailable` with the reason, which the fixture
turns into a skip. :func:`dump_dom` and :func:`screenshot` load a page in a fresh profile with
:data:`OFFLINE_FLAGS`: every host but loopback resolves to nothing and goes through a proxy that
nothing listens on, so a page that needs the internet renders without it (blank, for FastAPI's
stock CDN pages). :func:`page_requests` reads Chromium's net log back: the URLs that the page
itself asked for, to show that it asked for nothing outside the service. :func:`visible_text` is
the DOM's text (what the scripts rendered), not the HTML that the server sent.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
from html.parser import HTMLParser
from pathlib import Path

from tests.apt_packages import Unavailable, apt_install

#: Seconds one headless run may take (a page renders in 2-3 s).
RUN_TIMEOUT_S = 120
#: Virtual time a page gets for its scripts before the DOM is dumped or the screenshot taken:
#: Chromium fast-forwards idle timers, so this costs far less wall time, and ends early once
#: the page has nothing left to do.
VIRTUAL_TIME_BUDGET_MS = 10_000
#: A port nothing listens on (discard): the proxy for every host that is not loopback.
DEAD_PROXY = "127.0.0.1:9"
#: Only loopback reachable. Chromium never proxies loopback itself; every other host fails to
#: resolve, and would fail at the dead proxy if it resolved.
OFFLINE_FLAGS = [
    f"--proxy-server={DEAD_PROXY}",
    "--proxy-bypass-list=127.0.0.1;localhost",
    "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1",
]
#: Headless, as root (no sandbox), without the GPU, first-run and background traffic.
BASE_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--no-first-run",
    "--disable-background-networking",
    "--hide-scrollbars",
    f"--virtual-time-budget={VIRTUAL_TIME_BUDGET_MS}",
]
#: Elements whose content is not rendered text.
_NOT_TEXT = {"script", "style", "noscript", "template"}


def find() -> str:
    """The ``chromium`` executable, installed first if needed; raises Unavailable."""
    found = shutil.which("chromium")
    if found is None:
        apt_install("chromium", "chromium")
        found = shutil.which("chromium")
        if found is None:
            raise Unavailable("apt-get installed chromium but no chromium is on PATH")
    return found


def _run(browser: str, url: str, flags: list[str]) -> str:
    """Load ``url`` once in a fresh profile (a shared one would hand the page to a browser
    already running it) and return stdout; raises AssertionError with stderr on failure."""
    with tempfile.TemporaryDirectory(prefix="impactnet-chromium-") as profile:
        done = subprocess.run([browser, *BASE_FLAGS, *OFFLINE_FLAGS,
                               f"--user-data-dir={profile}", *flags, url],
                              capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
    assert done.returncode == 0, f"chromium exited {done.returncode}: {done.stderr[-2000:]}"
    return done.stdout


def dump_dom(browser: str, url: str, net_log: Path | None = None) -> str:
    """The page's DOM after its scripts ran, serialised; ``net_log``: write Chromium's net log
    of the run there (read it with :func:`page_requests`)."""
    flags = ["--dump-dom"] + ([f"--log-net-log={net_log}"] if net_log else [])
    return _run(browser, url, flags)


def screenshot(browser: str, url: str, path: Path, width: int, height: int) -> None:
    """A PNG of the page's first ``width`` x ``height`` CSS pixels, written to ``path``."""
    _run(browser, url, [f"--screenshot={path}", f"--window-size={width},{height}"])
    assert path.is_file(), f"chromium wrote no screenshot to {path}"


def page_requests(net_log: Path, origin: str) -> list[str]:
    """URLs of the requests that the page at ``origin`` started (its scripts, styles, images,
    fetches), from a net log; the browser's own traffic (updates, time sync) has no initiator
    and is left out."""
    log = json.loads(net_log.read_text())
    start_job = log["constants"]["logEventTypes"]["URL_REQUEST_START_JOB"]
    return [event["params"]["url"] for event in log["events"]
            if event["type"] == start_job and event.get("params", {}).get("initiator") == origin]


class _Text(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.hidden, self.parts = 0, []

    def handle_starttag(self, tag, attrs) -> None:
        self.hidden += tag in _NOT_TEXT
        if tag != "wbr":  # a line-break opportunity inside a word (Swagger UI's paths)
            self.parts.append(" ")

    def handle_endtag(self, tag) -> None:
        self.hidden -= tag in _NOT_TEXT
        self.parts.append(" ")

    def handle_data(self, data) -> None:
        if not self.hidden:
            self.parts.append(data)


def visible_text(dom: str) -> str:
    """The text of a serialised DOM, as a reader sees it: no scripts or styles, elements
    separated by one space, zero-width spaces (Swagger UI's break hints) removed."""
    parser = _Text()
    parser.feed(dom)
    return re.sub(r"\s+", " ", "".join(parser.parts).replace("\u200b", "")).strip()
