"""Opening a bus recording for a node: what it attaches and what a replay needs back.

A recording (:mod:`ecu.buslog.writer`) carries, as MCAP attachments, everything needed to run the
same ECU again over its frames (``pacc replay --ecu``): the DBC and the binding the node
used, the node's :class:`~ecu.config.EcuConfig` as JSON (:func:`config_to_json`, read back
by :func:`config_from_json`) and the table it started with (the DGPT JSON format).
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dbc import BINDING_PATH, DBC_PATH
from dbc.codec import Codec
from dbc.vocab.dgpt import Dgpt, SafetyBounds
from ecu.adaptation import AdaptationParams
from ecu.buslog.format import FLUSH_S, ROWS_S, CanLogError, TimeBase
from ecu.buslog.live import LIVE_FLUSH_S
from ecu.buslog.sinks import Sink
from ecu.buslog.writer import CanLogWriter
from ecu.config import ConfigError, EcuConfig
from ecu.controller import ControllerParams, RoadParams

DBC_ATTACHMENT = "network.dbc"
BINDING_ATTACHMENT = "binding.toml"
CONFIG_ATTACHMENT = "ecu_config.json"
TABLE_ATTACHMENT = "dgpt_start.json"


def config_to_json(config: EcuConfig) -> str:
    """``config`` as a JSON document (floats exactly, by repr)."""
    return json.dumps(dataclasses.asdict(config), sort_keys=True, allow_nan=False)


def _table(x: Any) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in x)


def config_from_json(text: str | bytes) -> EcuConfig:
    """The :class:`EcuConfig` of :func:`config_to_json`; ConfigError if it is not one."""
    try:
        d = json.loads(text)
        ctl = dict(d.pop("controller"))
        for k in ("kp", "ki", "kd"):
            ctl[k] = _table(ctl[k])
        ctl["road"] = RoadParams(**ctl["road"])
        return EcuConfig(
            **{k: v for k, v in d.items() if k not in ("adaptation_params", "bounds")},
            adaptation_params=AdaptationParams(**d["adaptation_params"]),
            controller=ControllerParams(**ctl),
            bounds=SafetyBounds(**d["bounds"]),
        )
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        raise ConfigError(f"not an ECU configuration: {exc}") from None


def _read(path: Path, what: str) -> bytes:
    try:
        return path.read_bytes()
    except OSError as exc:
        raise CanLogError(f"cannot attach the {what} {path}: {exc.strerror}") from None


def open_recording(
    path: str | os.PathLike[str] | None,
    codec: Codec,
    time_base: TimeBase,
    *,
    node: str,
    config: EcuConfig | None = None,
    table: Dgpt | None = None,
    dbc_path: str | os.PathLike[str] | None = None,
    binding_path: str | os.PathLike[str] | None = None,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
    sinks: Sequence[Sink] = (),
) -> CanLogWriter:
    """A :class:`CanLogWriter` for a node on ``codec``'s network with the DBC and binding (default:
    ``codec``'s files), the ECU's ``config`` and starting ``table`` attached; ``sinks`` get the same
    channels (every :data:`~ecu.buslog.live.LIVE_FLUSH_S`). CanLogError: a file not writable."""
    dbc_file = Path(dbc_path) if dbc_path else (codec.dbc_path or DBC_PATH)
    binding_file = Path(binding_path) if binding_path else (codec.binding.path or BINDING_PATH)
    attachments = {
        DBC_ATTACHMENT: _read(dbc_file, "DBC"),
        BINDING_ATTACHMENT: _read(binding_file, "binding"),
    }
    if config is not None:
        attachments[CONFIG_ATTACHMENT] = config_to_json(config).encode()
    if table is not None:
        attachments[TABLE_ATTACHMENT] = json.dumps(table.to_json_dict()).encode()
    return CanLogWriter(
        path,
        codec.db,
        time_base,
        node=node,
        attachments=attachments,
        metadata=metadata,
        sinks=sinks,
        flush_s=LIVE_FLUSH_S if sinks else FLUSH_S,
        rows_s=LIVE_FLUSH_S if sinks else ROWS_S,
    )
