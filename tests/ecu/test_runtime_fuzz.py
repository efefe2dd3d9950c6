"""Property: arbitrary peer traffic on a real virtual bus never breaks the ECU's output contract.

Hypothesis drives ESC/PEDAL/RADAR/HMI through :class:`tests.peers.PeerNodes` with values anywhere
in their DBC ranges, muted roles, corrupted CRCs, frozen alive counters and raw garbage frames,
into an :class:`ecu.runtime.EcuRuntime` in lockstep. A third bus listens; every ACC_Command
frame is decoded back with the codec and checked: E2E intact (CRC, counter +1), acceleration
inside the envelope, jerk limited (the emergency exception only decreases), request active
only in ACTIVE or during the FAULT ramp toward zero, takeover request exactly in FAULT. The
HMI also switches driver profiles: a far table (a swap while ACTIVE), a corrupt one, none.
"""

from __future__ import annotations

import atexit
import itertools
import shutil
import tempfile
from pathlib import Path
from typing import Any

import can
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import predefined
from dbc.vocab.dgpt_file import save_dgpt
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from tests.peers import PeerNodes

CODEC = load_codec()
_ids = itertools.count()
PROFILES = Path(tempfile.mkdtemp(prefix="pacc-fuzz-profiles-"))
atexit.register(shutil.rmtree, PROFILES, ignore_errors=True)
save_dgpt(predefined(4.0, driver_id="far"), PROFILES / "profile_1.json")  # a table swap
(PROFILES / "profile_2.json").write_text('{"format": "pacc.dgpt/1", "gap_m": [1e999]}')
LSB = 0.01  # AccelRequest resolution, m/s^2
DT = 0.02

ROLES = ("ego", "pedals", "radar", "hmi")
modes = st.sampled_from(["ok"] * 6 + ["mute", "corrupt", "freeze", "garbage"])
ego = st.fixed_dictionaries(
    {
        "speed_mps": st.floats(0.0, 90.0),
        "accel_mps2": st.floats(-20.0, 20.0),
        "speed_valid": st.sampled_from([1, 1, 1, 0]),
    }
)
pedals = st.fixed_dictionaries(
    {
        "accel_pedal_pct": st.floats(0.0, 100.0),
        "accel_pressed": st.sampled_from([0, 0, 0, 1]),
        "brake_pressed": st.sampled_from([0, 0, 0, 1]),
        "brake_pressure_bar": st.floats(0.0, 250.0),
    }
)
radar = st.fixed_dictionaries(
    {
        "lead_valid": st.sampled_from([1, 1, 0]),
        "gap_m": st.floats(0.0, 250.0),
        "rel_speed_mps": st.floats(-50.0, 50.0),
        "lead_accel_mps2": st.floats(-15.0, 15.0),
        "lead_accel_valid": st.integers(0, 1),
    }
)
hmi = st.fixed_dictionaries(
    {
        "main_switch": st.sampled_from([1, 1, 1, 0]),
        "set": st.sampled_from([0, 0, 1]),
        "resume": st.sampled_from([0, 0, 0, 1]),
        "cancel": st.sampled_from([0, 0, 0, 0, 1]),
        "profile_id": st.sampled_from([0, 0, 1, 2, 3]),  # 1 far table, 2 corrupt, 3 missing
    }
)
phase = st.tuples(
    st.fixed_dictionaries({"ego": ego, "pedals": pedals, "radar": radar, "hmi": hmi}),
    st.fixed_dictionaries({r: modes for r in ROLES}),
    st.integers(1, 120),  # 10 ms ticks
)


def _check_commands(cmds: list[tuple[dict[str, Any], bool]]) -> None:
    """``cmds``: decoded ACC_Command values with the node's emergency flag of that cycle."""
    prev_a, prev_active, prev_state = 0.0, False, AccState.OFF
    for values, emergency in cmds:
        a = values["accel_request_mps2"]
        state = AccState(values["acc_state"])
        active = bool(values["request_active"])
        assert -3.5 <= a <= 2.0
        assert a - prev_a <= 2.5 * DT + LSB + 1e-9
        assert prev_a - a <= (10.0 if emergency else 2.5) * DT + LSB + 1e-9
        if emergency:  # braking while ACTIVE, or an override's inactive preparation (docs/ecu.md)
            assert a <= prev_a + 1e-9
            assert state is AccState.ACTIVE or (state is AccState.OVERRIDE and not active)
        if state is AccState.FAULT:
            assert values["takeover_request"]
        elif values["takeover_request"]:  # engaged at the ACC's braking limit (docs/ecu.md)
            assert state in (AccState.ACTIVE, AccState.OVERRIDE)
        if active and state is not AccState.ACTIVE:
            assert state is AccState.FAULT  # the ramp of an executed request
            assert prev_active and prev_state in (AccState.ACTIVE, AccState.FAULT)
            assert abs(a) <= abs(prev_a) and a * prev_a >= 0.0
        prev_a, prev_active, prev_state = a, active, state


