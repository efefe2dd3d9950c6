"""tools/foxglove_shot.py's file server: byte ranges as the Foxglove app's MCAP reader asks for
them, a 416 where a range cannot be satisfied, nothing outside its folder."""

from __future__ import annotations

import urllib.error
import urllib.request
from collections.abc import Iterator

import pytest

from tools.foxglove_shot import serve

DATA = bytes(range(10))


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """One server for the module's tests (they only read): its shutdown waits half a second."""
    tmp_path = tmp_path_factory.mktemp("shot")
    (tmp_path / "root").mkdir()
    (tmp_path / "root" / "rec.mcap").write_bytes(DATA)
    (tmp_path / "root" / "empty.mcap").write_bytes(b"")
    (tmp_path / "secret.txt").write_text("not served\n")
    server, url = serve(tmp_path / "root")
    try:
        yield url
    finally:
        server.shutdown()
        server.server_close()


def _get(url: str, byte_range: str | None = None) -> tuple[int, dict[str, str], bytes]:
    req = urllib.request.Request(url)
    if byte_range is not None:
        req.add_header("Range", f"bytes={byte_range}")
    try:
        with urllib.request.urlopen(req, timeout=10) as resp:  # noqa: S310 - 127.0.0.1 only
            return resp.status, dict(resp.headers), resp.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def test_ranges_and_the_whole_file(base: str) -> None:
    assert _get(f"{base}/rec.mcap")[::2] == (200, DATA)
    status, headers, body = _get(f"{base}/rec.mcap", "2-4")
    assert (status, body, headers["Content-Range"]) == (206, DATA[2:5], "bytes 2-4/10")
    status, headers, body = _get(f"{base}/rec.mcap", "7-")
    assert (status, body, headers["Content-Length"]) == (206, DATA[7:], "3")
    assert _get(f"{base}/rec.mcap", "8-100")[::2] == (206, DATA[8:])  # clipped to the end


@pytest.mark.parametrize(("name", "byte_range"), [("rec", "20-"), ("rec", "5-3"), ("empty", "0-")])
def test_a_range_it_cannot_satisfy_is_416(base: str, name: str, byte_range: str) -> None:
    status, headers, body = _get(f"{base}/{name}.mcap", byte_range)
    assert (status, body) == (416, b"")
    assert headers["Content-Range"] == f"bytes */{len(DATA) if name == 'rec' else 0}"


@pytest.mark.parametrize("path", ["../secret.txt", "%2e%2e/secret.txt", "..%2fsecret.txt"])
def test_nothing_outside_its_folder(base: str, path: str) -> None:
    assert _get(f"{base}/{path}")[0] == 404
