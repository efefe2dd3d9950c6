"""A screenshot of the Foxglove app (Studio 1.48, web) drawing a recording through a layout.

Run by ``tools/foxglove_shot.sh`` (a maintainer's tool, not part of CI), which assembles ROOT:
the app's page and bundle, the recording and the layout. This module serves ROOT on 127.0.0.1
(with HTTP range requests, which the app's remote MCAP reader needs), opens the app in Debian's
chromium through Playwright with the recording as its data source
(``?ds=remote-file&ds.url=...``), imports the layout through the app's own "Import layout"
button (the OS file dialog answered by a stand-in for ``window.showOpenFilePicker`` that hands
over the layout file), waits for the plots, seeks to the end and saves the screenshot::

    python -m tools.foxglove_shot ROOT RECORDING.mcap LAYOUT.json SHOT.png [--wait-s 25]
    python -m tools.foxglove_shot ROOT ws://127.0.0.1:8765 LAYOUT.json SHOT.png   # live

It fails (exit 1) when the app reports a problem with its data source (a topic it cannot read,
a connection that failed).

Live (a ``ws://`` source: ``pacc ecu|sim|drive --foxglove``) needs two changes that are not the
app's: Studio 1.48's WebSocket client (in a worker) offers only the subprotocol
``foxglove.websocket.v1``, which foxglove-sdk 0.30 refuses (HTTP 400) for the same protocol's
new name ``foxglove.sdk.v1``, so the worker's script is served with a ``WebSocket`` that offers
the new name too and reports the old one back (:data:`RENAME_JS`); and chromium 156's Local
Network Access checks, which block a worker's connection to 127.0.0.1, are turned off.
"""

from __future__ import annotations

import argparse
import functools
import re
import sys
import threading
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import IO, Any

#: stands in for the OS file dialog: the app's importer gets the file at window.__pickFile
PICKER_JS = """
window.showOpenFilePicker = async () => {
  const url = window.__pickFile;
  const blob = await (await fetch(url)).blob();
  const name = url.split('/').pop();
  const file = new File([blob], name, {type: 'application/json'});
  return [{kind: 'file', name, getFile: async () => file}];
};
"""
#: the worker of studio-base 1.48.0 that holds the app's WebSocket (``new WebSocket(data.wsUrl``)
WS_WORKER = "9450.a244f4d3213cfe49a389.js"
#: put before that worker's script: its sockets offer foxglove.sdk.v1 too, and say they speak v1
RENAME_JS = """
(() => {
  const Native = self.WebSocket;
  self.WebSocket = class extends Native {
    constructor(url, protocols) {
      const offered = [].concat(protocols ?? []);
      const old = offered.includes("foxglove.websocket.v1");
      super(url, old ? ["foxglove.sdk.v1", ...offered] : protocols);
    }
    get protocol() {
      const p = super.protocol;
      return p === "foxglove.sdk.v1" ? "foxglove.websocket.v1" : p;
    }
  };
})();
"""
_RANGE = re.compile(r"bytes=(\d+)-(\d*)")


