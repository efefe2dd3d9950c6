"""Setting a file aside: a batch or report the cloud refused moves to ``rejected/`` with its
reason, and the folder is fsynced (atomic writes themselves: :mod:`dbc.atomic`).
"""

from __future__ import annotations

from pathlib import Path

from dbc.atomic import fsync_dir


def set_aside(path: Path, reason: str) -> Path:
    """Move ``path`` into ``rejected/`` beside it with a ``.reason`` file; the new path."""
    target = path.parent / "rejected"
    target.mkdir(exist_ok=True)
    (target / f"{path.name}.reason").write_text(reason + "\n", encoding="utf-8")
    path.replace(target / path.name)
    fsync_dir(path.parent)
    return target / path.name
