"""The layout of a bus recording (:mod:`ecu.buslog.writer`): topics, frame flags, schemas, the
time base that maps a node's clock onto UTC.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, fields
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from ecu import EcuError
from ecu.buslog.blocks import block_schema
from ecu.signals import NodeInputs, NodeOutputs

if TYPE_CHECKING:  # python-can costs start-up time `pacc ecu --help` does without
    import can

FORMAT = "pacc.canlog/2"
RAW_TOPIC = "/can/raw"
RAW_SCHEMA_NAME = "pacc.CanFrames"
EVENTS_TOPIC = "/ecu/events"
INPUTS_TOPIC = "/ecu/inputs"
OUTPUTS_TOPIC = "/ecu/outputs"
WORLD_TOPIC = "/sim/world"
#: default flush interval, s of the node's clock: every channel's buffered rows are written and
#: the MCAP chunk ended, so a killed recording loses at most this much
FLUSH_S = 1.0
#: default interval of the decoded rows and the cycles, s of the node's clock (a batch of rows
#: has a fixed cost that a 1-s batch of a sparse bus does not amortize)
ROWS_S = 10.0
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
    RAW_SCHEMA_NAME,
    "A block of CAN frames, one row per frame, in bus order",
    RAW_COLUMNS,
    ragged=("data",),
)


#: Foxglove's ``foxglove.Log`` (JSON schema), plus the node's clock ``t_s``
LOG_SCHEMA: dict[str, Any] = {
    "title": "foxglove.Log",
    "description": "A log message",
    "type": "object",
    "properties": {
        "timestamp": {
            "type": "object",
            "title": "time",
            "properties": {
                "sec": {"type": "integer", "minimum": 0},
                "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999},
            },
        },
        "level": {
            "title": "foxglove.LogLevel",
            "oneOf": [
                {"title": t, "const": i}
                for i, t in enumerate(("UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL"))
            ],
        },
        "message": {"type": "string"},
        "name": {"type": "string"},
        "file": {"type": "string"},
        "line": {"type": "integer", "minimum": 0},
        "t_s": {"type": "number", "description": "the node's clock, s"},
    },
    "required": ["timestamp", "level", "message", "name", "file", "line"],
}


@dataclass(frozen=True)
class TimeBase:
    """Maps a node's clock (s) onto UTC: ``utc_ns = utc_origin_ns + (t - clock_origin_s)``."""

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


def utc_ns_array(base: TimeBase, t_s: Any) -> Any:
    """:meth:`TimeBase.utc_ns` over a numpy array of node times: int64 ns (clamped at 0)."""
    import numpy as np  # noqa: PLC0415 - numpy only where arrays are written

    ns = np.rint((t_s - base.clock_origin_s) * 1e9).astype(np.int64) + base.utc_origin_ns
    return np.maximum(ns, 0)


def meta_record(base: TimeBase, node: str) -> dict[str, str]:
    """The ``pacc`` metadata record: format, node, time base."""
    return {
        "format": FORMAT,
        "node": node,
        "utc_origin_ns": str(base.utc_origin_ns),
        "clock_origin_s": repr(base.clock_origin_s),
    }


def log_message(t_s: float, stamp_ns: int, text: str, name: str) -> bytes:
    """One event as a ``foxglove.Log`` JSON message (:data:`LOG_SCHEMA`): level WARNING for
    faults, takeovers and emergencies, INFO else; the node's clock in ``t_s``."""
    import json  # noqa: PLC0415

    warn = text.lower().startswith(("fault", "takeover", "emergency"))
    doc = {
        "timestamp": {"sec": stamp_ns // 10**9, "nsec": stamp_ns % 10**9},
        "level": 3 if warn else 2,
        "message": text,
        "name": name,
        "file": "",
        "line": 0,
        "t_s": t_s if math.isfinite(t_s) else None,
    }
    return json.dumps(doc).encode()


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
