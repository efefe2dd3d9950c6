"""The simulator's bus node: plays ESC, PEDAL, RADAR and HMI, consumes ACC_Command.

Frames go out at their DBC periods (ego and pedals 10 ms, radar 50 ms, hmi 100 ms) with the
alive counter and CRC of the codec's Outbox, stamped with simulated time. ACC_Command frames
are checked by an Inbox (E2E); the request is applied only while the command is fresh
(``command_timeout_s``), ``request_active`` is 1 and no pedal is pressed (see world.World).

Two clocks: :meth:`SimNode.step` (lockstep, one tick; the caller owns time: same seed, same
frame sequence) and :meth:`SimNode.run_realtime` (sleeps to the wall clock).
Fault injection (sim_bus.faults) is applied to the transmitted frames.
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

from dbc.codec import Codec, MessageCodec, load_codec
from dbc.endpoint import Inbox, Outbox
from dbc.frame import OTHER, Frame, message_of, raw_key
from dbc.lockstep import LockstepBus
from dbc.vocab.acc_state import AccState
from sim_bus.faults import ROLES, FaultPlan, FaultSpec
from sim_bus.readings import Readings
from sim_bus.world import World

#: the roles the simulator sends (the ones faults apply to)
TX_ROLES = ROLES


class SimNode:
    """Bus I/O around a :class:`World`. ``bus`` is any python-can bus; a lockstep bus's end is
    read raw from construction on (:meth:`dbc.lockstep.LockstepBus.receive_raw`) and the
    node sends raw frames there, no message objects (a :attr:`tap` gets messages built for
    it).

    ``faults``: per-role fault plans; ``rng``: the Generator for random faults (seeded by the
    caller); ``gap_setting`` 1..3 and ``profile_id`` 0..255 are sent on HMI_Buttons.
    """

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
        self.world = world
        self.codec = codec or load_codec()
        self.outbox = Outbox(self.codec)
        cmd_cycle = self.codec.by_role["command"].cycle_s
        self.inbox = Inbox(
            self.codec,
            tuple(r for r in ("command", "status") if r in self.codec.roles),
            timeout_multiple=command_timeout_s / cmd_cycle,
        )
        self.dt_s = world.cfg.plant.dt_s
        self.tick = 0
        self.t_s = 0.0
        roles = {r: self.codec.roles[r] for r in TX_ROLES}
        #: the messages the simulator sends, role by role (most networks: one per role)
        self._parts: tuple[MessageCodec, ...] = tuple(p for r in TX_ROLES for p in roles[r].parts)
        every = {p.key: max(1, int(round(p.cycle_s / self.dt_s))) for p in self._parts}
        hyper = math.lcm(*every.values())
        self._hyper = hyper
        #: messages due at tick k are ``_due[k % hyper]`` (the periods as a tick schedule)
        self._due = [tuple(p for p in self._parts if k % every[p.key] == 0) for k in range(hyper)]
        #: the same schedule by role (role, its messages due), each role's values filled once
        self._due_roles = [
            tuple(
                (r, tuple(p for p in due if p.role == r))
                for r in TX_ROLES
                if any(p.role == r for p in due)
            )
            for due in self._due
        ]
        #: each role's values at this tick, read off the world (:class:`Readings`)
        self.readings = Readings(world, roles, gap_setting, profile_id)
        self.faults = faults if faults is not None and faults.plans else None
        self._rng = rng or np.random.default_rng(0)
        self._frozen: dict[str, dict[str, Any]] = {}
        self._pending: list[tuple[float, int, can.Message]] = []
        self._seq = 0
        self.request_active = False
        self.a_request_mps2 = 0.0
        self.acc_state: int = AccState.OFF
        self.takeover_request = False
        self.status: dict[str, Any] | None = None
        self.frames_sent = 0
        self.send_errors = 0  # frames the bus refused (can.CanError on send)
        self.recv_errors = 0  # can.CanError on receive
        self.fault_counts: Counter[tuple[str, str]] = Counter()
        # the virtual bus exposes its receive queue, the lockstep bus its count of frames
        # waiting: peeking either saves a recv() call per tick with nothing to read
        queue = getattr(bus, "queue", None)
        self._rx_queue = queue if callable(getattr(queue, "empty", None)) else None
        lock = bus if isinstance(bus, LockstepBus) else None
        self._rx_deque = lock.rx if lock is not None else None
        #: the lockstep bus, read raw: every waiting frame in one call, and frames sent
        #: without message objects (:meth:`dbc.lockstep.LockstepBus.receive_raw`,
        #: :meth:`~dbc.lockstep.LockstepBus.hand_over_raw`)
        self._take_raw = lock.receive_raw() if lock is not None else None
        self._hand_over_raw = lock.hand_over_raw if lock is not None else None
        self._channel = lock.channel_id if lock is not None else None
        # one reusable message per role (the virtual bus copies what it sends)
        self._msgs: dict[str, can.Message] = {
            p.key: Frame(arbitration_id=p.frame_id, is_extended_id=p.is_extended, dlc=p.length)
            for p in self._parts
        }
        #: each role's filler: its values for this tick (one call per role and tick)
        self._fillers = self.readings.fillers(TX_ROLES)
        #: the hot path's schedule: (filler, ((message, its reused frame), ...)) per role due
        self._due_fill = [
            tuple(
                (self._fillers[r], tuple((mc, self._msgs[mc.key]) for mc in parts))
                for r, parts in due
            )
            for due in self._due_roles
        ]
        self.commands_ok = 0
        #: called with (time, frame, received) for every frame in and out (a bus recorder)
        self.tap: Callable[[float, can.Message, bool], None] | None = None
        #: each message's raw key (:func:`dbc.frame.raw_key`)
        self._keys = {mc.key: raw_key(mc.frame_id, mc.is_extended) for mc in self._parts}

    # -- receive ------------------------------------------------------------------------
    def _idle(self) -> bool:
        """True when the bus surely holds no frame (lockstep or virtual); False: maybe."""
        if self._rx_deque is not None:
            return not self._rx_deque
        return self._rx_queue is not None and self._rx_queue.empty()

    def _receive(self, now: float) -> None:
        if self._idle():
            return  # nothing arrived since the last tick
        if self._take_raw is not None:  # the lockstep bus
            self._take_in(now)
            return
        bus = self.bus
        while True:
            try:
                msg = bus.recv(0.0)
            except can.CanError:  # a bus error (real bus): nothing more to read this tick
                self.recv_errors += 1
                break
            if msg is None:
                break
            self._accept(msg, now)

    def _take_in(self, now: float) -> None:
        """The lockstep bus: take every waiting frame in, in one call, raw."""
        assert self._take_raw is not None
        try:
            entries = self._take_raw()
        except can.CanError:
            self.recv_errors += 1
            return
        accept = self.inbox.accept_raw
        tap = self.tap
        for entry in entries:
            _, key, data = entry
            if key == OTHER:  # an error, remote or FD frame: the message itself
                self._accept(data, now)
                continue
            if tap is not None:  # a tap wants messages: built for it only
                tap(now, message_of(entry, self._channel), True)
            d = accept(key, data, now)
            if d is not None:
                self._use(d[0])

    def _accept(self, msg: can.Message, now: float) -> None:
        """Take one received frame in (the command and status it carries)."""
        if self.tap is not None:
            self.tap(now, msg, True)
        if msg.is_error_frame or msg.is_remote_frame:
            return
        d = self.inbox.accept_message(msg, now)
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

    # -- transmit -----------------------------------------------------------------------
    def _fill(self, role: str) -> dict[str, Any]:
        """``role``'s values at this tick (its dict, updated in place)."""
        return self._fillers[role]()

    def _send(self, msg: can.Message) -> None:
        try:
            self.bus.send(msg)
        except can.CanError:  # e.g. a full transmit queue on a real bus: the frame is lost
            self.send_errors += 1
            return
        self.frames_sent += 1
        if self.tap is not None:
            self.tap(msg.timestamp, msg, False)

    def _transmit(self, now: float) -> None:
        faults = self.faults
        if faults is None:  # the hot path: no fault logic
            self._transmit_due(now)
            return
        for mc in self._due[self.tick % len(self._due)]:
            vals = self._fill(mc.role)
            plan = faults.plan(mc.role)
            if plan is None:
                self._send(self.outbox.pack_part(mc, vals, timestamp=now))
            else:
                self._transmit_faulty(mc, vals, plan, now)
        if self._pending:
            while self._pending and self._pending[0][0] <= now + 1e-9:
                _, _, msg = heapq.heappop(self._pending)
                msg.timestamp = now
                self._send(msg)

    def _transmit_due(self, now: float) -> None:
        """Send the frames due at this tick, without faults: each role's values filled once;
        on the lockstep bus raw (:meth:`_transmit_raw`); on another bus the role's reused
        message, which the bus copies."""
        if self._hand_over_raw is not None:
            self._transmit_raw(now)
            return
        encode = self.outbox.encode_part
        tap = self.tap
        send = self.bus.send
        sent = 0
        for fill, frames in self._due_fill[self.tick % self._hyper]:
            values = fill()  # once per role and tick, whatever its messages
            for mc, msg in frames:
                msg.data = bytearray(encode(mc, values))
                msg.timestamp = now
                try:
                    send(msg)
                except can.CanError:  # lost, like a dropped frame; the simulation goes on
                    self.send_errors += 1
                    continue
                sent += 1
                if tap is not None:
                    tap(now, msg, False)
        self.frames_sent += sent

    def _transmit_raw(self, now: float) -> None:
        """:meth:`_transmit_due` on the lockstep bus: each frame sent raw, no message."""
        assert self._hand_over_raw is not None
        encode = self.outbox.encode_part
        send = self._hand_over_raw
        keys = self._keys
        tap = self.tap
        sent = 0
        for fill, frames in self._due_fill[self.tick % self._hyper]:
            values = fill()  # once per role and tick, whatever its messages
            for mc, _ in frames:
                data = encode(mc, values)
                key = keys[mc.key]
                try:
                    send(now, key, data)
                except can.CanError:  # a closed bus: lost, counted; the simulation goes on
                    self.send_errors += 1
                    continue
                sent += 1
                if tap is not None:  # a tap wants messages: built for it only
                    tap(now, message_of((now, key, data), self._channel, False), False)
        self.frames_sent += sent

    def _transmit_faulty(
        self, mc: MessageCodec, vals: dict[str, Any], plan: FaultPlan, now: float
    ) -> None:
        """Send one frame of message ``mc`` through its role's fault plan.

        One uniform draw per frame decides the random faults (``u < counter``, ``u < crc``,
        ``u < drop``), so with one seed the same frames are hit whatever the kind.
        """
        counts = self.fault_counts
        role = mc.role
        if plan.silent_at(now):
            counts[(role, "silent")] += 1
            return
        window = plan.frozen_at(now)
        if window is not None:
            key = f"{mc.key}@{window[0]}"
            if key not in self._frozen:
                self._frozen[key] = dict(vals)
            vals = self._frozen[key]
            counts[(role, "frozen")] += 1
        u = float(self._rng.random()) if plan.random else 1.0
        if u < plan.counter and mc.counter_modulo:  # repeat the previous alive counter
            counters = self.outbox.counters
            counters[mc.key] = (counters[mc.key] - 1) % mc.counter_modulo
            counts[(role, "counter")] += 1
        msg = self.outbox.pack_part(mc, vals, timestamp=now)
        if u < plan.crc:  # a payload byte flipped on the wire: the CRC no longer matches
            data = bytearray(msg.data)
            i = 2 if mc.crc_byte != 2 else 3
            data[i] ^= 0x5A
            msg.data = data
            counts[(role, "crc")] += 1
        if u < plan.drop:
            counts[(role, "drop")] += 1
            return
        if plan.delay_s > 0.0:
            self._seq += 1
            heapq.heappush(self._pending, (now + plan.delay_s, self._seq, msg))
            counts[(role, "delay")] += 1
            return
        self._send(msg)

    @property
    def frames_faulted(self) -> int:
        """Frames hit by any fault so far."""
        return sum(self.fault_counts.values())

    # -- clocks -------------------------------------------------------------------------
    def command_now(self, now: float) -> tuple[bool, float, int]:
        """(request active and fresh, request m/s², AccState the driver sees) at ``now``."""
        fresh = self.inbox.fresh("command", now) if self.commands_ok else False
        active = self.request_active and fresh
        a = self.a_request_mps2 if active and math.isfinite(self.a_request_mps2) else 0.0
        return active, a, self.acc_state if fresh else AccState.OFF

    def step(self) -> None:
        """One lockstep tick: take in commands, send due frames, advance the world by dt."""
        now = self.t_s
        rx = self._rx_deque
        if rx is None:
            self._receive(now)
        elif rx:  # the lockstep bus, a frame waiting: every waiting frame at once
            self._take_in(now)
        if self.faults is None:
            self._transmit_due(now)
        else:
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