class RangeHandler(SimpleHTTPRequestHandler):
    """Static files, with single byte ranges (``Range: bytes=a-b``) answered 206."""

    _left: int | None = None

    def end_headers(self) -> None:
        """Every answer says that ranges are served."""
        self.send_header("Accept-Ranges", "bytes")
        super().end_headers()

    def send_head(self) -> Any:
        """The file object to send, after the headers; a range's headers where one is asked."""
        m = _RANGE.fullmatch(self.headers.get("Range", ""))
        path = Path(self.translate_path(self.path))
        if not m or not path.is_file():
            return super().send_head()
        size = path.stat().st_size
        start, end = int(m[1]), min(int(m[2]) if m[2] else size - 1, size - 1)
        if start > end:  # past the end, reversed, or an empty file: not satisfiable
            self.send_response(416)
            self.send_header("Content-Range", f"bytes */{size}")
            self.send_header("Content-Length", "0")
            self.end_headers()
            return None
        f = path.open("rb")  # noqa: SIM115 - closed by the base class after copyfile
        f.seek(start)
        self.send_response(206)
        self.send_header("Content-Type", self.guess_type(path))
        self.send_header("Content-Range", f"bytes {start}-{end}/{size}")
        self.send_header("Content-Length", str(end - start + 1))
        self.end_headers()
        self._left = end - start + 1
        return f

    def copyfile(self, source: IO[bytes], outputfile: IO[bytes]) -> None:  # type: ignore[override]
        """The whole file, or the range's bytes only."""
        if self._left is None:
            super().copyfile(source, outputfile)
            return
        while self._left > 0 and (buf := source.read(min(self._left, 1 << 16))):
            outputfile.write(buf)
            self._left -= len(buf)

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base's name
        """Quiet."""


def serve(root: Path) -> tuple[ThreadingHTTPServer, str]:
    """A server of ``root`` on a free loopback port, running in a thread, and its base URL."""
    handler = functools.partial(RangeHandler, directory=str(root))
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}"


def shoot(base: str, source: str, layout: str, shot: Path, wait_s: float) -> list[str]:
    """Open the app on ``source`` (a recording under ``base``, or a ``ws://`` URL), import
    ``layout`` (under ``base``), save ``shot``; the problems the app logged."""
    from playwright.sync_api import Route, sync_playwright  # noqa: PLC0415

    live = source.startswith("ws://")
    problems: list[str] = []

    def renamed(route: Route) -> None:
        answer = route.fetch()
        route.fulfill(response=answer, body=RENAME_JS + answer.text())

    with sync_playwright() as p:
        args = ["--disable-features=LocalNetworkAccessChecks"] if live else []
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", headless=True, args=args)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.on(
            "console",
            lambda m: problems.append(m.text) if "Player problem" in m.text else None,
        )
        page.add_init_script(PICKER_JS)
        if live:
            page.route(f"**/assets/{WS_WORKER}", renamed)
            page.goto(f"{base}/index.html?ds=foxglove-websocket&ds.url={source}")
        else:
            page.goto(f"{base}/index.html?ds=remote-file&ds.url={base}/{source}")
        page.wait_for_function("document.body.innerText.includes('/ecu/inputs')", timeout=120_000)
        page.evaluate(f"window.__pickFile = '{base}/{layout}'")
        page.get_by_title("Layouts").first.click()
        page.get_by_title("Import layout").click()
        page.wait_for_timeout(wait_s * 1000)
        if not live:
            # the end of the recording on the playback bar (its scrubber spans the window's
            # width, 57 px above the bottom): the cursors and the log panel at the end
            page.mouse.click(1400 - 10, 900 - 57)
            page.mouse.move(700, 890)  # off the bar: no hover tip
            page.wait_for_timeout(3000)
        page.screenshot(path=str(shot))
        browser.close()
    return problems


def main(argv: list[str] | None = None) -> int:
    """Serve ROOT, take the screenshot; 1 when the app reported a problem."""
    ap = argparse.ArgumentParser(prog="python -m tools.foxglove_shot", description=__doc__)
    ap.add_argument("root", type=Path, help="the app's page and bundle, recording and layout")
    ap.add_argument("source", help="the recording, relative to ROOT, or a ws:// URL (live)")
    ap.add_argument("layout", help="the layout, relative to ROOT")
    ap.add_argument("shot", type=Path, help="the PNG to write")
    ap.add_argument("--wait-s", type=float, default=25.0, help="time for the plots to load")
    args = ap.parse_args(argv)
    server, base = serve(args.root)
    try:
        problems = shoot(base, args.source, args.layout, args.shot, args.wait_s)
    finally:
        server.shutdown()
    for problem in problems:
        print(f"foxglove: {problem}", file=sys.stderr)
    print(f"screenshot: {args.shot}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
