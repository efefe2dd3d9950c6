"""The ECU runtime: wires a python-can bus, the codec (Inbox/Outbox), a clock and the log.

Two clocks drive the same :class:`ecu.node.EcuNode`:

- **lockstep** — the simulator owns time. After it has put its frames on the shared bus it
  calls ``rt.advance_to(now_s)``: every pending frame is drained (``bus.recv(0)``) and fed to
  the Inbox stamped ``now_s``; then every 20 ms control cycle due up to ``now_s`` runs (step,
  ACC_Command every cycle, ACC_Status every 5th cycle = 100 ms). Deterministic, as fast as
  the CPU allows. The first call fixes the cycle grid: cycles at ``t0 + k * cycle_s``.
- **real time** — ``rt.run_realtime(duration_s)``: a 50 Hz cycle from ``time.monotonic``;
  between cycles the runtime blocks in ``bus.recv`` until the next deadline, stamping frames
  with their arrival time. ``rt.stop()`` (from another thread) or Ctrl-C ends it.

API::

    from ecu.node import EcuNode, EcuConfig
    from ecu.runtime import EcuRuntime
    rt = EcuRuntime(bus, EcuNode(EcuConfig(), table), codec=None)  # None: packaged DBC
    rt.advance_to(now_s)          # lockstep
    rt.run_realtime(60.0)         # or real time
    print(rt.summary())           # cycles, frames in/out, E2E errors by kind, ...

A frame that fails its E2E check is dropped and counted by the Inbox; a role is usable while
it is fresh (within 10 of its periods). The runtime never raises from a cycle: an encode
failure (which the clamping below should make impossible) is logged and counted.
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import can

from ecu import EcuError
from ecu.node import EcuNode, NodeInputs, NodeOutputs
from ecu.state import AccState, FaultCode

if TYPE_CHECKING:
    from dbc.codec import Codec

log = logging.getLogger(__name__)

INPUT_ROLES = ("ego", "pedals", "radar", "hmi")
#: Largest clock jump (s) that advance_to catches up cycle by cycle; beyond it, it skips.
MAX_CATCHUP_S = 10.0


class RuntimeClockError(EcuError):
    """The runtime was given a time it cannot run to (not finite)."""


class RuntimeCodecError(EcuError):
    """The codec (DBC) cannot carry every output of the node."""


@dataclass(frozen=True)
class RuntimeSummary:
    """Counters of a run. ``max_cycle_s`` is the longest compute time of one cycle, s."""

    cycles: int
    frames_in: int
    frames_out: int
    e2e_errors: dict[str, int]
    takeovers: int
    adaptations: int
    max_cycle_s: float
    state: str
    dgpt_version: int
    send_errors: int = 0
    skipped_cycles: int = 0
    adaptation_decisions: dict[str, int] = field(default_factory=dict)
    faults: dict[str, int] = field(default_factory=dict)

    def __str__(self) -> str:
        errors = ", ".join(f"{k} {v}" for k, v in sorted(self.e2e_errors.items())) or "none"
        decisions = (
            ", ".join(f"{k} {v}" for k, v in sorted(self.adaptation_decisions.items())) or "none"
        )
        faults = ", ".join(f"{k} {v}" for k, v in sorted(self.faults.items())) or "none"
        return "\n".join(
            [
                f"cycles:         {self.cycles}",
                f"frames in/out:  {self.frames_in} / {self.frames_out}",
                f"E2E errors:     {errors}",
                f"takeovers:      {self.takeovers}",
                f"adaptations:    {self.adaptations} (decisions: {decisions})",
                f"DGPT version:   {self.dgpt_version}",
                f"faults:         {faults}",
                f"final state:    {self.state}",
                f"max cycle time: {self.max_cycle_s * 1e3:.3f} ms",
                f"send errors:    {self.send_errors}, skipped cycles: {self.skipped_cycles}",
            ]
        )


def _clamp(x: float, lo: float, hi: float) -> float:
    return lo if not x >= lo else (hi if x > hi else x)


class EcuRuntime:
    """Bus-side driver of an :class:`EcuNode` (see the module docstring).

    Args:
        bus: an open python-can bus (the caller owns and closes it).
        node: the node to run.
        codec: the network codec; None loads the packaged pacc DBC.
        on_event: called with each node event text (state changes, faults, adaptations).
        timeout_multiple: an input role times out after this many of its DBC periods.
        profile_dir: driver profiles: when HMI ``DriverProfileId`` changes to ``n > 0`` the
            runtime loads ``profile_dir/profile_<n>.json``; an invalid file is refused (the
            node keeps its last good table and reports FaultCode Profile), a missing one
            keeps the table; ``n = 0`` (guest) returns to the table the node started with.

    Raises:
        RuntimeCodecError: the codec's ACC_Command / ACC_Status cannot carry every output
            (AccState FAULT, every FaultCode, the node's acceleration envelope).
    """

    def __init__(
        self,
        bus: can.BusABC,
        node: EcuNode,
        codec: Codec | None = None,
        *,
        on_event: Callable[[str], None] | None = None,
        timeout_multiple: float = 10.0,
        profile_dir: str | os.PathLike[str] | None = None,
    ) -> None:
        from dbc.codec import load_codec
        from dbc.endpoint import Inbox, Outbox

        self.bus = bus
        self.node = node
        self.codec = codec if codec is not None else load_codec()
        self.inbox = Inbox(self.codec, roles=INPUT_ROLES, timeout_multiple=timeout_multiple)
        self.outbox = Outbox(self.codec)
        self.on_event = on_event
        self.cycle_s = node.config.cycle_s
        self._status_every = max(1, int(round(node.config.status_period_s / self.cycle_s)))
        self._t0: float | None = None
        self._k = 0
        self.cycles = 0
        self.max_cycle_s = 0.0
        self.send_errors = 0
        #: cycles not run because the clock jumped by more than ``MAX_CATCHUP_S``
        self.skipped_cycles = 0
        self._max_catchup = int(MAX_CATCHUP_S / self.cycle_s)
        self.last_outputs: NodeOutputs | None = None
        #: real-time mode: start time of every cycle (s, monotonic), for jitter statistics
        self.cycle_starts: list[float] = []
        self._stop = threading.Event()
        self.profile_dir = Path(profile_dir) if profile_dir is not None else None
        self._guest_table = node.table
        self._profile_id: int | None = None
        self._lo_cmd, self._hi_cmd = self.codec.by_role["command"].bounds("accel_request_mps2")
        status = self.codec.by_role["status"]
        self._hi_gap = status.bounds("desired_gap_m")[1]
        self._hi_set = status.bounds("set_speed_mps")[1]
        self._check_outputs_fit()

    def _check_outputs_fit(self) -> None:
        """Refuse a DBC that cannot carry every output (raise :class:`RuntimeCodecError`)."""
        ctl = self.node.config.controller
        command, status = self.codec.by_role["command"], self.codec.by_role["status"]
        needs = [
            (command, "accel_request_mps2", ctl.accel_min_mps2, ctl.accel_max_mps2),
            (command, "acc_state", 0, max(AccState)),
            (command, "request_active", 0, 1),
            (command, "takeover_request", 0, 1),
            (status, "fault_code", 0, max(FaultCode)),
        ]
        for mc, key, lo, hi in needs:
            have_lo, have_hi = mc.bounds(key)
            if have_lo > lo + 1e-9 or have_hi < hi - 1e-9:
                raise RuntimeCodecError(
                    f"{mc.name}: {key} range [{have_lo:g}, {have_hi:g}] cannot carry "
                    f"[{lo:g}, {hi:g}] (AccState FAULT = {int(AccState.FAULT)}, FaultCode up "
                    f"to {int(max(FaultCode))}, the acceleration envelope)"
                )

    # -- lockstep ----------------------------------------------------------------------

    def advance_to(self, now_s: float) -> None:
        """Drain the bus into the Inbox at ``now_s`` and run every cycle due up to ``now_s``.

        Raises:
            RuntimeClockError: ``now_s`` is not finite, or so far from the first call that
                the cycle grid overflows (a host bug; nothing is consumed).
        """
        if not math.isfinite(now_s):
            raise RuntimeClockError(f"advance_to: time must be finite, got {now_s}")
        if self._t0 is not None and not math.isfinite((now_s - self._t0) / self.cycle_s):
            raise RuntimeClockError(f"advance_to: {now_s} s is beyond the cycle grid")
        self._drain(now_s)
        if self._t0 is None:
            self._t0 = now_s
        behind = int((now_s - self._t0) / self.cycle_s) - self._k
        if behind > self._max_catchup:  # a jump of the host clock: skip, do not replay
            log.warning("advance_to: %d cycles behind, skipping %d", behind, behind - 1)
            self.skipped_cycles += behind - 1
            self._k += behind - 1
        while True:
            t = self._t0 + self._k * self.cycle_s
            if t > now_s + 1e-9:
                break
            self._cycle(t)

    def _drain(self, now_s: float) -> None:
        recv = self.bus.recv
        accept = self.inbox.accept_message
        while True:
            msg = recv(0)
            if msg is None:
                return
            accept(msg, now_s)

    # -- real time ---------------------------------------------------------------------

    def run_realtime(self, duration_s: float | None = None) -> None:
        """Run 50 Hz cycles on ``time.monotonic`` for ``duration_s`` s (None: until stop()).

        Overruns of more than one period skip the missed cycles (counted in
        ``skipped_cycles``) instead of bursting them. A :meth:`stop` that came before the
        run ends it at once (a SIGTERM arriving as it starts is not lost).
        """
        if duration_s is not None and not duration_s >= 0.0:
            raise RuntimeClockError(f"run_realtime: duration must be >= 0 s, got {duration_s}")
        try:
            self._run_realtime(duration_s)
        finally:
            self._stop.clear()  # consumed: the next run starts afresh

    def _run_realtime(self, duration_s: float | None) -> None:
        clock = time.monotonic
        start = clock()
        self._t0 = start if self._t0 is None else self._t0
        first_k = self._k
        end = math.inf if duration_s is None else start + duration_s
        next_t = start
        while not self._stop.is_set():
            now = clock()
            while now < next_t:
                msg = self.bus.recv(timeout=next_t - now)
                now = clock()
                if msg is not None:
                    self.inbox.accept_message(msg, now)
            if now >= end:
                break
            self.cycle_starts.append(now)
            self._drain(now)
            self._cycle(now)
            next_t = start + (self._k - first_k) * self.cycle_s
            if next_t < clock() - self.cycle_s:  # overrun by more than a period: skip ahead
                skipped = int((clock() - next_t) / self.cycle_s)
                self._k += skipped
                self.skipped_cycles += skipped
                next_t += skipped * self.cycle_s

    def stop(self) -> None:
        """Ask :meth:`run_realtime` to return after the current cycle, or at once if called
        before it starts (thread-safe, signal-safe)."""
        self._stop.set()

    # -- one cycle ---------------------------------------------------------------------

    def read_inputs(self, now_s: float) -> NodeInputs:
        """The node's inputs from the Inbox at ``now_s``: latest values plus freshness."""
        inbox = self.inbox
        inp = NodeInputs()
        ego = inbox.latest("ego")
        if ego is not None:
            inp.v_mps = float(ego["speed_mps"])
            inp.a_mps2 = float(ego["accel_mps2"])
            inp.speed_ok = bool(ego["speed_valid"]) and inbox.fresh("ego", now_s)
        else:
            inp.speed_ok = False
        ped = inbox.latest("pedals")
        if ped is not None:
            inp.accel_pedal = float(ped["accel_pedal_pct"]) / 100.0
            inp.brake_pedal = min(float(ped["brake_pressure_bar"]) / 100.0, 1.0)
            inp.accel_pressed = bool(ped["accel_pressed"])
            inp.brake_pressed = bool(ped["brake_pressed"])
            inp.pedals_ok = inbox.fresh("pedals", now_s)
        else:
            inp.pedals_ok = False
        radar = inbox.latest("radar")
        if radar is not None:
            inp.lead_valid = bool(radar["lead_valid"])
            inp.gap_m = float(radar["gap_m"])
            inp.rel_speed_mps = float(radar["rel_speed_mps"])
            inp.lead_accel_mps2 = float(radar["lead_accel_mps2"])
            inp.lead_accel_valid = bool(radar["lead_accel_valid"])
            inp.radar_ok = inbox.fresh("radar", now_s)
        else:
            inp.radar_ok = False
        hmi = inbox.latest("hmi")
        if hmi is not None:
            inp.main_switch = bool(hmi["main_switch"])
            inp.set_button = bool(hmi["set"])
            inp.resume_button = bool(hmi["resume"])
            inp.cancel_button = bool(hmi["cancel"])
            inp.hmi_ok = inbox.fresh("hmi", now_s)
        else:
            inp.hmi_ok = False
        return inp

    def _cycle(self, t: float) -> None:
        t_start = time.perf_counter()
        inputs = self.read_inputs(t)
        if self.profile_dir is not None and inputs.hmi_ok:
            hmi = self.inbox.latest("hmi")
            if hmi is not None and int(hmi["profile_id"]) != self._profile_id:
                self._switch_profile(int(hmi["profile_id"]))
        out = self.node.step(inputs, t)
        self.last_outputs = out
        self._send(t, out)
        self._k += 1
        self.cycles += 1
        for text in out.events:
            log.debug("t=%.2f %s", t, text)
            if self.on_event is not None:
                self.on_event(f"t={t:.2f} s  {text}")
        elapsed = time.perf_counter() - t_start
        if elapsed > self.max_cycle_s:
            self.max_cycle_s = elapsed

    def _send(self, t: float, out: NodeOutputs) -> None:
        from dbc.codec import EncodeError

        try:
            command: dict[str, Any] = {
                "accel_request_mps2": _clamp(out.accel_request_mps2, self._lo_cmd, self._hi_cmd),
                "request_active": int(out.request_active),
                "acc_state": int(out.acc_state),
                "takeover_request": int(out.takeover_request),
            }
            self.bus.send(self.outbox.pack("command", command, timestamp=t))
            if (self._k % self._status_every) == 0:
                status: dict[str, Any] = {
                    "desired_gap_m": _clamp(out.desired_gap_m, 0.0, self._hi_gap),
                    "dgpt_version": out.dgpt_version & 0xFFFF,
                    "adaptation_count": min(out.adaptation_count, 255),
                    "fault_code": int(out.fault_code),
                    "set_speed_mps": _clamp(out.set_speed_mps, 0.0, self._hi_set),
                }
                self.bus.send(self.outbox.pack("status", status, timestamp=t))
        except (EncodeError, can.CanError) as exc:
            self.send_errors += 1
            log.error("t=%.2f send failed: %s", t, exc)

    def _switch_profile(self, profile_id: int) -> None:
        """Load driver profile ``profile_id`` (I/O at the edge; never raises)."""
        from ecu.dgpt import DgptError, load_dgpt

        self._profile_id = profile_id
        node = self.node
        if profile_id == 0:
            if node.table is not self._guest_table:
                node.set_table(self._guest_table, "profile 0 (guest): startup table")
            return
        assert self.profile_dir is not None
        path = self.profile_dir / f"profile_{profile_id}.json"
        try:
            missing = not path.exists()
        except OSError as exc:  # e.g. EACCES, ENAMETOOLONG: not "missing", unusable
            node.report_profile_fault(
                f"profile {profile_id} refused: {path}: {exc.strerror or exc}; keeping the "
                f"last good DGPT ({node.table.driver_id} v{node.table.version})"
            )
            return
        if missing:
            node.set_table(
                node.table, f"profile {profile_id}: no {path}, keeping DGPT v{node.table.version}"
            )
            return
        try:
            table = load_dgpt(path, node.config.bounds)
        except DgptError as exc:
            node.report_profile_fault(
                f"profile {profile_id} refused: {exc}; keeping the last good DGPT "
                f"({node.table.driver_id} v{node.table.version})"
            )
            return
        node.set_table(
            table, f"profile {profile_id}: {table.driver_id} {table.source} v{table.version}"
        )

    # -- reporting ---------------------------------------------------------------------

    def summary(self) -> RuntimeSummary:
        """Counters of the run so far."""
        node = self.node
        return RuntimeSummary(
            cycles=self.cycles,
            frames_in=self.inbox.frames_in,
            frames_out=self.outbox.frames_out,
            e2e_errors=self.inbox.errors(),
            takeovers=node.takeovers,
            adaptations=node.adaptations,
            max_cycle_s=self.max_cycle_s,
            state=node.state.name,
            dgpt_version=node.table.version,
            send_errors=self.send_errors,
            skipped_cycles=self.skipped_cycles,
            adaptation_decisions={r.value: n for r, n in node.decisions.items()},
            faults={f.name: n for f, n in node.faults.items()},
        )


__all__ = [
    "INPUT_ROLES",
    "MAX_CATCHUP_S",
    "EcuRuntime",
    "RuntimeClockError",
    "RuntimeCodecError",
    "RuntimeSummary",
]
