"""The ECU's bus I/O: frames -> :class:`NodeInputs`, :class:`NodeOutputs` -> frames.

The only ECU module that knows roles and logical fields of the network (the codec below it
knows signal names and CAN ids; the node above it knows neither). Received frames go through
an :class:`dbc.endpoint.Inbox` (decode, E2E check, freshness); outputs leave through an
:class:`dbc.endpoint.Outbox` (alive counter and CRC). Pedal fractions are scaled by the DBC's
full scale (:class:`dbc.vocab.pedals.PedalScale`). A codec that cannot carry every output of the
node is refused when the port is built (:func:`check_outputs_fit`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import can

from dbc.codec import Codec, RoleCodec
from dbc.endpoint import Inbox, Outbox
from dbc.errors import EncodeError
from dbc.frame import Raw, port_of, raw_key
from dbc.message import MessageCodec
from dbc.vocab.acc_state import AccState, FaultCode
from dbc.vocab.pedals import PedalScale
from ecu import EcuError
from ecu.config import EcuConfig
from ecu.safety import CommandSafety
from ecu.signals import NodeInputs, NodeOutputs

log = logging.getLogger(__name__)

#: The roles the ECU receives.
INPUT_ROLES = ("ego", "pedals", "radar", "hmi")


class RuntimeCodecError(EcuError):
    """The codec (DBC) cannot carry every output of the node."""


def check_outputs_fit(codec: Codec, config: EcuConfig) -> None:
    """RuntimeCodecError unless ``codec`` carries every output of a node of ``config``: AccState
    FAULT, every FaultCode, the acceleration envelope and the highest set speed."""
    ctl = config.controller
    command, status = codec.roles["command"], codec.roles.get("status")
    needs: list[tuple[RoleCodec | None, str, float, float]] = [
        (command, "accel_request_mps2", ctl.accel_min_mps2, ctl.accel_max_mps2),
        (command, "acc_state", 0, max(AccState)),
        (command, "request_active", 0, 1),
        (command, "takeover_request", 0, 1),
        (status, "fault_code", 0, max(FaultCode)),
        (status, "set_speed_mps", 0.0, config.max_set_speed_mps),
    ]
    for rc, key, lo, hi in needs:
        mc = None if rc is None else rc.part_of(key)
        if mc is None:  # the network does not carry this output (docs/vehicles.md)
            continue
        have_lo, have_hi = mc.bounds(key)
        if have_lo > lo + 1e-9 or have_hi < hi - 1e-9:
            raise RuntimeCodecError(
                f"{mc.name}: {key} range [{have_lo:g}, {have_hi:g}] cannot carry "
                f"[{lo:g}, {hi:g}] (AccState FAULT = {int(AccState.FAULT)}, FaultCode up "
                f"to {int(max(FaultCode))}, the acceleration envelope, max_set_speed_mps "
                f"{config.max_set_speed_mps:g})"
            )


def inputs_from(inbox: Inbox, now_s: float, pedals: PedalScale) -> NodeInputs:
    """The node's inputs from ``inbox`` at ``now_s``: latest values plus freshness."""
    latest, fresh = inbox.latest, inbox.fresh
    # each role's values, or NodeInputs' defaults and not ok when it never delivered one
    ego = latest("ego")
    if ego is not None:
        v, a = float(ego["speed_mps"]), float(ego["accel_mps2"])
        speed_ok = bool(ego["speed_valid"]) and fresh("ego", now_s)
    else:
        v, a, speed_ok = 0.0, 0.0, False
    ped = latest("pedals")
    if ped is not None:
        accel = pedals.accel(float(ped["accel_pedal_pct"]))
        brake = pedals.brake(float(ped["brake_pressure_bar"]))
        accel_pressed, brake_pressed = bool(ped["accel_pressed"]), bool(ped["brake_pressed"])
        pedals_ok = fresh("pedals", now_s)
    else:
        accel, brake, accel_pressed, brake_pressed, pedals_ok = 0.0, 0.0, False, False, False
    radar = latest("radar")
    if radar is not None:
        lead_valid = bool(radar["lead_valid"])
        gap, rel = float(radar["gap_m"]), float(radar["rel_speed_mps"])
        lead_accel = float(radar["lead_accel_mps2"])
        lead_accel_valid = bool(radar["lead_accel_valid"])
        radar_ok = fresh("radar", now_s)
    else:
        lead_valid, gap, rel, lead_accel, lead_accel_valid, radar_ok = (
            False, 0.0, 0.0, 0.0, False, False
        )  # fmt: skip
    hmi = latest("hmi")
    if hmi is not None:
        main, set_b = bool(hmi["main_switch"]), bool(hmi["set"])
        resume_b, cancel_b = bool(hmi["resume"]), bool(hmi["cancel"])
        hmi_ok = fresh("hmi", now_s)
    else:
        main, set_b, resume_b, cancel_b, hmi_ok = False, False, False, False, False
    # positional fields in declaration order (a class call with keywords builds a dict)
    return NodeInputs(
        v, a, speed_ok, accel, brake, accel_pressed, brake_pressed, pedals_ok,
        lead_valid, gap, rel, lead_accel, lead_accel_valid, radar_ok,
        main, set_b, resume_b, cancel_b, hmi_ok,
    )  # fmt: skip


def _clamp(x: float, lo: float, hi: float) -> float:
    """``x`` clipped to [lo, hi]; NaN gives ``lo`` (for a gap or a speed: 0)."""
    return lo if not x >= lo else (hi if x > hi else x)


