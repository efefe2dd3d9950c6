"""The manifest of a run (``OUT/manifest.json``): what ran, with which code, so that it can run
again: pacc's version and git commit, the resolved ``config``, the seeds, the platform, the
command, and each plug-in's distribution and version (:func:`check_plugins` refuses a
rerun with another).
"""

from __future__ import annotations

import json
import platform
import subprocess
import sys
from collections.abc import Iterable, Mapping
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from cloud_sync.learners import BUILTIN_LEARNERS
from dbc.atomic import write_bytes_atomic
from dbc.vocab.dgpt import utc_now_iso
from dbc.vocab.plugins import PluginError, provenance
from ecu.methods import BUILTIN_ADAPTATIONS, BUILTIN_CONTROLLERS

MANIFEST = "manifest.json"


def git_commit(root: Path | None = None) -> dict[str, Any] | None:
    """``{"commit": sha, "dirty": bool}`` of the checkout at ``root`` (default: the folder
    above this package); None when it is no git checkout or git is missing."""
    where = root if root is not None else Path(__file__).resolve().parents[2]
    if not (where / ".git").exists():
        return None
    try:
        sha, status = (
            subprocess.run(
                ["git", "-C", str(where), *args],
                capture_output=True,
                text=True,
                check=True,
                timeout=10,
            ).stdout
            for args in (["rev-parse", "HEAD"], ["status", "--porcelain", "--untracked-files=no"])
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": sha.strip(), "dirty": bool(status.strip())}


#: method field -> (plug-in group, built-ins, the values that name no plug-in)
_FIELDS = {
    "table": ("pacc.learners", BUILTIN_LEARNERS, {"predefined"}),
    "adaptation": ("pacc.adaptations", BUILTIN_ADAPTATIONS, {"", "none"}),
    "controller": ("pacc.controllers", BUILTIN_CONTROLLERS, {"", "builtin"}),
}


def plugin_origins(methods: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, str | None]]:
    """``group:spec`` -> provenance of every plug-in the config's ``methods`` name."""
    out = {}
    for method in methods:
        for field, (group, builtins, none) in _FIELDS.items():
            spec = str(method.get(field) or "")
            if spec not in none:
                out[f"{group}:{spec}"] = provenance(group, spec, builtins)
    return out


def check_plugins(recorded: Mapping[str, Any]) -> None:
    """PluginError unless each plug-in a manifest recorded comes from the same distribution
    and version here (one recorded without a distribution is not checked)."""
    builtins = {group: table for group, table, _ in _FIELDS.values()}
    for key, want in recorded.items():
        group, _, spec = key.partition(":")
        if not (isinstance(want, Mapping) and want.get("distribution")) or group not in builtins:
            continue
        have = provenance(group, spec, builtins[group])
        if (have["distribution"], have["version"]) != (want["distribution"], want["version"]):
            found = f"{have['distribution']} {have['version']}" if have["distribution"] else "none"
            raise PluginError(
                f"the manifest's {spec!r} ran from {want['distribution']} {want['version']}, "
                f"installed here: {found} (pip install '{want['distribution']}=={want['version']}')"
            )


def write_manifest(
    out: Path,
    config: Mapping[str, Any],
    extra: Mapping[str, Any] | None = None,
) -> Path:
    """Write ``out/manifest.json`` for ``config`` (plus ``extra`` keys); its path."""
    try:
        pacc_version = version("pacc")
    except PackageNotFoundError:
        pacc_version = "unknown"
    seed = int(config["seed"])
    doc = {
        "pacc_version": pacc_version,
        "git": git_commit(),
        "created_utc": utc_now_iso(),
        "command": sys.argv,
        "platform": {
            "python": sys.version.split()[0],
            "system": f"{platform.system()} {platform.release()}",
            "machine": platform.machine(),
            "numpy": np.__version__,
        },
        "seeds": {
            "study": seed,
            "trials": [seed + k for k in range(int(config["trials"]))],
            "populations": [p["seed"] for p in config["drivers"]["population"]],
        },
        "config": dict(config),
        "plugins": plugin_origins(config.get("methods", [])),
        **(dict(extra) if extra else {}),
    }
    out.mkdir(parents=True, exist_ok=True)
    path = out / MANIFEST
    write_bytes_atomic(
        path, json.dumps(doc, indent=2, sort_keys=True, default=str).encode() + b"\n"
    )
    return path
