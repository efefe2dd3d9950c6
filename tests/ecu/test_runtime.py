"""The ECU on a real python-can virtual bus, with ESC/PEDAL/RADAR/HMI played from the DBC."""

from __future__ import annotations

import dataclasses
import itertools
import json
import os
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
import pytest

from dbc import DBC_PATH
from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import predefined
from dbc.vocab.dgpt_file import save_dgpt
from dbc.vocab.triplog import Trip
from ecu.adaptation import AdaptationParams
from ecu.busio import RuntimeCodecError
from ecu.clocks import RuntimeClockError
from ecu.config import ConfigError, EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from ecu.signals import NodeInputs
from tests.peers import PeerNodes

_ids = itertools.count()
CODEC = load_codec()
JERK_STEP = 2.5 * 0.02 + 0.01 + 1e-9  # per 20 ms frame, plus the DBC's 0.01 m/s^2 resolution


class Bench:
    """ECU runtime + scripted peers + a listener, on one private virtual channel, lockstep."""

    def __init__(
        self,
        config: EcuConfig | None = None,
        headway_s: float = 1.5,
        profile_dir: Path | None = None,
    ) -> None:
        channel = f"ecu-test-{next(_ids)}"
        self.buses = [can.Bus(interface="virtual", channel=channel) for _ in range(3)]
        ecu_bus, peer_bus, self.listener = self.buses
        self.node = EcuNode(config or EcuConfig(set_speed_mps=30.0), predefined(headway_s))
        self.events: list[str] = []
        self.rt = EcuRuntime(
            ecu_bus, self.node, CODEC, on_event=self.events.append, profile_dir=profile_dir
        )
        self.peers = PeerNodes(peer_bus, CODEC)
        self.t = 0.0
        self.k = 0
        self.commands: list[dict[str, Any]] = []
        self.statuses: list[dict[str, Any]] = []
        self.plant = False
        self.state: tuple[float, float] | None = None  # plant (v m/s, gap m)
        self.v_lead = 20.0

    def close(self) -> None:
        for bus in self.buses:
            bus.shutdown()

    def run(self, seconds: float, settle: bool = True, **hmi: int) -> list[float]:
        """Advance ``seconds`` in 10 ms steps; HMI fields held at ``hmi`` meanwhile. With
        ``settle`` a profile load started by a step ends before the next step (a lockstep
        bench outruns the load's worker thread). The wall time of each step, s."""
        self.peers.set("hmi", **{"set": 0, "resume": 0, "cancel": 0, **hmi})
        spent = []
        for _ in range(int(round(seconds / 0.01))):
            self.k += 1
            self.t = self.k * 0.01
            self.peers.send_due(self.t)
            t0 = time.perf_counter()
            self.rt.advance_to(self.t)
            spent.append(time.perf_counter() - t0)
            loading = getattr(self.rt.profiles, "loading", None)
            if settle and loading is not None:
                loading.join(5.0)
            self._listen()
            if self.plant:
                self._plant_step(0.01)
        return spent

    def _listen(self) -> None:
        while (msg := self.listener.recv(0)) is not None:
            mc = CODEC.by_id.get(msg.arbitration_id)
            if mc is None or mc.role not in ("command", "status"):
                continue
            d = mc.decode(msg.data)
            (self.commands if d.role == "command" else self.statuses).append(d.values)

    def _plant_step(self, dt: float) -> None:
        """Ego executes the active request; true state in floats, frames carry it rounded."""
        if self.state is None:
            self.state = (
                self.peers.values["ego"]["speed_mps"],
                self.peers.values["radar"]["gap_m"],
            )
        v, gap = self.state
        cmd = self.commands[-1] if self.commands else None
        a = cmd["accel_request_mps2"] if cmd and cmd["request_active"] else 0.0
        v = max(v + a * dt, 0.0)
        gap += (self.v_lead - v) * dt
        self.state = (v, gap)
        self.peers.set("ego", speed_mps=round(v, 2), accel_mps2=round(a, 2))
        self.peers.set("radar", gap_m=round(gap, 2), rel_speed_mps=round(self.v_lead - v, 2))

    def engage(self) -> None:
        self.run(1.2)
        self.run(0.2, set=1)
        self.run(0.1)
        assert self.commands[-1]["acc_state"] == 2


@pytest.fixture
def bench() -> Iterator[Bench]:
    b = Bench()
    yield b
    b.close()


