"""The simulator's bus node on the python-can virtual bus, checked with the real codec."""

from __future__ import annotations

import itertools
from collections import Counter
from collections.abc import Iterator
from typing import Any

import can
import numpy as np
import pytest

from dbc.codec import load_codec
from dbc.e2e import E2EStatus
from dbc.endpoint import Inbox, Outbox
from dbc.frame import OTHER
from sim_bus.behaviour import COAST_MPS2
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.faults import parse_faults
from sim_bus.lead.profile import LeadProfile
from sim_bus.node import SimNode
from sim_bus.world import World, WorldConfig

_ids = itertools.count()


@pytest.fixture
def channel() -> str:
    return f"test-sim-node-{next(_ids)}"


@pytest.fixture
def buses(channel: str) -> Iterator[tuple[can.BusABC, can.BusABC]]:
    a = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    b = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    yield a, b
    a.shutdown()
    b.shutdown()


def _flat(v: float, seconds: float = 20.0) -> LeadProfile:
    n = int(seconds / 0.1) + 1
    return LeadProfile("flat", np.arange(n) * 0.1, np.full(n, v))


def _drain(bus: can.BusABC) -> list[can.Message]:
    out = []
    while (m := bus.recv(0.0)) is not None:
        out.append(m)
    return out


def test_frames_at_dbc_periods_with_valid_e2e(buses: tuple[can.BusABC, can.BusABC]) -> None:
    sim_bus, listener = buses
    codec = load_codec()
    world = World(BUILTIN_DRIVERS["d2"], _flat(20.0), seed=0)
    node = SimNode(sim_bus, world, codec=codec)
    for _ in range(100):  # 1 s
        node.step()
    frames = _drain(listener)
    inbox = Inbox(codec, ("ego", "pedals", "radar", "hmi"))
    roles: Counter[str] = Counter()
    for m in frames:
        d = inbox.accept(m.arbitration_id, m.data, m.timestamp)
        assert d is not None
        roles[d.role] += 1
    assert roles == {"ego": 100, "pedals": 100, "radar": 20, "hmi": 10}
    assert set(inbox.counts) == {(r, E2EStatus.OK) for r in roles}
    radar = [m for m in frames if m.arbitration_id == codec.by_role["radar"].frame_id]
    assert np.allclose(np.diff([m.timestamp for m in radar]), 0.05)
    last = inbox.latest("radar")
    assert last is not None and last["lead_valid"] == 1
    assert last["gap_m"] == pytest.approx(world.plant.gap_m, abs=1.0)
    hmi = inbox.latest("hmi")
    assert hmi is not None and hmi["main_switch"] == 1 and hmi["gap_setting"] == 2


def _command(outbox: Outbox, active: int, accel: float, state: int, t: float) -> can.Message:
    return outbox.pack(
        "command",
        {
            "accel_request_mps2": accel,
            "request_active": active,
            "acc_state": state,
            "takeover_request": 0,
        },
        timestamp=t,
    )


def test_request_applied_only_while_active_fresh_and_no_pedal(
    buses: tuple[can.BusABC, can.BusABC],
) -> None:
    sim_bus, ecu_bus = buses
    codec = load_codec()
    world = World(
        BUILTIN_DRIVERS["d2"], _flat(20.0), seed=0, cfg=WorldConfig(engage_s=100.0)
    )  # the driver never presses SET here
    node = SimNode(sim_bus, world, codec=codec)
    out = Outbox(codec)

    def run(seconds: float, active: int | None, accel: float, state: int = 2) -> None:
        for _ in range(int(round(seconds / 0.01))):
            if active is not None and node.tick % 2 == 0:
                ecu_bus.send(_command(out, active, accel, state, node.t_s))
            node.step()

    run(0.1, 1, -1.0)
    assert world.applied_mps2 == pytest.approx(-1.0)
    assert not (world.agent.accel_pressed or world.agent.brake_pressed)
    run(0.1, 0, -1.0)
    assert world.applied_mps2 == pytest.approx(COAST_MPS2)
    run(0.1, 1, 0.5)
    assert world.applied_mps2 == pytest.approx(0.5)
    run(0.15, None, 0.0)  # the ECU goes silent: the last request goes stale
    assert node.command_now(node.t_s)[:1] == (False,)
    assert node.command_now(node.t_s)[2] == 0  # the driver no longer sees an engaged ACC
    agent = world.agent
    assert agent.accel_pressed or agent.brake_pressed  # so it drives by hand
    assert world.applied_mps2 == agent.a_cmd_mps2 != 0.5
    run(0.1, 0, 0.0, state=1)  # ACC back in standby, request inactive
    # corrupted command frames are never acted on
    msg = _command(out, 1, -3.0, 2, node.t_s)
    msg.data = bytearray(msg.data)
    msg.data[2] ^= 0x40
    ecu_bus.send(msg)
    node.step()
    assert node.command_now(node.t_s)[:2] == (False, 0.0)
    assert world.applied_mps2 != -3.0
    assert node.inbox.errors().get(E2EStatus.WRONG_CRC.value) == 1


