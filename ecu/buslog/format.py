"""The layout of a bus recording (:mod:`ecu.buslog.writer`): topics, frame flags, block columns, the
time base that maps a node's clock onto UTC.

``/can/raw`` rows: ``t_s`` (the node's clock, s: simulated time in lockstep, the monotonic
clock in real time), ``id``, ``flags`` (bit 0 extended id, 1 received, 2 CAN FD, 3 error
frame, 4 remote frame, 5 bit-rate switch, 6 error state indicator), ``dlc``, ``len`` and the
payloads joined in ``data``. Sampled channels (``/ecu/inputs``, ``/ecu/outputs``,
``/sim/world``): ``t_s`` plus float64 columns (booleans 0/1, NaN kept). ``/ecu/events``: one
JSON object ``{"t_s", "text"}`` per event.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, fields
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from ecu import EcuError
from ecu.buslog.blocks import block_schema
from ecu.signals import NodeInputs, NodeOutputs

if TYPE_CHECKING:  # python-can costs start-up time `pacc ecu --help` does without
    import can

__all__ = [
    "BLOCK_S",
    "EVENTS_TOPIC",
    "FLAG_BRS",
    "FLAG_ERROR",
    "FLAG_ESI",
    "FLAG_EXTENDED",
    "FLAG_FD",
    "FLAG_REMOTE",
    "FLAG_RX",
    "FORMAT",
    "INPUTS_TOPIC",
    "INPUT_FIELDS",
    "META_RECORD",
    "OUTPUTS_TOPIC",
    "OUTPUT_FIELDS",
    "RAW_TOPIC",
    "WORLD_TOPIC",
    "CanLogError",
    "TimeBase",
    "frame_flags",
    "series_columns",
]

FORMAT = "pacc.canlog/1"
RAW_TOPIC = "/can/raw"
RAW_SCHEMA_NAME = "pacc.CanFrames"
EVENTS_TOPIC = "/ecu/events"
INPUTS_TOPIC = "/ecu/inputs"
OUTPUTS_TOPIC = "/ecu/outputs"
WORLD_TOPIC = "/sim/world"
#: default block length, s of the node's clock (longer blocks spread the per-block costs)
BLOCK_S = 10.0
#: metadata record of every recording: format, node, time base, start time
META_RECORD = "pacc"

FLAG_EXTENDED = 1
FLAG_RX = 2
FLAG_FD = 4
FLAG_ERROR = 8
FLAG_REMOTE = 16
FLAG_BRS = 32
FLAG_ESI = 64

INPUT_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(NodeInputs))
OUTPUT_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(NodeOutputs) if f.name != "events")


class CanLogError(EcuError):
    """A bus recording cannot be written or read (path, format, contents)."""


#: /can/raw columns: name -> (dtype, description); ``data`` is every payload joined
RAW_COLUMNS: dict[str, tuple[str, str]] = {
    "t_s": ("<f8", "time on the recording node's clock, s"),
    "id": ("<u4", "arbitration id"),
    "flags": (
        "|u1",
        "bit 0 extended id, 1 received (else sent), 2 CAN FD, 3 error frame, 4 remote frame, "
        "5 bit-rate switch, 6 error state indicator",
    ),
    "dlc": ("|u1", "data length code"),
    "len": ("|u1", "payload length, bytes"),
    "data": ("|u1", "the payloads, one after the other (len bytes each; not n values)"),
}
RAW_SCHEMA = block_schema(
    RAW_SCHEMA_NAME, "A block of CAN frames, one row per frame, in bus order", RAW_COLUMNS
)


def series_columns(columns: Sequence[str]) -> dict[str, tuple[str, str]]:
    """Block columns of a sampled channel: ``t_s`` plus float64 columns (booleans 0/1)."""
    out = {"t_s": ("<f8", "sample time on the node's clock, s")}
    out.update({name: ("<f8", name) for name in columns})
    return out


EVENT_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "pacc.EcuEvent",
    "description": "One event of the ECU node: state change, fault, adaptation decision",
    "type": "object",
    "properties": {"t_s": {"type": "number"}, "text": {"type": "string"}},
    "required": ["t_s", "text"],
}


@dataclass(frozen=True)
class TimeBase:
    """Maps a node's clock (s) onto UTC: ``utc_ns = utc_origin_ns + (t - clock_origin_s)``.

    Lockstep drives: the clock is simulated time from 0 and the origin the drive's start on
    the wall clock. Real time: the monotonic clock and the wall clock read together.
    """

    utc_origin_ns: int
    clock_origin_s: float

    @classmethod
    def now(cls, clock_s: float) -> TimeBase:
        """The node's clock reads ``clock_s`` now."""
        return cls(time.time_ns(), clock_s)

    def utc_ns(self, t_s: float) -> int:
        """UTC of node time ``t_s``, ns since the epoch (clamped at 0)."""
        if not math.isfinite(t_s):
            return self.utc_origin_ns
        return max(0, self.utc_origin_ns + int(round((t_s - self.clock_origin_s) * 1e9)))

    def iso(self, t_s: float) -> str:
        """UTC of node time ``t_s`` as ISO 8601 with microseconds."""
        ns = self.utc_ns(t_s)
        dt = datetime.fromtimestamp(ns // 1000 / 1e6, tz=UTC)
        return dt.strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def frame_flags(msg: can.Message, rx: bool) -> int:
    """The ``flags`` bit field of ``msg`` (see the module docstring)."""
    return (
        (FLAG_EXTENDED if msg.is_extended_id else 0)
        | (FLAG_RX if rx else 0)
        | (FLAG_FD if msg.is_fd else 0)
        | (FLAG_ERROR if msg.is_error_frame else 0)
        | (FLAG_REMOTE if msg.is_remote_frame else 0)
        | (FLAG_BRS if msg.bitrate_switch else 0)
        | (FLAG_ESI if msg.error_state_indicator else 0)
    )