def _accel_on_bus(x: float, lo: float, hi: float) -> float:
    """The acceleration request ``x`` (m/s^2) clipped to the frame's [lo, hi]; a non-finite
    request goes out as 0 (clipped), as the controller treats it, never as the floor: the
    last line before the bus must not turn garbage into the harshest braking."""
    return _clamp(x if math.isfinite(x) else 0.0, lo, hi)


@dataclass(frozen=True, slots=True)
class OutputLimits:
    """The ranges the output frames can carry (from the codec), physical units."""

    accel_lo_mps2: float
    accel_hi_mps2: float
    gap_hi_m: float
    set_speed_hi_mps: float

    @classmethod
    def from_codec(cls, codec: Codec) -> OutputLimits:
        lo, hi = codec.roles["command"].bounds("accel_request_mps2")
        status = codec.roles.get("status")

        def top(key: str) -> float:
            mc = None if status is None else status.part_of(key)
            return math.inf if mc is None else mc.bounds(key)[1]

        return cls(
            accel_lo_mps2=lo,
            accel_hi_mps2=hi,
            gap_hi_m=top("desired_gap_m"),
            set_speed_hi_mps=top("set_speed_mps"),
        )


def command_values(out: NodeOutputs, limits: OutputLimits) -> dict[str, Any]:
    """The ``command`` role's fields of ``out`` (ACC_Command, every cycle)."""
    return {
        "accel_request_mps2": _accel_on_bus(
            out.accel_request_mps2, limits.accel_lo_mps2, limits.accel_hi_mps2
        ),
        "request_active": int(out.request_active),
        "acc_state": int(out.acc_state),
        "takeover_request": int(out.takeover_request),
    }


def status_values(out: NodeOutputs, limits: OutputLimits) -> dict[str, Any]:
    """The ``status`` role's fields of ``out`` (ACC_Status; counters wrap or saturate)."""
    return {
        "desired_gap_m": _clamp(out.desired_gap_m, 0.0, limits.gap_hi_m),
        "dgpt_version": out.dgpt_version & 0xFFFF,
        "adaptation_count": min(out.adaptation_count, 255),
        "fault_code": int(out.fault_code),
        "set_speed_mps": _clamp(out.set_speed_mps, 0.0, limits.set_speed_hi_mps),
    }


def _keyed(parts: Sequence[MessageCodec]) -> tuple[tuple[MessageCodec, int], ...]:
    return tuple((mc, raw_key(mc.frame_id, mc.is_extended)) for mc in parts)


class BusIO:
    """The ECU's port on ``bus`` (owned by the caller): an Inbox for the input roles (timing out
    after ``timeout_multiple`` DBC periods), an Outbox (:func:`check_outputs_fit`)."""

    def __init__(
        self, bus: can.BusABC, codec: Codec, config: EcuConfig, timeout_multiple: float = 10.0
    ) -> None:
        check_outputs_fit(codec, config)
        self.bus = bus
        self.port = port_of(bus)
        self.codec = codec
        self.inbox = Inbox(codec, roles=INPUT_ROLES, timeout_multiple=timeout_multiple)
        self.outbox = Outbox(codec)
        self.pedals = PedalScale.from_codec(codec)
        self.limits = OutputLimits.from_codec(codec)
        self.send_errors = 0
        #: the independent check of every command frame (:mod:`ecu.safety`)
        self.safety = CommandSafety()
        status = codec.roles.get("status")
        #: each output message with its frame key (:func:`dbc.frame.raw_key`)
        self._command = _keyed(codec.roles["command"].parts)
        self._status = _keyed(status.parts if status is not None else ())
        #: called with (time, key, payload, received) for every frame in and out (a bus
        #: recorder's :meth:`~ecu.buslog.writer.CanLogWriter.frame_raw`; :mod:`dbc.frame`)
        self.tap: Callable[[float, int, Any, bool], None] | None = None

    def drain(self, now_s: float) -> None:
        """Feed every frame waiting on the bus to the Inbox, stamped ``now_s``."""
        self._feed(self.port.take(), now_s)

    def receive(self, timeout_s: float, clock: Callable[[], float]) -> float:
        """Wait up to ``timeout_s`` for a frame and accept what came, stamped with its arrival
        time (``clock()``); return ``clock()`` after the wait."""
        frames = self.port.take(timeout_s)
        now = clock()
        self._feed(frames, now)
        return now

    def _feed(self, frames: Sequence[Raw], now_s: float) -> None:
        accept = self.inbox.accept
        tap = self.tap
        for _, key, data in frames:
            accept(key, data, now_s)
            if tap is not None:
                tap(now_s, key, data, True)

    def read_inputs(self, now_s: float) -> NodeInputs:
        """The node's inputs at ``now_s`` (:func:`inputs_from`)."""
        return inputs_from(self.inbox, now_s, self.pedals)

    def send(self, t_s: float, out: NodeOutputs, *, status: bool) -> NodeOutputs:
        """Send ACC_Command (and ACC_Status if ``status``) stamped ``t_s``; the outputs as
        sent (after the safety check: ``out`` itself when it passed). Never raises: an
        encode or bus failure is logged and counted in :attr:`send_errors`."""
        out = self.safety.check(out, t_s)  # the independent check (ecu.safety), last word
        encode, put, tap = self.outbox.encode_part, self.port.put, self.tap
        try:
            batches = [(self._command, command_values(out, self.limits))]
            if status and self._status:
                batches.append((self._status, status_values(out, self.limits)))
            for parts, values in batches:
                for mc, key in parts:
                    data = encode(mc, values)
                    put(t_s, key, data)
                    if tap is not None:
                        tap(t_s, key, data, False)
        except (EncodeError, can.CanError) as exc:
            self.send_errors += 1
            log.error("t=%.2f send failed: %s", t_s, exc)
        return out