def test_pedal_press_overrides_the_request(buses: tuple[can.BusABC, can.BusABC]) -> None:
    sim_bus, ecu_bus = buses
    codec = load_codec()
    world = World(
        BUILTIN_DRIVERS["d1"], _flat(20.0), seed=0, cfg=WorldConfig(initial_gap_factor=0.4)
    )  # far too close: the driver brakes
    node = SimNode(sim_bus, world, codec=codec)
    out = Outbox(codec)
    braked = False
    for _ in range(300):
        if node.tick % 2 == 0:
            ecu_bus.send(_command(out, 1, 1.0, 2, node.t_s))
        node.step()
        if world.agent.brake_pressed:
            braked = True
            assert world.applied_mps2 == world.agent.a_cmd_mps2 < 0.0
    assert braked


def test_faults_silence_drop_crc_counter(buses: tuple[can.BusABC, can.BusABC]) -> None:
    sim_bus, listener = buses
    codec = load_codec()
    world = World(BUILTIN_DRIVERS["d2"], _flat(20.0), seed=0)
    spec = parse_faults("radar:dropout=0.5-1.0;ego:crc=0.2;pedals:counter=0.2;hmi:drop=0.5")
    node = SimNode(sim_bus, world, codec=codec, faults=spec, rng=np.random.default_rng(1))
    for _ in range(200):
        node.step()
    inbox = Inbox(codec, ("ego", "pedals", "radar", "hmi"))
    radar_t = []
    for m in _drain(listener):
        d = inbox.accept(m.arbitration_id, m.data, m.timestamp)
        if d is not None and d.role == "radar":
            radar_t.append(m.timestamp)
    assert len(radar_t) == 30 and not any(0.5 <= t < 1.0 for t in radar_t)
    crc_bad = inbox.counts[("ego", E2EStatus.WRONG_CRC)]
    assert 20 <= crc_bad <= 60
    assert sum(n for (r, _), n in inbox.counts.items() if r == "ego") == 200
    assert inbox.counts[("pedals", E2EStatus.REPEATED)] >= 20
    hmi_seen = sum(n for (r, _), n in inbox.counts.items() if r == "hmi")
    assert 3 <= hmi_seen <= 17


def test_delay_and_freeze(buses: tuple[can.BusABC, can.BusABC]) -> None:
    sim_bus, listener = buses
    codec = load_codec()
    prof = LeadProfile("ramp", np.arange(201) * 0.1, np.linspace(10.0, 20.0, 201))
    world = World(BUILTIN_DRIVERS["d2"], prof, seed=0)
    spec = parse_faults("ego:delay=0.05;radar:freeze=0.5-1.5")
    node = SimNode(sim_bus, world, codec=codec, faults=spec)
    for _ in range(200):
        node.step()
    inbox = Inbox(codec, ("ego", "radar"))
    ego_first = None
    gaps = []
    for m in _drain(listener):
        d = inbox.accept(m.arbitration_id, m.data, m.timestamp)
        if d is None:
            continue
        if d.role == "ego" and ego_first is None:
            ego_first = m.timestamp
        if d.role == "radar" and 0.5 <= m.timestamp < 1.5:
            gaps.append(d.values["rel_speed_mps"])
    assert ego_first == pytest.approx(0.05)
    assert len(gaps) == 20 and len(set(gaps)) == 1  # frozen values, valid E2E


