"""Fixtures for the studio's browser tests (Debian's Chromium driven by Playwright).

A test module sets ``pytest_plugins = ["studio_pages"]`` and gets the fixtures ``server`` (a
studio on a free port, one per module), ``browser``, ``open_studio(width, height)`` and
``studio`` (a page with the studio ready); they fail the test on any console error, uncaught
exception or unhandled promise rejection. Tests wait on
the page's state (``wait_for_function``), never for fixed times.
"""

from __future__ import annotations

import os
import re
import socket
import threading
import time

import pytest

from studio_helpers import TIMEOUT_MS

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run",
        "--autoplay-policy=no-user-gesture-required"]
#: Chromium's software GL reports stalls as console warnings, not errors; nothing to ignore
#: what a message for people must not contain: server paths, command-line flags, regexes
JARGON = re.compile(r"(?:^|[\s'\"(])(?:/[\w.-]+){2,}|(?:^|\s)--[a-z]|\^\[|\]\*\$|\(\?:|\\[dws]"
                    r"|Traceback|Error:|\w+Error\b")
READY = "window.mimikaStudio && window.mimikaStudio.ready === true"



def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


#: the head the browser tests open with (the light built-in head); a test module may set
#: ``STUDIO_HEAD`` to open with another (the default character has its own test file)
HEAD = "builtin"


@pytest.fixture(scope="module")
def server(tmp_path_factory, request):
    pytest.importorskip("fastapi")
    uvicorn = pytest.importorskip("uvicorn")
    from mimika.errors import DataError
    from mimika.studio.app import create_app
    from mimika.web.three import ensure_vendor

    try:
        ensure_vendor()
    except DataError as e:
        pytest.skip(str(e))
    d = tmp_path_factory.mktemp("studio-browser")
    app = create_app(d / "projects", library_path=d / "expressions.json", warm_up=True,
                     head=getattr(request.module, "STUDIO_HEAD", HEAD))
    port = _free_port()
    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning",
                                        ws_max_size=2 * 1024 * 1024))
    th = threading.Thread(target=srv.run, daemon=True)
    th.start()
    t0 = time.time()
    while not srv.started:
        if time.time() - t0 > 60:
            pytest.fail("studio server did not start")
        time.sleep(0.05)
    yield {"url": f"http://127.0.0.1:{port}/", "dir": d, "app": app}
    srv.should_exit = True
    th.join(10)


@pytest.fixture(scope="module")
def browser():
    if not os.path.exists(CHROMIUM):
        pytest.skip("Chromium is missing: run scripts/setup-browser.sh "
                    "(sudo apt-get install -y chromium)")
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


class _Problems:
    """Console errors and uncaught errors of a page; ``allow`` whitelists expected ones."""

    def __init__(self) -> None:
        self.seen: list[str] = []
        self.allowed: list[re.Pattern] = []

    def allow(self, pattern: str) -> None:
        self.allowed.append(re.compile(pattern))

    def unexpected(self) -> list[str]:
        return [m for m in self.seen if not any(p.search(m) for p in self.allowed)]


@pytest.fixture
def open_studio(browser, server):
    """``open_studio(width, height)`` → a ready studio page at that viewport."""
    contexts = []
    problems = _Problems()

    def _open(width: int = 1440, height: int = 900, *, init_script: str | None = None):
        ctx = browser.new_context(viewport={"width": width, "height": height},
                                  accept_downloads=True)
        contexts.append(ctx)
        if init_script:
            ctx.add_init_script(init_script)
        pg = ctx.new_page()
        pg.set_default_timeout(TIMEOUT_MS)
        pg.on("pageerror", lambda e: problems.seen.append(f"uncaught: {e}"))
        pg.on("console", lambda m: problems.seen.append(f"console.{m.type}: {m.text}")
              if m.type == "error" else None)
        pg.goto(server["url"])
        pg.wait_for_function(READY, timeout=120_000)
        pg.problems = problems
        return pg

    yield _open
    shown: list[str] = []
    for ctx in contexts:
        for pg in ctx.pages:
            shown += pg.evaluate("window.__mimikaToasts || []")
        ctx.close()
    bad = problems.unexpected()
    assert not bad, bad
    jargon = [t for t in shown if JARGON.search(t)]
    assert not jargon, f"messages with server paths, command-line flags or regexes: {jargon}"


@pytest.fixture
def studio(open_studio):
    return open_studio()