def test_engage_and_frames(bench: Bench) -> None:
    bench.peers.set("radar", gap_m=60.0)
    bench.run(1.0)
    assert {c["acc_state"] for c in bench.commands} == {1}
    assert not any(c["request_active"] for c in bench.commands)
    bench.engage()
    bench.run(1.0)
    cmds = bench.commands
    assert len(cmds) == bench.rt.cycles == 175  # t = 0.01 .. 3.49 s at 50 Hz
    assert len(bench.statuses) == 35  # every 5th cycle
    active = [c for c in cmds if c["acc_state"] == 2]
    assert all(c["request_active"] for c in active)
    # gap 60 m > DGPT(20) = 34 m: accelerate, ramping at the jerk limit
    accels = [c["accel_request_mps2"] for c in active]
    assert accels[-1] > 0.5
    assert all(0.0 <= b - a <= JERK_STEP for a, b in itertools.pairwise(accels))
    st = bench.statuses[-1]
    assert st["desired_gap_m"] == pytest.approx(34.0, abs=0.05)
    assert st["dgpt_version"] == 0 and st["fault_code"] == 0
    assert st["set_speed_mps"] == pytest.approx(30.0)
    assert any("STANDBY -> ACTIVE" in e for e in bench.events)
    summary = bench.rt.summary()
    assert summary.e2e_errors == {}
    assert summary.safety_stops == {} and "safety stops:   none" in str(summary)
    assert summary.frames_out == len(cmds) + len(bench.statuses)
    assert "cycles:" in str(summary)


def test_follow_closed_loop_on_the_bus(bench: Bench) -> None:
    bench.plant = True
    bench.peers.set("radar", gap_m=50.0)
    bench.engage()
    bench.run(60.0)
    gap = bench.peers.values["radar"]["gap_m"]
    assert abs(gap - 34.0) <= 0.1 * 34.0 + 0.5
    assert bench.node.state.name == "ACTIVE"


@pytest.fixture
def paper_bench() -> Iterator[Bench]:
    """Algorithm 1's local window (the paper mode)."""
    b = Bench(EcuConfig(set_speed_mps=30.0, adaptation_params=AdaptationParams(mode="paper")))
    yield b
    b.close()


def test_accelerator_override_and_resume(paper_bench: Bench) -> None:
    bench = paper_bench
    bench.peers.set("radar", gap_m=25.0)  # shorter than the table's 34 m: the driver wants it
    bench.engage()
    bench.peers.set("pedals", accel_pressed=1, accel_pedal_pct=30.0)
    bench.run(2.0)
    assert bench.commands[-1]["acc_state"] == 3 and bench.commands[-1]["request_active"] == 0
    bench.peers.set("pedals", accel_pressed=0, accel_pedal_pct=0.0)
    bench.run(0.2)
    assert bench.commands[-1]["acc_state"] == 2 and bench.commands[-1]["request_active"] == 1
    s = bench.rt.summary()
    assert s.takeovers == 1 and s.adaptations == 1 and s.dgpt_version == 1
    # v = v_f at release: the table now holds the 25 m gap at 20 m/s
    assert bench.statuses[-1]["desired_gap_m"] == pytest.approx(25.0, abs=0.05)
    assert bench.statuses[-1]["adaptation_count"] == 1


@pytest.mark.parametrize(("mode", "during", "after"), [("resume", 3, 2), ("cancel", 1, 1)])
def test_brake(mode: str, during: int, after: int) -> None:
    b = Bench(EcuConfig(brake_mode=mode, set_speed_mps=30.0))  # type: ignore[arg-type]
    try:
        b.peers.set("radar", gap_m=30.0)
        b.engage()
        b.peers.set("pedals", brake_pressed=1, brake_pressure_bar=20.0)
        b.run(1.5)
        assert b.commands[-1]["acc_state"] == during and b.commands[-1]["request_active"] == 0
        b.peers.set("pedals", brake_pressed=0, brake_pressure_bar=0.0)
        b.run(0.2)
        assert b.commands[-1]["acc_state"] == after
        assert b.rt.summary().takeovers == 1
    finally:
        b.close()


