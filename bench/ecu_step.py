"""Benchmark of the ACC ECU: step() time, lockstep cycle cost, real-time cycle jitter.

Run from the repository root: ``python bench/ecu_step.py [--seconds 60] [--steps 20000]``
(the ESC, PEDAL, RADAR and HMI peers are played by :class:`Peers` below).

1. ``step()`` of an engaged node following a lead on a minimal plant (no bus): p50 / p99,
   against a named peer measured in the same run: cantools ``Database.decode_message`` of one
   ACC_Command frame (the usual cost of touching one CAN frame in Python).
2. Lockstep: ``EcuRuntime.advance_to`` per 20 ms cycle on the lockstep bus with ESC, PEDAL,
   RADAR and HMI frames pending (what ``pacc drive`` pays per cycle), p50 / p99.
3. Real time: ``run_realtime`` for ``--seconds`` on a virtual bus while a thread plays the
   other nodes; jitter = |cycle period - 20 ms|, p50 / p99 / max, against a named peer: a
   bare 50 Hz loop sleeping to the same deadlines (``time.sleep``) in the same run.

Targets: step p99 <= 200 us, jitter p99 <= 2 ms.
"""

from __future__ import annotations

import argparse
import math
import threading
import time

import can
import numpy as np

from dbc.codec import Codec, load_codec
from dbc.endpoint import Outbox
from dbc.schema import resting_values
from dbc.vocab.dgpt import predefined
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from ecu.signals import NodeInputs

#: the roles the peers play
PEER_ROLES = ("ego", "pedals", "radar", "hmi")


class Peers:
    """Scripted ESC, PEDAL, RADAR and HMI nodes on ``bus``: an engaged car 40 m behind a lead
    at the same 20 m/s, each role sent at its DBC period with counter and CRC."""

    def __init__(self, bus: can.BusABC, codec: Codec | None = None) -> None:
        self.bus = bus
        self.codec = codec if codec is not None else load_codec()
        self.outbox = Outbox(self.codec)
        self.values: dict[str, dict[str, float]] = resting_values(
            ego={"speed_mps": 20.0}, radar={"gap_m": 40.0}
        )
        self._next = dict.fromkeys(PEER_ROLES, -math.inf)

    def set(self, role: str, **values: float) -> None:
        """Update the logical values of ``role`` for its next frames."""
        self.values[role].update(values)

    def send_due(self, now_s: float) -> None:
        """Send every role whose period has elapsed at ``now_s`` (s); a late caller
        re-aligns instead of bursting."""
        for role in PEER_ROLES:
            due = self._next[role]
            if now_s + 1e-9 < due:
                continue
            period = self.codec.by_role[role].cycle_s
            following = (now_s if due == -math.inf else due) + period
            self._next[role] = following if following > now_s else now_s + period
            self.bus.send(self.outbox.pack(role, self.values[role], now_s))


DT = 0.02


def _pct(samples: list[float] | np.ndarray, q: float) -> float:
    return float(np.percentile(np.asarray(samples), q))


