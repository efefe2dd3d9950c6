"""The simulator's bus node: plays ESC, PEDAL, RADAR and HMI, consumes ACC_Command.

Frames go out at their DBC periods through the Outbox (counter, CRC) and the role's fault plan
(:mod:`sim_bus.faults`), stamped with simulated time; ACC_Command is E2E-checked by an Inbox
and applied while fresh (``command_timeout_s``, s). :meth:`SimNode.step` is one lockstep tick
(same seed, same frames); :meth:`SimNode.run_realtime` sleeps to the wall clock.
"""

from __future__ import annotations

import heapq
import math
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

import can
import numpy as np

from dbc.codec import Codec, load_codec
from dbc.endpoint import Inbox, Outbox
from dbc.frame import port_of, raw_key
from dbc.message import MessageCodec
from dbc.vocab.acc_state import AccState
from sim_bus.faults import ROLES as TX_ROLES
from sim_bus.faults import FaultPlan, FaultSpec
from sim_bus.readings import Readings
from sim_bus.world import World


class SimNode:
    """Bus I/O around a :class:`World` on any python-can ``bus`` (:func:`dbc.frame.port_of`);
    ``rng`` draws the random faults; ``gap_setting`` 1..3 and ``profile_id`` go on the HMI."""

    def __init__(
        self,
        bus: can.BusABC,
        world: World,
        codec: Codec | None = None,
        faults: FaultSpec | None = None,
        rng: np.random.Generator | None = None,
        gap_setting: int = 2,
        profile_id: int = 0,
        command_timeout_s: float = 0.1,
    ) -> None:
        self.bus = bus
        self.port = port_of(bus)
        self.world = world
        self.codec = codec or load_codec()
        self.outbox = Outbox(self.codec)
        self.inbox = Inbox(
            self.codec,
            tuple(r for r in ("command", "status") if r in self.codec.roles),
            timeout_multiple=command_timeout_s / self.codec.by_role["command"].cycle_s,
        )
        self.dt_s = world.cfg.plant.dt_s
        self.tick, self.t_s = 0, 0.0
        roles = {r: self.codec.roles[r] for r in TX_ROLES}
        #: each role's values at this tick, read off the world (:class:`Readings`)
        self.readings = Readings(world, roles, gap_setting, profile_id)
        self._rng = rng or np.random.default_rng(0)
        self._frozen: dict[str, dict[str, Any]] = {}
        #: delayed frames: (due time s, sequence, key, payload)
        self._pending: list[tuple[float, int, int, bytes]] = []
        self._seq = 0
        #: the last usable command: request active, request m/s², AccState, takeover request
        self.request_active, self.a_request_mps2, self.takeover_request = False, 0.0, False
        self.acc_state: int = AccState.OFF
        self.status: dict[str, Any] | None = None
        self.frames_sent = 0
        self.send_errors = 0  # frames the bus refused (can.CanError on send)
        self.recv_errors = 0  # can.CanError on receive
        self.fault_counts: Counter[tuple[str, str]] = Counter()
        rd = self.readings  # each role's filler: its values at this tick
        self._fillers = {"ego": rd.ego, "pedals": rd.pedals, "radar": rd.radar, "hmi": rd.hmi}
        self._roles = roles
        self.faults = faults  # schedules the frames (the property's setter)
        self.commands_ok = 0
        #: called with (time s, key, payload, received) for every frame in and out (a recorder)
        self.tap: Callable[[float, int, Any, bool], None] | None = None

    @property
    def faults(self) -> FaultSpec | None:
        """The fault plans of the transmitted frames (None: none); setting re-plans them."""
        return self._faults

    @faults.setter
    def faults(self, faults: FaultSpec | None) -> None:
        self._faults = faults if faults is not None and faults.plans else None
        roles, fillers = self._roles, self._fillers
        plans = self._faults.plans if self._faults is not None else {}
        every = {r: [max(1, round(p.cycle_s / self.dt_s)) for p in roles[r].parts] for r in roles}
        self._hyper = math.lcm(*(n for ns in every.values() for n in ns))
        #: ``_due[k % _hyper]``: per role due at tick k, its filler and its messages due (each
        #: with its frame key and fault plan)
        self._due = [
            tuple(
                (
                    fillers[r],
                    tuple(
                        (mc, raw_key(mc.frame_id, mc.is_extended), plans.get(r))
                        for mc, n in zip(roles[r].parts, every[r], strict=True)
                        if k % n == 0
                    ),
                )
                for r in TX_ROLES
                if any(k % n == 0 for n in every[r])
            )
            for k in range(self._hyper)
        ]

    def _receive(self, now: float) -> None:
        """Take every waiting frame in (the command and status they carry)."""
        try:
            frames = self.port.take()
        except can.CanError:  # a bus error (real bus): nothing more to read this tick
            self.recv_errors += 1
            return
        accept, tap = self.inbox.accept, self.tap
        for _, key, data in frames:
            if tap is not None:
                tap(now, key, data, True)
            d = accept(key, data, now)
            if d is not None:
                self._use(d[0])

    def _use(self, role: str) -> None:
        """A usable frame of ``role`` came in: the command and status it carries."""
        if role == "command":
            v = self.inbox.latest("command")  # every message of the role, merged
            if v is None:
                return
            self.commands_ok += 1
            self.request_active = bool(v["request_active"])
            self.a_request_mps2 = float(v["accel_request_mps2"])
            self.acc_state = int(v["acc_state"])
            self.takeover_request = bool(v["takeover_request"])
        elif role == "status":
            self.status = self.inbox.latest("status")

    def _transmit(self, now: float) -> None:
        """Send the frames due at this tick (through their fault plans), then delayed ones."""
        encode, put, tap = self.outbox.encode_part, self.port.put, self.tap
        out: list[tuple[int, bytes]] = []
        for fill, frames in self._due[self.tick % self._hyper]:
            values = fill()
            for mc, key, plan in frames:
                if plan is None:
                    out.append((key, encode(mc, values)))
                else:
                    self._fault(mc, key, values, plan, now, out)
        pending = self._pending
        while pending and pending[0][0] <= now + 1e-9:
            _, _, key, data = heapq.heappop(pending)
            out.append((key, data))
        sent = 0
        for key, data in out:
            try:
                put(now, key, data)
            except can.CanError:  # lost, like a dropped frame; the simulation goes on
                self.send_errors += 1
                continue
            sent += 1
            if tap is not None:
                tap(now, key, data, False)
        self.frames_sent += sent

    def _fault(
        self,
        mc: MessageCodec,
        key: int,
        vals: dict[str, Any],
        plan: FaultPlan,
        now: float,
        out: list[tuple[int, bytes]],
    ) -> None:
        """One frame of ``mc`` through its role's fault plan, into ``out`` if it goes now; one
        uniform draw decides every random fault (one seed hits the same frames)."""
        counts = self.fault_counts
        role = mc.role
        if plan.silent_at(now):
            counts[(role, "silent")] += 1
            return
        window = plan.frozen_at(now)
        if window is not None:
            vals = self._frozen.setdefault(f"{mc.key}@{window[0]}", dict(vals))
            counts[(role, "frozen")] += 1
        u = float(self._rng.random()) if plan.random else 1.0
        if u < plan.counter and mc.counter_modulo:  # repeat the previous alive counter
            counters = self.outbox.counters
            counters[mc.key] = (counters[mc.key] - 1) % mc.counter_modulo
            counts[(role, "counter")] += 1
        data = self.outbox.encode_part(mc, vals)
        if u < plan.crc:  # a payload byte flipped on the wire: the CRC no longer matches
            flipped = bytearray(data)
            flipped[2 if mc.crc_byte != 2 else 3] ^= 0x5A
            data = bytes(flipped)
            counts[(role, "crc")] += 1
        if u < plan.drop:
            counts[(role, "drop")] += 1
            return
        if plan.delay_s > 0.0:
            self._seq += 1
            heapq.heappush(self._pending, (now + plan.delay_s, self._seq, key, data))
            counts[(role, "delay")] += 1
            return
        out.append((key, data))

    @property
    def frames_faulted(self) -> int:
        """Frames hit by any fault so far."""
        return sum(self.fault_counts.values())

    def command_now(self, now: float) -> tuple[bool, float, int]:
        """(request active and fresh, request m/s², AccState the driver sees) at ``now``."""
        fresh = self.inbox.fresh("command", now) if self.commands_ok else False
        active = self.request_active and fresh
        a = self.a_request_mps2 if active and math.isfinite(self.a_request_mps2) else 0.0
        return active, a, self.acc_state if fresh else AccState.OFF

    def step(self) -> None:
        """One lockstep tick: take in commands, send due frames, advance the world by dt."""
        now = self.t_s
        self._receive(now)
        self._transmit(now)
        active, a, state = self.command_now(now)
        self.world.advance(active, a, state)
        self.tick += 1
        self.t_s = self.tick * self.dt_s

    def run_realtime(self, duration_s: float, stop: Any = None) -> None:
        """Run in real time for ``duration_s`` (or until the world is done / ``stop()``)."""
        start = time.monotonic()
        while self.t_s < duration_s and not self.world.done:
            if stop is not None and stop():
                break
            self.step()
            delay = start + self.t_s - time.monotonic()
            if delay > 0:
                time.sleep(delay)
