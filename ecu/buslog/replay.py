"""Replaying a bus recording: through the ECU in lockstep, or onto a bus in real time."""

from __future__ import annotations

import itertools
import json
import tempfile
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import can

from dbc import BINDING_PATH, DBC_PATH
from dbc.codec import Codec, load_codec
from dbc.endpoint import Inbox
from dbc.frame import ID_MASK, Frame, raw_of
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import Dgpt, predefined
from dbc.vocab.dgpt_file import dgpt_from_json_dict
from ecu.buslog.format import (
    FLAG_ERROR,
    FLAG_EXTENDED,
    FLAG_REMOTE,
    FLAG_RX,
    META_RECORD,
    OUTPUTS_TOPIC,
    CanLogError,
)
from ecu.buslog.reader import CanLog, messages
from ecu.buslog.recording import (
    BINDING_ATTACHMENT,
    CONFIG_ATTACHMENT,
    DBC_ATTACHMENT,
    TABLE_ATTACHMENT,
    config_from_json,
)
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime, RuntimeSummary

#: creation time of the tables a replay adapts (the replay stays a pure function of the log)
REPLAY_UTC = "2000-01-01T00:00:00Z"
_channels = itertools.count()


@dataclass
class ReplayResult:
    """What the ECU did over a recording, and how it compares with what was recorded."""

    summary: RuntimeSummary
    #: (t_s, frame id, payload) of every frame the replayed ECU sent
    sent: list[tuple[float, int, bytes]]
    #: the same of the recording (the frames its node sent)
    recorded: list[tuple[float, int, bytes]]
    #: (t_s, state name) at every ACC state change of the replay
    states: list[tuple[float, str]]
    events: list[tuple[float, str]] = field(default_factory=list)
    #: frames the recorded node sent after its last recorded cycle (a killed recording), not
    #: in :attr:`recorded`
    unreplayed: int = 0

    @property
    def identical(self) -> bool:
        """The replayed ECU sent exactly the recorded frames (times, ids, payloads)."""
        return self.sent == self.recorded

    def first_difference(self) -> int | None:
        """Index of the first frame that differs (None: identical)."""
        pairs = enumerate(zip(self.sent, self.recorded, strict=False))
        first = next((i for i, (a, b) in pairs if a != b), None)
        n, m = len(self.sent), len(self.recorded)
        return first if first is not None or n == m else min(n, m)


def codec_of(log: CanLog) -> Codec:
    """The codec of the recording's attached DBC and binding (the packaged network when they
    are the packaged files or absent)."""
    dbc = log.attachments.get(DBC_ATTACHMENT)
    binding = log.attachments.get(BINDING_ATTACHMENT)
    if (dbc is None or dbc == DBC_PATH.read_bytes()) and (
        binding is None or binding == BINDING_PATH.read_bytes()
    ):
        return load_codec()
    with tempfile.TemporaryDirectory(prefix="pacc-replay-") as tmp:
        dbc_path, binding_path = Path(tmp) / "network.dbc", Path(tmp) / "binding.toml"
        dbc_path.write_bytes(dbc if dbc is not None else DBC_PATH.read_bytes())
        binding_path.write_bytes(binding if binding is not None else BINDING_PATH.read_bytes())
        return load_codec(dbc_path, binding_path)


def _ecu_of(log: CanLog) -> EcuNode:
    """The ECU the recording ran: its attached configuration and starting table."""
    if CONFIG_ATTACHMENT not in log.attachments:
        raise CanLogError(
            f"{log.path}: the recording has no ECU configuration ({CONFIG_ATTACHMENT}); "
            "it was not recorded by an ECU (pacc ecu or pacc drive)"
        )
    config = config_from_json(log.attachments[CONFIG_ATTACHMENT])
    raw = log.attachments.get(TABLE_ATTACHMENT)
    table: Dgpt = (
        dgpt_from_json_dict(json.loads(raw), config.bounds) if raw is not None else predefined(1.5)
    )
    return EcuNode(config, table, utc_now=lambda: REPLAY_UTC)


def _received(log: CanLog) -> list[tuple[float, can.Message]]:
    """(time, frame) of every frame the recorded node received, in bus order."""
    f = log.frames
    out: list[tuple[float, can.Message]] = []
    for t, fid, fl, data in zip(
        f.t_s.tolist(), f.id.tolist(), f.flags.tolist(), f.data, strict=True
    ):
        if fl & FLAG_RX:
            msg = Frame(
                arbitration_id=fid,
                is_extended_id=bool(fl & FLAG_EXTENDED),
                data=data,
                timestamp=t,
                is_remote_frame=bool(fl & FLAG_REMOTE),
                is_error_frame=bool(fl & FLAG_ERROR),
            )
            out.append((t, msg))
    return out