def test_radar_timeout_faults_with_ramp(bench: Bench) -> None:
    bench.peers.set("radar", gap_m=20.0, rel_speed_mps=-2.0)  # close and closing: brake
    bench.engage()
    bench.run(1.5)
    assert bench.commands[-1]["accel_request_mps2"] < -1.0
    n0 = len(bench.commands)
    bench.peers.mute("radar")
    bench.run(2.0)
    after = bench.commands[n0:]
    fault_at = next(i for i, c in enumerate(after) if c["acc_state"] == 4)
    # 10 radar periods = 0.5 s, +-1 period
    assert 22 <= fault_at <= 28
    ramp = after[fault_at:]
    assert all(c["takeover_request"] == 1 for c in ramp)
    active = [c["accel_request_mps2"] for c in ramp if c["request_active"]]
    assert len(active) >= 20  # from below -1 m/s^2 at 0.05 per frame
    assert all(0.0 <= b - a <= JERK_STEP for a, b in itertools.pairwise(active))
    assert ramp[-1]["request_active"] == 0 and ramp[-1]["accel_request_mps2"] == 0.0
    assert bench.statuses[-1]["fault_code"] == 3
    assert any("RADAR_INPUT" in e for e in bench.events)
    assert bench.rt.summary().faults == {"RADAR_INPUT": 1}
    assert bench.rt.summary().safety_stops == {}  # the fault ramp is lawful
    assert "faults:         RADAR_INPUT 1" in str(bench.rt.summary())
    # radar back: SET is refused until inputs have been valid for 1 s
    bench.peers.mute("radar", False)
    bench.run(0.5)
    bench.run(0.2, set=1)
    assert bench.commands[-1]["acc_state"] == 4
    bench.run(1.0)
    bench.run(0.2, set=1)
    assert bench.commands[-1]["acc_state"] == 2


def test_bad_crc_frames_dropped_and_counted(bench: Bench) -> None:
    bench.engage()
    bench.peers.corrupt("radar", 3)
    bench.peers.corrupt("ego", 2)
    bench.run(0.5)
    errors = bench.rt.summary().e2e_errors
    assert errors.get("wrong_crc") == 5
    assert bench.node.state.name == "ACTIVE"
    assert bench.rt.io.inbox.fresh("radar", bench.t)


def test_garbage_frames_ignored(bench: Bench) -> None:
    bench.engage()
    for _ in range(4):
        bench.peers.send_garbage()
        bench.run(0.05)
    errors = bench.rt.summary().e2e_errors
    assert errors.get("unknown_id") == 4
    assert errors.get("wrong_dlc") == 4
    assert errors.get("wrong_crc") == 4
    assert bench.node.state.name == "ACTIVE"
    assert all(c["acc_state"] == 2 for c in bench.commands[-10:])


def test_realtime_mode_runs_and_stops() -> None:
    """0.25 s at 50 Hz: never more cycles than the grid holds, never a cycle before its
    deadline, and the run ends on time. (How many cycles run depends on the machine's load:
    an overrun skips cycles instead of bursting them.)"""
    b = Bench()
    try:
        t0 = time.monotonic()
        b.rt.run_realtime(0.25)
        took = time.monotonic() - t0
        assert 0.25 <= took < 5.0
        assert b.rt.cycles >= 1 and b.rt.cycles + b.rt.clock.skipped <= 14
        starts = list(b.rt.clock.starts)
        assert len(starts) == b.rt.cycles
        assert all(s - starts[0] >= i * 0.02 - 1e-6 for i, s in enumerate(starts))
        assert b.node.state.name == "OFF"  # no HMI on the bus
        assert b.rt.summary().max_cycle_s > 0.0
    finally:
        b.close()


def test_stop_before_the_run_is_not_lost() -> None:
    """stop() (a SIGTERM handler, another thread) just before run_realtime starts must still
    end the run, and a later run works again."""
    b = Bench()
    try:
        b.rt.stop()
        t0 = time.monotonic()
        b.rt.run_realtime(3.0)
        assert time.monotonic() - t0 < 2.0 and b.rt.cycles <= 1
        before = b.rt.cycles
        b.rt.run_realtime(0.3)  # the stop was consumed: this run runs
        assert b.rt.cycles > before
    finally:
        b.close()


def test_bad_clock_rejected_and_jumps_skipped(bench: Bench) -> None:
    with pytest.raises(RuntimeClockError):
        bench.rt.advance_to(float("nan"))
    with pytest.raises(RuntimeClockError):
        bench.rt.run_realtime(float("nan"))
    bench.run(1.0)
    cycles = bench.rt.cycles
    bench.rt.advance_to(1.0 + 3600.0)  # an hour in one call: no hour of replay
    assert bench.rt.cycles - cycles <= 2
    assert bench.rt.summary().skipped_cycles > 179_000
    bench.rt.advance_to(3601.5)
    assert bench.rt.cycles - cycles <= 30