@pytest.mark.parametrize("interface", ["virtual", "lockstep"])
def test_a_bus_that_refuses_frames_does_not_stop_the_simulation(
    channel: str, interface: str
) -> None:
    """A send error (a full queue on a real bus; here a closed bus) loses frames, no more:
    through the edge adapter (the virtual bus) and the lockstep bus's own port alike."""
    bus = can.Bus(interface=interface, channel=channel)
    world = World(BUILTIN_DRIVERS["d2"], _flat(20.0), seed=0)
    node = SimNode(bus, world)
    for _ in range(50):
        node.step()
    sent = node.frames_sent
    assert sent > 0 and node.send_errors == 0
    peer = can.Bus(interface=interface, channel=channel)
    peer.send(_command(Outbox(load_codec()), 1, -1.0, 2, node.t_s))  # waiting in the queue
    peer.shutdown()
    bus.shutdown()  # from now on every send and receive raises can.CanOperationError
    for _ in range(50):
        node.step()
    assert node.recv_errors >= 1 and node.commands_ok == 0
    assert node.frames_sent == sent
    assert node.send_errors == 50 + 50 + 10 + 5  # ESC, PEDAL every tick, RADAR, HMI
    assert world.tick == 100 and world.plant.v_mps > 0.0


def test_faulty_frames_refused_are_counted_too(channel: str) -> None:
    bus = can.Bus(interface="lockstep", channel=channel)
    world = World(BUILTIN_DRIVERS["d2"], _flat(20.0), seed=0)
    node = SimNode(bus, world, faults=parse_faults("radar:crc=0.5"))
    bus.shutdown()
    for _ in range(10):
        node.step()
    assert node.frames_sent == 0 and node.send_errors == 10 + 10 + 2 + 1


def test_on_the_lockstep_bus_no_received_frame_aliases_a_later_one() -> None:
    """The simulator puts a frame per message on the lockstep bus (no copy): a frame
    received earlier keeps its payload and timestamp while later frames go out."""
    channel = f"test-sim-handover-{next(_ids)}"
    sim_bus = can.Bus(interface="lockstep", channel=channel)
    listener = can.Bus(interface="lockstep", channel=channel)
    try:
        world = World(BUILTIN_DRIVERS["d2"], _flat(20.0), seed=0)
        node = SimNode(sim_bus, world, codec=load_codec())
        node.step()
        first = _drain(listener)
        kept = [(m.timestamp, bytes(m.data)) for m in first]
        for _ in range(20):
            node.step()
        later = _drain(listener)
        assert [(m.timestamp, bytes(m.data)) for m in first] == kept
        assert not {id(m) for m in first} & {id(m) for m in later}
        assert {id(m.data) for m in later}.isdisjoint(id(m.data) for m in first)
        assert all(m.is_rx and m.timestamp == 0.0 for m in first)
    finally:
        sim_bus.shutdown()
        listener.shutdown()


@pytest.mark.parametrize("interface", ["virtual", "lockstep"])
def test_the_tap_sees_every_frame_in_and_out(channel: str, interface: str) -> None:
    """The tap gets (time, key, payload, received) of every frame sent and received, an
    error frame as (time, OTHER, message), on any bus."""
    bus = can.Bus(interface=interface, channel=channel, preserve_timestamps=True)
    peer = can.Bus(interface=interface, channel=channel, preserve_timestamps=True)
    try:
        codec = load_codec()
        node = SimNode(bus, World(BUILTIN_DRIVERS["d2"], _flat(20.0), seed=0), codec=codec)
        seen: list[tuple[float, int, Any, bool]] = []
        node.tap = lambda t, key, data, rx: seen.append((t, key, data, rx))
        peer.send(_command(Outbox(codec), 1, -1.0, 2, 0.0))
        peer.send(can.Message(is_error_frame=True))
        for _ in range(10):
            node.step()
        received = [f for f in seen if f[3]]
        cmd = codec.by_role["command"]
        assert [f[1] for f in received] == [cmd.frame_id, OTHER]
        assert received[1][2].is_error_frame and node.commands_ok == 1
        sent = [f for f in seen if not f[3]]
        assert len(sent) == node.frames_sent == 10 + 10 + 2 + 1
        listened = _drain(peer)
        assert [(m.timestamp, m.arbitration_id, bytes(m.data)) for m in listened] == [
            (t, key, data) for t, key, data, _ in sent
        ]
    finally:
        bus.shutdown()
        peer.shutdown()
