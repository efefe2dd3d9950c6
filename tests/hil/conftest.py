"""A real browser for the hil tests: Debian's chromium driven by Playwright (no download).

``make test`` installs ``chromium`` (the Makefile) and ``playwright`` ([dev]); the browser is
launched once per test session, and ``tab`` is one page of it that the tests take in turn (a
page costs about 0.5 s to open). ``hil_app`` serves a session on a free port of 127.0.0.1.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from pacc.hil.plan import Step
from pacc.hil.server import ServerThread, create_app
from pacc.hil.session import Session, SessionConfig

CHROMIUM = "/usr/bin/chromium"


@pytest.fixture(scope="session")
def browser() -> Iterator[Any]:
    """One headless chromium for the whole test session (skipped without Debian chromium)."""
    if shutil.which(CHROMIUM) is None:
        pytest.skip(f"{CHROMIUM} is missing: `make test` installs it (apt-get install chromium)")
    from playwright.sync_api import sync_playwright  # noqa: PLC0415 - only the browser tests

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True)
        yield b
        b.close()


AppFactory = Callable[..., tuple[str, Session]]


@pytest.fixture(scope="session")
def _stopping() -> Iterator[list[ServerThread]]:
    """Servers told to stop, joined at the end: each takes up to 0.1 s to notice, meanwhile
    the next tests run."""
    servers: list[ServerThread] = []
    yield servers
    for server in servers:
        server.stop()


@pytest.fixture
def hil_app(tmp_path: Path, _stopping: list[ServerThread]) -> Iterator[AppFactory]:
    """Factory: ``hil_app(plan, **SessionConfig fields)`` -> (base URL, session), served."""
    servers: list[tuple[ServerThread, Session]] = []

    def make(plan: list[Step], **kw: Any) -> tuple[str, Session]:
        kw.setdefault("participant", "P01")
        kw.setdefault("protocol", "test")
        kw.setdefault("out", tmp_path / "sessions")
        session = Session(SessionConfig(**kw), plan)
        server = ServerThread(create_app(session, tmp_path / "gamepad.json"))
        port = server.start()
        servers.append((server, session))
        return f"http://127.0.0.1:{port}", session

    yield make
    for server, session in servers:
        session.close()
        server.server.should_exit = True
        _stopping.append(server)


@pytest.fixture(scope="session")
def _shared_tab(browser: Any) -> Iterator[Any]:
    page = browser.new_page()
    yield page
    page.close()


@pytest.fixture
def tab(_shared_tab: Any, hil_app: AppFactory) -> Iterator[Any]:
    """The shared page for one test (goto a ``hil_app`` URL): its uncaught errors are
    collected in ``tab.errors`` and fail the test; it leaves for about:blank before the
    test's servers stop."""
    page = _shared_tab
    page.errors = []

    def on_error(e: Any) -> None:
        page.errors.append(str(e))

    page.on("pageerror", on_error)
    yield page
    page.goto("about:blank")
    page.remove_listener("pageerror", on_error)
    assert page.errors == [], page.errors
