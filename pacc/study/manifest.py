"""The manifest of a run: what ran, with which code, on what, so that it can run again.

``OUT/manifest.json`` holds ``pacc_version``, ``git_commit`` (of the source tree pacc was
imported from, when it is a git checkout; ``dirty`` when it has uncommitted changes), the
full resolved ``config`` (:mod:`pacc.study.spec`), the ``seeds`` (the study's, each
trial's, each drawn population's), the ``platform`` (Python, OS, machine, numpy) and the
command. ``pacc study --config OUT/manifest.json`` reads its ``config`` and runs it again.
"""

from __future__ import annotations

import json
import platform
import subprocess
import sys
from collections.abc import Mapping
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from dbc.vocab.dgpt import utc_now_iso

MANIFEST = "manifest.json"


def git_commit(root: Path | None = None) -> dict[str, Any] | None:
    """``{"commit": sha, "dirty": bool}`` of the checkout at ``root`` (default: the folder
    above this package); None when it is no git checkout or git is missing."""
    where = root if root is not None else Path(__file__).resolve().parents[2]
    if not (where / ".git").exists():
        return None
    try:
        sha = subprocess.run(
            ["git", "-C", str(where), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
        status = subprocess.run(
            ["git", "-C", str(where), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": sha, "dirty": bool(status.strip())}


def pacc_version() -> str:
    """The installed pacc's version ("unknown" when not installed)."""
    try:
        return version("pacc")
    except PackageNotFoundError:
        return "unknown"


def platform_info() -> dict[str, str]:
    """Python, OS, machine and numpy of this run."""
    return {
        "python": sys.version.split()[0],
        "system": f"{platform.system()} {platform.release()}",
        "machine": platform.machine(),
        "numpy": np.__version__,
    }


def seeds_of(config: Mapping[str, Any]) -> dict[str, Any]:
    """Every seed a resolved config uses."""
    seed, trials = int(config["seed"]), int(config["trials"])
    return {
        "study": seed,
        "trials": [seed + k for k in range(trials)],
        "populations": [p["seed"] for p in config["drivers"]["population"]],
    }


def write_manifest(
    out: Path,
    config: Mapping[str, Any],
    extra: Mapping[str, Any] | None = None,
) -> Path:
    """Write ``out/manifest.json`` for ``config`` (plus ``extra`` keys); its path."""
    doc = {
        "pacc_version": pacc_version(),
        "git": git_commit(),
        "created_utc": utc_now_iso(),
        "command": sys.argv,
        "platform": platform_info(),
        "seeds": seeds_of(config),
        "config": dict(config),
        **(dict(extra) if extra else {}),
    }
    out.mkdir(parents=True, exist_ok=True)
    path = out / MANIFEST
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(doc, indent=2, sort_keys=True, default=str) + "\n", encoding="utf-8")
    tmp.replace(path)
    return path


__all__ = ["MANIFEST", "git_commit", "pacc_version", "platform_info", "seeds_of", "write_manifest"]