@pytest.mark.parametrize("bad", [1e308, -1e308])
def test_time_beyond_the_cycle_grid_is_a_clock_error(bench: Bench, bad: float) -> None:
    """A finite time so far from the first call that the 20 ms grid overflows is a host bug
    like NaN: RuntimeClockError, nothing consumed; the runtime then carries on."""
    bench.run(0.5)
    cycles = bench.rt.cycles
    with pytest.raises(RuntimeClockError):
        bench.rt.advance_to(bad)
    assert bench.rt.cycles == cycles
    bench.run(0.5)
    assert bench.rt.cycles == cycles + 25


def test_driver_profile_switch_keeps_last_good_table(tmp_path: Path) -> None:
    save_dgpt(predefined(3.0, driver_id="d3"), tmp_path / "profile_3.json")
    bad = predefined(2.0).to_json_dict()
    bad["gap_m"][40] = 500.0  # outside the safety bounds at 20 m/s
    (tmp_path / "profile_4.json").write_text(json.dumps(bad))
    b = Bench(profile_dir=tmp_path)
    try:
        b.run(0.5)
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(34.0, abs=0.05)
        b.run(0.5, profile_id=3)
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(64.0, abs=0.05)
        assert b.node.table.driver_id == "d3"
        b.run(0.5, profile_id=4)
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(64.0, abs=0.05)
        assert b.statuses[-1]["fault_code"] == 5
        assert any("profile 4 refused" in e and "outside the safety bounds" in e for e in b.events)
        b.run(0.5, profile_id=7)  # no such file: keep the table
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(64.0, abs=0.05)
        b.run(0.5, profile_id=0)
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(34.0, abs=0.05)
        assert b.statuses[-1]["fault_code"] == 0
    finally:
        b.close()


def test_frozen_esc_sender_faults(bench: Bench) -> None:
    """ESC stuck repeating one frame (its alive counter frozen): the speed input times out
    and the ECU goes to FAULT, although a frame keeps arriving every 10 ms."""
    bench.peers.set("radar", gap_m=40.0)
    bench.engage()
    for _ in range(60):
        bench.peers.outbox.counters["ego"] = 5  # the sender re-sends counter 5 forever
        bench.run(0.01)
    assert bench.node.state.name == "FAULT"
    assert bench.node.faults and all(f.name == "SPEED_INPUT" for f in bench.node.faults)
    assert bench.commands[-1]["takeover_request"] == 1
    assert bench.rt.summary().e2e_errors["repeated_counter"] >= 50


def test_corrupt_profile_file_is_refused_in_the_loop(tmp_path: Path) -> None:
    """Profiles a disk or a download can corrupt: binary bytes, a number beyond float range.
    The cycle goes on with the last good table and reports FaultCode Profile."""
    (tmp_path / "profile_1.json").write_bytes(b"\xff\xfe\x00\x80garbage")
    text = json.dumps(predefined(2.0).to_json_dict()).replace(
        '"gap_m": [4.0', '"gap_m": [1' + "0" * 400
    )
    (tmp_path / "profile_2.json").write_text(text)
    b = Bench(profile_dir=tmp_path)
    try:
        for pid in (1, 2):
            b.run(0.5, profile_id=pid)
            assert b.statuses[-1]["fault_code"] == 5
            assert b.statuses[-1]["desired_gap_m"] == pytest.approx(34.0, abs=0.05)
            assert any(f"profile {pid} refused" in e for e in b.events)
        assert b.rt.cycles == 50
    finally:
        b.close()


def test_unusable_profile_directory_does_not_stop_the_loop(tmp_path: Path) -> None:
    """Looking a profile up can fail with an OSError other than 'missing' (here a name too
    long for the file system; EACCES alike): the profile is refused, the cycle goes on."""
    b = Bench(profile_dir=tmp_path / ("x" * 300))
    try:
        b.run(0.5, profile_id=2)
        assert b.rt.cycles == 25
        assert b.statuses[-1]["fault_code"] == 5
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(34.0, abs=0.05)
        assert any("profile 2 refused" in e for e in b.events)
    finally:
        b.close()