def bench_step(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-call times (s) of ``EcuNode.step`` in a following scenario, and of the peer."""
    node = EcuNode(EcuConfig(set_speed_mps=30.0), predefined(1.5))
    v, gap, a, v_lead, t = 20.0, 50.0, 0.0, 20.0, 0.0
    clock = time.perf_counter_ns
    times = np.empty(n)
    for k in range(n + 100):
        v_lead = 20.0 + 3.0 * np.sin(0.05 * t)
        inp = NodeInputs(
            v_mps=v,
            a_mps2=a,
            lead_valid=True,
            gap_m=gap,
            rel_speed_mps=v_lead - v,
            main_switch=True,
            set_button=50 <= k < 55,
        )
        t0 = clock()
        out = node.step(inp, t)
        if k >= 100:
            times[k - 100] = (clock() - t0) * 1e-9
        a += ((out.accel_request_mps2 if out.request_active else 0.0) - a) * DT / 0.3
        v = max(v + a * DT, 0.0)
        gap += (v_lead - v) * DT
        t += DT
    assert node.state.name == "ACTIVE", node.state
    codec = load_codec()
    db = codec.db  # the cantools Database the codec was built from
    mc = codec.by_role["command"]
    data = mc.encode(
        {"accel_request_mps2": 0.5, "request_active": 1, "acc_state": 2, "takeover_request": 0}, 1
    )
    peer = np.empty(n)
    for k in range(n):
        t0 = clock()
        db.decode_message(mc.frame_id, data)
        peer[k] = (clock() - t0) * 1e-9
    return times, peer


def bench_lockstep(cycles: int) -> np.ndarray:
    """Per-cycle cost (s) of ``advance_to`` with the peers' frames pending (2 x 10 ms)."""
    codec = load_codec()
    with (
        can.Bus(interface="lockstep", channel="bench-lockstep") as ecu_bus,
        can.Bus(interface="lockstep", channel="bench-lockstep") as peer_bus,
    ):
        node = EcuNode(EcuConfig(set_speed_mps=30.0), predefined(1.5))
        rt = EcuRuntime(ecu_bus, node, codec)
        peers = Peers(peer_bus, codec)
        times = np.empty(cycles)
        clock = time.perf_counter_ns
        for k in range(2 * cycles + 200):
            t = k * 0.01
            peers.set("hmi", set=int(1.2 <= t < 1.4))
            peers.send_due(t)
            t0 = clock()
            rt.advance_to(t)
            el = (clock() - t0) * 1e-9
            if k >= 200 and k % 2 == 0:
                times[(k - 200) // 2] = el
            while peer_bus.recv(0) is not None:
                pass
        assert node.state.name == "ACTIVE", node.state
    return times


def _play(channel: str, stop: threading.Event) -> None:
    with can.Bus(interface="virtual", channel=channel) as bus:
        peers = Peers(bus)
        t0 = time.monotonic()
        while not stop.is_set():
            t = time.monotonic() - t0
            peers.set("hmi", set=int(1.2 <= t < 1.4))
            peers.send_due(t)
            while bus.recv(0) is not None:
                pass
            time.sleep(0.001)


def bench_realtime(seconds: float) -> tuple[np.ndarray, float, str]:
    """Cycle-period jitter (s) of ``run_realtime``, its max cycle time, final state."""
    channel = "bench-realtime"
    stop = threading.Event()
    player = threading.Thread(target=_play, args=(channel, stop), daemon=True)
    player.start()
    try:
        with can.Bus(interface="virtual", channel=channel) as bus:
            node = EcuNode(EcuConfig(set_speed_mps=30.0), predefined(1.5))
            rt = EcuRuntime(bus, node)
            rt.run_realtime(seconds)
    finally:
        stop.set()
        player.join()
    periods = np.diff(np.asarray(rt.clock.starts))
    return np.abs(periods - DT), rt.max_cycle_s, node.state.name


def bench_bare_loop(seconds: float) -> np.ndarray:
    """Jitter (s) of a bare 50 Hz loop sleeping to its deadlines: the peer of the runtime."""
    clock = time.monotonic
    start = clock()
    starts = []
    k = 0
    while True:
        now = clock()
        if now - start >= seconds:
            break
        starts.append(now)
        k += 1
        delay = start + k * DT - clock()
        if delay > 0:
            time.sleep(delay)
    return np.abs(np.diff(np.asarray(starts)) - DT)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its figures."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=60.0, help="real-time run length, s")
    p.add_argument("--steps", type=int, default=20000, help="timed step() calls")
    args = p.parse_args(argv)

    step, peer = bench_step(args.steps)
    print(f"step p50: {_pct(step, 50) * 1e6:.1f} us")
    print(f"step p99: {_pct(step, 99) * 1e6:.1f} us")
    print(
        f"peer cantools decode_message p50: {_pct(peer, 50) * 1e6:.1f} us, "
        f"p99: {_pct(peer, 99) * 1e6:.1f} us"
    )
    print(
        f"ratio step/decode_message: p50 {_pct(step, 50) / _pct(peer, 50):.2f}x, "
        f"p99 {_pct(step, 99) / _pct(peer, 99):.2f}x"
    )

    lock = bench_lockstep(max(1000, args.steps // 4))
    print(
        f"lockstep advance_to per cycle p50: {_pct(lock, 50) * 1e6:.1f} us, "
        f"p99: {_pct(lock, 99) * 1e6:.1f} us "
        f"({DT / _pct(lock, 50):.0f}x real time for the ECU side)"
    )

    jitter, max_cycle, state = bench_realtime(args.seconds)
    print(
        f"real time: {jitter.size + 1} cycles in {args.seconds:g} s, final state {state}, "
        f"max cycle time {max_cycle * 1e3:.3f} ms"
    )
    print(f"jitter p50: {_pct(jitter, 50) * 1e3:.3f} ms")
    print(f"jitter p99: {_pct(jitter, 99) * 1e3:.3f} ms")
    print(f"jitter max: {jitter.max() * 1e3:.3f} ms")
    bare_s = min(args.seconds, 10.0)
    bare = bench_bare_loop(bare_s)
    print(
        f"peer bare sleep loop ({bare_s:g} s) jitter p99: {_pct(bare, 99) * 1e3:.3f} ms; "
        f"ratio runtime/bare p99: {_pct(jitter, 99) / max(_pct(bare, 99), 1e-9):.2f}x"
    )
    ok = _pct(step, 99) <= 200e-6 and _pct(jitter, 99) <= 2e-3
    print(f"targets (step p99 <= 200 us, jitter p99 <= 2 ms): {'met' if ok else 'NOT met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