def _inject(peers: PeerNodes, role_modes: dict[str, str], t: float) -> None:
    """This tick's faults: corrupted CRCs, frozen counters, garbage frames."""
    for role in ROLES:
        mode = role_modes.get(role, "ok")
        if mode == "corrupt":
            peers.corrupt(role)
        elif mode == "freeze":
            peers.outbox.counters[role] = 7
    if "garbage" in role_modes.values():
        peers.send_garbage(t)


def _read_commands(listener: can.BusABC, counters: list[int]) -> list[dict[str, Any]]:
    """The ACC_Command frames waiting on ``listener``, decoded (CRC checked); their alive
    counters are appended to ``counters``."""
    got = []
    while (msg := listener.recv(0)) is not None:
        mc = CODEC.by_id.get(msg.arbitration_id)
        if mc is not None and mc.role == "command":
            decoded = mc.decode(msg.data)
            got.append(decoded.values)
            assert decoded.counter is not None
            counters.append(decoded.counter)
    return got


@pytest.mark.slow
@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(
    phases=st.lists(phase, min_size=1, max_size=8),
    brake_mode=st.sampled_from(["resume", "cancel"]),
    set_speed=st.sampled_from([None, 30.0]),
)
def test_arbitrary_traffic_keeps_the_command_contract(
    phases: list[tuple[dict[str, dict[str, Any]], dict[str, str], int]],
    brake_mode: str,
    set_speed: float | None,
) -> None:
    channel = f"ecu-fuzz-{next(_ids)}"
    ecu_bus, peer_bus, listener = (can.Bus(interface="virtual", channel=channel) for _ in "abc")
    try:
        node = EcuNode(
            EcuConfig(brake_mode=brake_mode, set_speed_mps=set_speed),  # type: ignore[arg-type]
            predefined(1.5),
        )
        rt = EcuRuntime(ecu_bus, node, CODEC, profile_dir=PROFILES)
        peers = PeerNodes(peer_bus, CODEC)
        peers.set("radar", gap_m=30.0)
        # engage first (valid inputs for 1.2 s, SET), then the arbitrary phases
        script: list[tuple[dict[str, dict[str, Any]], dict[str, str], int]] = [
            ({}, {}, 120),
            ({"hmi": {"set": 1}}, {}, 20),
            ({"hmi": {"set": 0}}, {}, 30),
        ]
        script += phases
        cmds: list[tuple[dict[str, Any], bool]] = []
        counters: list[int] = []
        t, k = 0.0, 0
        for values, role_modes, ticks in script:
            for role, v in values.items():
                peers.set(role, **v)
            for role in ROLES:
                peers.mute(role, role_modes.get(role) == "mute")
            for _ in range(ticks):
                k += 1
                t = k * 0.01
                _inject(peers, role_modes, t)
                peers.send_due(t)
                cycles = rt.cycles
                rt.advance_to(t)
                ran = rt.cycles - cycles
                got = _read_commands(listener, counters)
                assert len(got) == ran <= 1
                if got:
                    assert rt.last_outputs is not None
                    cmds.append((got[0], rt.last_outputs.emergency))
        assert all((b - a) % 16 == 1 for a, b in itertools.pairwise(counters))
        assert rt.io.send_errors == 0
        assert rt.summary().safety_stops == {}  # a correct controller never trips the check
        _check_commands(cmds)
        event(f"states seen: {sorted({c['acc_state'] for c, _ in cmds})}")
        event(f"final table: {node.table.driver_id}")
    finally:
        for bus in (ecu_bus, peer_bus, listener):
            bus.shutdown()