def _hostile_profile(kind: str, path: Path) -> None:
    if kind == "fifo":  # a reader of a FIFO blocks until a writer comes: one comes after 1 s
        os.mkfifo(path)

        def write() -> None:
            try:
                fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)  # ENXIO: nobody reads
            except OSError:
                return
            os.write(fd, b"{}")
            os.close(fd)

        threading.Timer(1.0, write).start()
    elif kind == "huge":
        with path.open("wb") as fh:
            fh.truncate(150 * 2**20)  # 150 MB (sparse)
    else:
        path.symlink_to("/dev/zero")


@pytest.mark.parametrize("kind", ["fifo", "huge", "dev-zero"])
def test_a_hostile_profile_never_stalls_the_command_frames(tmp_path: Path, kind: str) -> None:
    """A profile that is a FIFO, a 150 MB file or /dev/zero, selected while ACTIVE: every
    cycle runs on time on the current table (no step longer than two command periods), the
    profile is refused with FaultCode Profile, and the ACC stays ACTIVE."""
    _hostile_profile(kind, tmp_path / "profile_1.json")
    b = Bench(profile_dir=tmp_path)
    try:
        b.peers.set("radar", gap_m=40.0)
        b.engage()
        n = len(b.commands)
        spent = b.run(1.5, settle=False, profile_id=1)
        assert max(spent) < 0.040
        assert len(b.commands) - n == 75
        loading = b.rt.profiles.loading if b.rt.profiles is not None else None
        if loading is not None:  # the lockstep steps may outrun the load: let it end
            loading.join(5.0)
        b.run(0.2, profile_id=1)
        assert b.node.state is AccState.ACTIVE
        assert b.statuses[-1]["fault_code"] == 5
        assert any("profile 1 refused" in e for e in b.events)
    finally:
        b.close()


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("SG_ AccState : 32|3@1+ (1,0) [0|4]", "SG_ AccState : 32|2@1+ (1,0) [0|3]"), "FAULT"),
        (('(0.01,0) [-10|5] "m/s^2" PT', '(0.01,0) [-2|5] "m/s^2" PT'), "-3.5"),
        (("SG_ FaultCode : 12|4@1+ (1,0) [0|15]", "SG_ FaultCode : 12|4@1+ (1,0) [0|3]"), "5"),
        (
            ("SG_ SetSpeed : 56|8@1+ (0.25,0) [0|63.75]", "SG_ SetSpeed : 56|8@1+ (0.2,0) [0|40]"),
            "50",
        ),
    ],
    ids=[
        "acc-state-without-fault",
        "accel-range-narrower-than-envelope",
        "fault-code-range",
        "set-speed-below-max-set-speed",
    ],
)
def test_dbc_that_cannot_carry_the_outputs_is_refused(
    tmp_path: Path, edit: tuple[str, str], message: str
) -> None:
    """A DBC that loads but cannot carry every output (AccState FAULT, the full acceleration
    envelope, every FaultCode) would silence ACC_Command in FAULT or cut braking authority:
    the runtime refuses it when built, with an error naming the signal."""
    text = DBC_PATH.read_text()
    assert edit[0] in text
    path = tmp_path / "narrow.dbc"
    path.write_text(text.replace(edit[0], edit[1]))
    codec = load_codec(path)
    with (
        can.Bus(interface="virtual", channel=f"ecu-test-{next(_ids)}") as bus,
        pytest.raises(RuntimeCodecError, match=message),
    ):
        EcuRuntime(bus, EcuNode(EcuConfig(), predefined(1.5)), codec)


# -- one pedal, one value: the DBC's full scale ------------------------------------------------


def test_brake_pressure_is_a_fraction_of_the_dbc_full_scale(bench: Bench) -> None:
    """The brake pedal is the pressure over the DBC's full scale (250 bar), the scale the
    simulator's trip logs use: 125 bar is half the pedal, not 1.25 clipped to 1."""
    full = CODEC.by_role["pedals"].bounds("brake_pressure_bar")[1]
    assert full == 250.0
    bench.peers.set("pedals", brake_pressed=1, brake_pressure_bar=75.0, accel_pedal_pct=40.0)
    bench.run(0.1)
    inputs = bench.rt.io.read_inputs(bench.t)
    assert inputs.pedals_ok
    assert inputs.brake_pedal == pytest.approx(75.0 / full)
    assert inputs.accel_pedal == pytest.approx(0.4)