def _cycles(log: CanLog) -> list[tuple[float, int]]:
    """(time, index) of every recorded control cycle."""
    outputs = log.series.get(OUTPUTS_TOPIC)
    if outputs is None or "cycle" not in outputs:
        raise CanLogError(f"{log.path}: the recording holds no ECU cycles ({OUTPUTS_TOPIC})")
    return list(zip(outputs["t_s"].tolist(), outputs["cycle"].astype(int).tolist(), strict=True))


def replay_through_ecu(log: CanLog, node: EcuNode | None = None) -> ReplayResult:
    """Run the recording's received frames and cycles through the ECU (module docstring;
    CanLogError: the recording names no ECU: no attached configuration, no cycles)."""
    node = node if node is not None else _ecu_of(log)
    codec = codec_of(log)
    cycles = _cycles(log)
    channel = f"pacc-replay-{next(_channels)}"
    sent: list[tuple[float, int, bytes]] = []

    def tap(t: float, key: int, data: bytes, rx: bool) -> None:
        if not rx:
            sent.append((t, key & ID_MASK, data))

    feeder = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    ecu_bus = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    states: list[tuple[float, str]] = []
    events: list[tuple[float, str]] = []
    try:
        rt = EcuRuntime(ecu_bus, node, codec)
        rt.io.tap = tap
        received = _received(log)
        i, last = 0, None
        for t, k in cycles:
            while i < len(received) and received[i][0] <= t:  # a frame stamped t: before it
                feeder.send(received[i][1])
                rt.io.drain(received[i][0])
                i += 1
            rt.cycle_at(t, k)
            out = rt.last_outputs
            if out is not None:
                events.extend((t, text) for text in out.events)
                if out.acc_state != last:
                    last = out.acc_state
                    states.append((t, AccState(out.acc_state).name))
        node.finish()
        summary = rt.summary()
    finally:
        feeder.shutdown()
        ecu_bus.shutdown()
    f = log.frames
    recorded = [
        (t, fid, data)
        for t, fid, rx, data in zip(
            f.t_s.tolist(), f.id.tolist(), f.rx.tolist(), f.data, strict=True
        )
        if not rx
    ]
    unreplayed = 0
    if "start_utc" not in log.metadata.get(META_RECORD, {}) and cycles:  # killed: no closing
        end_s = cycles[-1][0]
        kept = [r for r in recorded if r[0] <= end_s]
        recorded, unreplayed = kept, len(recorded) - len(kept)
    return ReplayResult(summary, sent, recorded, states, events, unreplayed)


@dataclass
class PlayResult:
    """What a real-time play sent and which ACC commands came back."""

    frames_sent: int
    commands: int = 0
    states: Counter[str] = field(default_factory=Counter)
    send_errors: int = 0


def play(
    log: CanLog,
    bus: can.BusABC,
    *,
    which: str = "all",
    codec: Codec | None = None,
    stop: Callable[[], bool] | None = None,
    gap_s: float = 0.0001,
    skip_s: float = 60.0,
) -> PlayResult:
    """Send the recording's frames (``which``: ``all``, ``rx``, ``tx``) onto ``bus`` with their
    recorded spacing (pauses cut to ``skip_s``, s) and decode the ACC commands that come back;
    stops early when ``stop()`` returns True."""
    codec = codec if codec is not None else codec_of(log)
    inbox = Inbox(codec, ("command",))
    result = PlayResult(frames_sent=0)
    msgs: Iterable[can.Message] = messages(log)
    if which != "all":
        want_rx = which == "rx"
        msgs = (m for m in msgs if m.is_rx == want_rx)
    for msg in can.MessageSync(msgs, timestamps=True, gap=gap_s, skip=skip_s):
        if stop is not None and stop():
            break
        try:
            bus.send(msg)
            result.frames_sent += 1
        except can.CanError:
            result.send_errors += 1
        _answers(bus, inbox, result)
    _answers(bus, inbox, result)
    return result


def _answers(bus: can.BusABC, inbox: Inbox, result: PlayResult) -> None:
    """Decode every ACC command waiting on ``bus`` into ``result``."""
    while (msg := bus.recv(0)) is not None:
        t, key, data = raw_of(msg)
        d = inbox.accept(key, data, t)
        if d is not None and d.role == "command":
            result.commands += 1
            result.states[AccState(int(d.values["acc_state"])).name] += 1
