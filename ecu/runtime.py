"""The ECU runtime: wires a python-can bus, the codec, a clock and the log to an EcuNode.

Thin wiring of :mod:`ecu.busio` (frames <-> node values, ACC_Command every cycle, ACC_Status
every 100 ms), :mod:`ecu.profiles` (the HMI's driver profile -> the node's table) and
:mod:`ecu.clocks` (the cycle grid in lockstep, ``rt.advance_to(now_s)``, or in real time,
``rt.run_realtime(duration_s)`` at 50 Hz until ``rt.stop()``).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import can

from dbc.codec import Codec, load_codec
from dbc.vocab.dgpt import Dgpt
from ecu.busio import BusIO, inputs_from
from ecu.buslog.writer import CanLogWriter
from ecu.clocks import CycleClock
from ecu.node import EcuNode
from ecu.profiles import GUEST_PROFILE, ProfileSwitcher, TableOffer, gap_setting_table
from ecu.signals import NodeOutputs

log = logging.getLogger(__name__)


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
    #: command frames the safety check (:mod:`ecu.safety`) changed, by rule broken
    safety_stops: dict[str, int] = field(default_factory=dict)
    #: faults of plug-in methods (``"controller raised"`` -> count; :mod:`ecu.methods.guard`)
    plugin_faults: dict[str, int] = field(default_factory=dict)

    def __str__(self) -> str:
        def counts(d: dict[str, int], empty: str = "none") -> str:
            return ", ".join(f"{k} {v}" for k, v in sorted(d.items())) or empty

        errors, faults = counts(self.e2e_errors), counts(self.faults)
        decisions, stops = counts(self.adaptation_decisions), counts(self.safety_stops)
        plugin = counts(self.plugin_faults, "")
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
                f"safety stops:   {stops}",
            ]
            + ([f"plug-in faults: {plugin} (safe output used)"] if plugin else [])
        )


class EcuRuntime:
    """Bus-side driver of an :class:`EcuNode` on an open ``bus`` (the caller closes it).

    ``codec`` None: the packaged pacc DBC; ``on_event``: gets each node event text; an input role
    times out after ``timeout_multiple`` DBC periods; ``profile_dir``: ``profile_<n>.json``
    (:mod:`ecu.profiles`). RuntimeCodecError: the codec cannot carry every output."""

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
        self.bus = bus
        self.node = node
        self.codec = codec if codec is not None else load_codec()
        self.io = BusIO(bus, self.codec, node.config, timeout_multiple)
        self.clock = CycleClock(node.config.cycle_s)
        self.profiles = ProfileSwitcher(node, profile_dir) if profile_dir is not None else None
        self._gap_setting: float | None = None  # the HMI GapSetting last seen (None: none)
        #: tables offered from other threads (the cloud download), swapped in when safe
        self.table_offer = TableOffer()
        self.on_event = on_event
        self.cycle_s = node.config.cycle_s
        self._status_every = max(1, int(round(node.config.status_period_s / self.cycle_s)))
        self.cycles = 0
        #: longest compute time of one cycle, s
        self.max_cycle_s = 0.0
        self.last_outputs: NodeOutputs | None = None
        self.recorder: CanLogWriter | None = None

    def record_to(self, recorder: CanLogWriter | None) -> None:
        """Record every frame in and out and every cycle's inputs, outputs and events to
        ``recorder`` (:mod:`ecu.buslog.writer`; None: stop recording). The caller closes it."""
        self.recorder = recorder
        self.io.tap = recorder.frame_raw if recorder is not None else None

    def advance_to(self, now_s: float) -> None:
        """Lockstep: drain the bus at ``now_s`` and run every cycle due (:class:`CycleClock`)."""
        self.clock.advance_to(now_s, self.io, self._cycle)

    def run_realtime(self, duration_s: float | None = None) -> None:
        """Run 50 Hz cycles on ``time.monotonic`` for ``duration_s`` s (None: until stop())."""
        self.clock.run_realtime(duration_s, self.io, self._cycle)

    def cycle_at(self, t_s: float, k: int) -> None:
        """Run control cycle ``k`` at ``t_s`` now, on a clock the caller keeps (a replay of a
        recording's cycles: :mod:`ecu.buslog.replay`); frames must have been accepted before."""
        self._cycle(t_s, k)

    def offer_table(self, table: Dgpt, message: str) -> None:
        """Swap ``table`` in at the next cycle where the ACC is not ACTIVE (thread-safe)."""
        self.table_offer.offer(table, message)

    def stop(self) -> None:
        """Ask :meth:`run_realtime` to return after the current cycle, or at once if called
        before it starts (thread-safe, signal-safe)."""
        self.clock.stop()

    def _cycle(self, t: float, k: int) -> None:
        """Cycle ``k`` at ``t``: inputs, profile, step, frames, events."""
        t_start = time.perf_counter()
        io = self.io
        inputs = inputs_from(io.inbox, t, io.pedals)  # io.read_inputs, without the call
        hmi = io.inbox.latest("hmi") if inputs.hmi_ok else None  # None: stale
        profiles = self.profiles
        if profiles is not None:  # the driver profile the HMI asks for (DriverProfileId)
            profiles.request(None if hmi is None else int(hmi["profile_id"]))
        if profiles is None or profiles.selected in (None, GUEST_PROFILE):
            self.table_offer.apply(self.node)  # not under another driver's HMI profile
        if hmi is not None and hmi.get("gap_setting") != self._gap_setting:
            self._gap_setting, first = hmi.get("gap_setting"), self._gap_setting is None
            table = None if first else gap_setting_table(self.node.table, self._gap_setting)
            if table is not None:  # the driver changed the gap: the predefined headway follows
                self.node.set_table(table, f"gap setting {self._gap_setting}")
        out = self.node.step(inputs, t)
        self.last_outputs = out
        sent = io.send(t, out, status=k % self._status_every == 0)
        if self.recorder is not None:
            self.recorder.cycle(t, inputs, sent, k)  # what went on the bus, safety-checked
        self.cycles += 1
        for text in out.events:
            log.debug("t=%.2f %s", t, text)
            if self.on_event is not None:
                self.on_event(f"t={t:.2f} s  {text}")
        spent = time.perf_counter() - t_start
        if spent > self.max_cycle_s:  # noqa: PLR1730 - max() without the builtin call
            self.max_cycle_s = spent

    def summary(self) -> RuntimeSummary:
        """Counters of the run so far."""
        node = self.node
        return RuntimeSummary(
            cycles=self.cycles,
            frames_in=self.io.inbox.frames_in,
            frames_out=self.io.outbox.frames_out,
            e2e_errors=self.io.inbox.errors(),
            takeovers=node.takeovers,
            adaptations=node.adaptations,
            max_cycle_s=self.max_cycle_s,
            state=node.state.name,
            dgpt_version=node.table.version,
            send_errors=self.io.send_errors,
            skipped_cycles=self.clock.skipped,
            adaptation_decisions={r.value: n for r, n in node.decisions.items()},
            faults={f.name: n for f, n in node.faults.items()},
            safety_stops=dict(self.io.safety.stopped),
            plugin_faults=node.plugin_faults,
        )