def test_recorded_takeover_segment_holds_the_brake_fraction(tmp_path: Path) -> None:
    segments: list[Trip] = []
    channel = f"ecu-test-{next(_ids)}"
    with (
        can.Bus(interface="virtual", channel=channel) as ecu_bus,
        can.Bus(interface="virtual", channel=channel) as peer_bus,
    ):
        node = EcuNode(EcuConfig(set_speed_mps=30.0), predefined(1.5), segments.append)
        rt = EcuRuntime(ecu_bus, node, CODEC)
        peers = PeerNodes(peer_bus, CODEC)
        peers.set("radar", gap_m=30.0)
        t = 0.0
        for k, (hmi_set, bar) in enumerate(
            [(0, 0.0)] * 120 + [(1, 0.0)] * 20 + [(0, 0.0)] * 30 + [(0, 100.0)] * 200
        ):
            t = (k + 1) * 0.01
            peers.set("hmi", set=hmi_set)
            peers.set("pedals", brake_pressed=int(bar > 0), brake_pressure_bar=bar)
            peers.send_due(t)
            rt.advance_to(t)
        node.finish()
    assert node.takeovers == 1 and len(segments) == 1
    braking = segments[0].brake_pedal[segments[0].acc_state == 3]
    assert braking.size > 10
    assert braking == pytest.approx(100.0 / 250.0)


# -- DBC limits stay below the node: the node's max set speed must fit the network -----------


def test_engaging_above_the_max_set_speed_caps_it() -> None:
    node = EcuNode(EcuConfig(max_set_speed_mps=45.0), predefined(1.5))
    inp = NodeInputs(v_mps=48.0, main_switch=True)
    for k in range(60):
        node.step(inp, k * 0.02)
    out = node.step(NodeInputs(v_mps=48.0, main_switch=True, set_button=True), 1.2)
    assert out.acc_state is AccState.ACTIVE
    assert out.set_speed_mps == 45.0


def test_max_set_speed_is_a_production_value_not_the_signal_maximum() -> None:
    assert EcuConfig().max_set_speed_mps == 50.0  # 180 km/h
    assert CODEC.by_role["status"].bounds("set_speed_mps")[1] == 63.75
    with pytest.raises(ConfigError, match="set_speed_mps"):
        EcuConfig(set_speed_mps=55.0)
    EcuConfig(set_speed_mps=55.0, max_set_speed_mps=60.0)  # a faster car may allow it


def test_a_max_set_speed_the_dbc_cannot_carry_is_refused() -> None:
    with can.Bus(interface="virtual", channel=f"ecu-test-{next(_ids)}") as bus:
        fits = EcuNode(EcuConfig(max_set_speed_mps=63.75), predefined(1.5))
        EcuRuntime(bus, fits, CODEC)
        too_fast = EcuNode(EcuConfig(max_set_speed_mps=70.0), predefined(1.5))
        with pytest.raises(RuntimeCodecError, match="set_speed_mps range \\[0, 63.75\\]"):
            EcuRuntime(bus, too_fast, CODEC)


def test_gap_setting_chooses_the_predefined_headway() -> None:
    """The driver's GapSetting on HMI_Buttons switches a predefined table to the paper's
    headway of that setting (1: 1 s, 2: 3 s, 3: 4 s): ACC_Status's desired gap at the car's
    20 m/s follows; the code seen first is the drive's own (no switch)."""
    b = Bench(headway_s=3.0)
    try:
        b.run(0.5, gap_setting=1)  # the first setting seen: the table stays 4 m + 3 s · v
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(64.0, abs=0.05)
        b.run(0.5, gap_setting=3)
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(84.0, abs=0.05)
        b.run(0.5, gap_setting=1)
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(24.0, abs=0.05)
        assert b.node.table.source == "predefined" and b.node.table.meta["headway_s"] == 1.0
        assert any("gap setting 1" in e for e in b.events)
    finally:
        b.close()


def test_gap_setting_leaves_a_learned_table_alone() -> None:
    b = Bench(headway_s=3.0)
    learned = dataclasses.replace(b.node.table, source="irl")
    b.node.set_table(learned)
    try:
        b.run(0.5, gap_setting=2)
        b.run(0.5, gap_setting=3)
        assert b.node.table is learned
        assert b.statuses[-1]["desired_gap_m"] == pytest.approx(64.0, abs=0.05)
    finally:
        b.close()
