"""Where the vehicle's cloud is: :func:`connect` gives an
:class:`~cloud_sync.vehicle.client.HttpCloud` for an ``http(s)://`` target, else an embedded
:class:`~cloud_sync.service.local.LocalCloud` over the folder. Tokens live in files
(``--token-file``), never on the command line.
"""

from __future__ import annotations

import os
from pathlib import Path

from cloud_sync.api import CloudApi
from cloud_sync.errors import CloudSyncError
from dbc.atomic import atomic_writer


def is_url(target: str) -> bool:
    """True for an ``http://`` or ``https://`` target."""
    return target.startswith(("http://", "https://"))


def connect(target: str, token: str, *, timeout_s: float = 30.0) -> CloudApi:
    """The cloud at ``target`` (URL or folder) as seen by the vehicle holding ``token``;
    ``timeout_s`` bounds each HTTP call (connect and answer), s."""
    # each backend costs start-up the other does not need (httpx; numpy, scipy, the trainer)
    if is_url(target):
        from cloud_sync.vehicle.client import HttpCloud  # noqa: PLC0415

        return HttpCloud(target, token, timeout_s=timeout_s)
    from cloud_sync.service.local import LocalCloud  # noqa: PLC0415

    return LocalCloud.open(target, token)


def read_token(path: str | os.PathLike[str]) -> str:
    """The token in file ``path`` (surrounding whitespace stripped); CloudSyncError if unusable."""
    try:
        token = Path(path).read_text(encoding="utf-8").strip()
    except (OSError, UnicodeDecodeError) as exc:
        raise CloudSyncError(f"cannot read the token file {path}: {exc}") from exc
    if not token or any(c.isspace() for c in token):
        raise CloudSyncError(f"token file {path} holds no single token")
    return token


def write_token(path: str | os.PathLike[str], token: str, *, force: bool = False) -> None:
    """Write ``token`` to ``path``, readable by the owner only (mode 0600). An existing file
    (perhaps another vehicle's token) is replaced only with ``force``, atomically
    (:mod:`dbc.atomic`); otherwise CloudSyncError."""
    target = Path(path)
    if not force and target.exists():
        raise CloudSyncError(
            f"{target} exists (another vehicle's token?): name a new file, or --force to replace it"
        )
    with atomic_writer(target) as stream:  # not durable=True: it would make a missing folder
        os.fchmod(stream.fileno(), 0o600)  # before the token is in it
        stream.write(f"{token}\n".encode())
        stream.flush()
        os.fsync(stream.fileno())
