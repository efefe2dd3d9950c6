"""The independent check of what leaves the ECU (ecu.safety): rules, properties, the bus."""

from __future__ import annotations

import math
from collections.abc import Iterator

import can
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState, FaultCode
from ecu.busio import BusIO
from ecu.config import EcuConfig
from ecu.safety import (
    ENVELOPE,
    JERK,
    NON_FINITE,
    NOT_ENGAGED,
    STATE_ACTIVE,
    STATE_FAULT,
    CommandSafety,
    SafetyLimits,
    vet,
)
from ecu.signals import NodeOutputs

L = SafetyLimits()
TOL = L.tolerance_mps2
DT = 0.02
ACTIVE, FAULT = int(AccState.ACTIVE), int(AccState.FAULT)

any_float = st.floats(allow_nan=True, allow_infinity=True)
accel = st.floats(-3.5, 2.0)
states = st.sampled_from([int(s) for s in AccState])
dts = st.floats(0.0, 1.0)


def test_the_state_codes_are_the_dbc_s() -> None:
    assert (STATE_ACTIVE, STATE_FAULT) == (ACTIVE, FAULT)


# -- the rules, one by one -------------------------------------------------------------------


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_goes_out_as_zero_inactive(bad: float) -> None:
    v = vet(L, bad, True, ACTIVE, 0.0, DT)
    assert (v.accel_mps2, v.active, v.broken) == (0.0, False, (NON_FINITE,))


@pytest.mark.parametrize(
    "state", [s for s in AccState if s not in (AccState.ACTIVE, AccState.FAULT)]
)
def test_a_request_is_active_only_while_engaged(state: AccState) -> None:
    v = vet(L, 0.5, True, int(state), 0.5, DT)
    assert (v.accel_mps2, v.active, v.broken) == (0.5, False, (NOT_ENGAGED,))
    assert vet(L, 0.5, False, int(state), 0.5, DT).broken == ()  # inactive: nothing to stop


def test_in_fault_an_active_request_only_ramps_toward_zero() -> None:
    assert vet(L, -1.0, True, FAULT, -1.05, DT).broken == ()  # toward zero
    v = vet(L, -1.2, True, FAULT, -1.05, DT)  # away from zero: held at the last request
    assert (v.accel_mps2, v.active, v.broken) == (-1.05, True, (NOT_ENGAGED,))
    v = vet(L, 0.3, True, FAULT, -0.02, DT)  # across zero: stops at zero
    assert (v.accel_mps2, v.broken) == (0.0, (NOT_ENGAGED,))
    v = vet(L, 0.9, True, FAULT, 1.0, DT)
    assert v.broken == () and v.accel_mps2 == 0.9


@pytest.mark.parametrize(("req", "edge"), [(-3.6, -3.5), (-10.0, -3.5), (2.01, 2.0)])
def test_the_envelope_clamps(req: float, edge: float) -> None:
    v = vet(L, req, False, ACTIVE, 0.0, DT)
    assert (v.accel_mps2, v.broken) == (edge, (ENVELOPE,))
    assert vet(L, edge, False, ACTIVE, 0.0, DT).broken == ()


def test_the_jerk_limit_rise_and_fall() -> None:
    rise, fall = L.jerk_rise_mps3 * DT, L.jerk_fall_mps3 * DT
    assert vet(L, 1.0 + rise, True, ACTIVE, 1.0, DT).broken == ()
    v = vet(L, 1.0 + rise + 0.01, True, ACTIVE, 1.0, DT)
    assert v.accel_mps2 == pytest.approx(1.0 + rise) and v.broken == (JERK,)
    assert vet(L, 1.0 - fall, True, ACTIVE, 1.0, DT).broken == ()
    v = vet(L, 1.0 - fall - 0.01, True, ACTIVE, 1.0, DT)
    assert v.accel_mps2 == pytest.approx(1.0 - fall) and v.broken == (JERK,)
    assert vet(L, 1.5, False, ACTIVE, 0.0, DT).broken == ()  # inactive: not executed, no jerk


def test_a_huge_request_breaks_envelope_then_jerk() -> None:
    v = vet(L, -10.0, True, ACTIVE, 0.0, DT)
    assert v.broken == (ENVELOPE, JERK) and v.accel_mps2 == pytest.approx(-L.jerk_fall_mps3 * DT)


# -- properties ------------------------------------------------------------------------------


@given(any_float, st.booleans(), states, accel, dts)
def test_what_leaves_is_finite_in_the_envelope_and_engaged(
    a: float, active: bool, state: int, prev: float, dt: float
) -> None:
    v = vet(L, a, active, state, prev, dt)
    assert math.isfinite(v.accel_mps2)
    assert L.accel_min_mps2 - TOL <= v.accel_mps2 <= L.accel_max_mps2 + TOL
    assert v.active <= active  # never turns a request on
    if v.active:
        assert state in (ACTIVE, FAULT)
        assert prev - L.jerk_fall_mps3 * dt - TOL <= v.accel_mps2
        assert v.accel_mps2 <= prev + L.jerk_rise_mps3 * dt + TOL
        if state == FAULT:
            assert min(prev, 0.0) - TOL <= v.accel_mps2 <= max(prev, 0.0) + TOL
    if not v.broken:  # what passes, passes untouched
        assert (v.accel_mps2, v.active) == (a, active)
    elif v.active != active:
        assert NON_FINITE in v.broken or NOT_ENGAGED in v.broken


@given(any_float, st.booleans(), states, accel, dts)
def test_vetting_is_idempotent(a: float, active: bool, state: int, prev: float, dt: float) -> None:
    once = vet(L, a, active, state, prev, dt)
    twice = vet(L, once.accel_mps2, once.active, state, prev, dt)
    assert twice.broken == ()
    assert (twice.accel_mps2, twice.active) == (once.accel_mps2, once.active)


@given(st.floats(-1.0, 1.0), accel, dts)
def test_a_lawful_request_passes_untouched(frac: float, prev: float, dt: float) -> None:
    step = frac * (L.jerk_rise_mps3 if frac > 0 else L.jerk_fall_mps3) * dt
    a = min(max(prev + step, L.accel_min_mps2), L.accel_max_mps2)
    v = vet(L, a, True, ACTIVE, prev, dt)
    assert (v.accel_mps2, v.active, v.broken) == (a, True, ())


def outputs(a: float, active: bool = True, state: AccState = AccState.ACTIVE) -> NodeOutputs:
    return NodeOutputs(
        accel_request_mps2=a,
        request_active=active,
        acc_state=state,
        takeover_request=state is AccState.FAULT,
        desired_gap_m=30.0,
        dgpt_version=1,
        adaptation_count=0,
        fault_code=FaultCode.NONE,
        set_speed_mps=25.0,
        emergency=False,
    )


@given(st.lists(st.tuples(any_float, st.booleans(), st.sampled_from(list(AccState))), max_size=40))
def test_a_sequence_of_frames_keeps_the_jerk_limit_between_sent_requests(
    seq: list[tuple[float, bool, AccState]],
) -> None:
    safety = CommandSafety()
    prev = 0.0
    for k, (a, active, state) in enumerate(seq):
        out = safety.check(outputs(a, active, state), 1.0 + k * DT)
        if out.request_active:
            assert prev - L.jerk_fall_mps3 * DT - TOL <= out.accel_request_mps2
            assert out.accel_request_mps2 <= prev + L.jerk_rise_mps3 * DT + TOL
        prev = out.accel_request_mps2
    assert sum(safety.stopped.values()) >= sum(1 for a, _, _ in seq if not math.isfinite(a))


def test_outputs_that_pass_are_the_same_object_and_nothing_is_counted() -> None:
    safety = CommandSafety()
    ramp = [outputs(0.04 * k) for k in range(10)]
    assert all(safety.check(o, 1.0 + k * DT) is o for k, o in enumerate(ramp))
    assert safety.stopped == {}


def test_the_first_frame_may_not_jump() -> None:
    safety = CommandSafety()
    out = safety.check(outputs(1.0), 5.0)
    assert out.accel_request_mps2 == 0.0 and safety.stopped == {JERK: 1}


# -- on the bus ------------------------------------------------------------------------------


@pytest.fixture
def port() -> Iterator[tuple[BusIO, can.BusABC]]:
    codec = load_codec()
    tx = can.Bus(interface="virtual", channel="safety-test", receive_own_messages=False)
    rx = can.Bus(interface="virtual", channel="safety-test")
    yield BusIO(tx, codec, EcuConfig()), rx
    tx.shutdown()
    rx.shutdown()


def test_the_port_sends_only_vetted_commands_and_counts_the_stops(
    port: tuple[BusIO, can.BusABC],
) -> None:
    io, rx = port
    codec = io.codec
    sent = [
        outputs(0.0),
        outputs(0.05),
        outputs(math.nan),  # non-finite: zero, inactive
        outputs(0.0),
        outputs(-9.0),  # outside the envelope and faster than the jerk limit
        outputs(0.0, state=AccState.OVERRIDE),  # not engaged
    ]
    returned = [io.send(1.0 + k * DT, out, status=False) for k, out in enumerate(sent)]
    assert returned[0] is sent[0]  # a lawful output passes as itself
    assert returned[2].accel_request_mps2 == 0.0  # what went out, for the recorder to log
    frames = []
    while (msg := rx.recv(0.1)) is not None:
        d = codec.by_id[msg.arbitration_id].decode(msg.data)
        if d.role == "command":
            frames.append((d.values["accel_request_mps2"], d.values["request_active"]))
    assert frames[:4] == [(0.0, 1), (0.05, 1), (0.0, 0), (0.0, 1)]
    assert frames[4][0] == pytest.approx(-L.jerk_fall_mps3 * DT) and frames[4][1] == 1
    assert frames[5][1] == 0
    assert io.safety.stopped == {NON_FINITE: 1, ENVELOPE: 1, JERK: 1, NOT_ENGAGED: 1}


def test_the_limits_are_the_vehicle_s() -> None:
    assert (L.accel_min_mps2, L.accel_max_mps2) == (-3.5, 2.0)  # ISO 15622
    assert (L.jerk_rise_mps3, L.jerk_fall_mps3) == (2.5, 10.0)


# -- edges (each kills a mutant of ecu/safety.py that the tests above let live) --------------


def test_the_tolerance_edges_pass_exactly() -> None:
    lo, hi = L.accel_min_mps2, L.accel_max_mps2
    assert vet(L, lo - TOL, False, ACTIVE, 0.0, DT).broken == ()
    assert vet(L, hi + TOL, False, ACTIVE, 0.0, DT).broken == ()
    prev, rise, fall = 1.0, L.jerk_rise_mps3 * DT, L.jerk_fall_mps3 * DT
    assert vet(L, prev - fall - TOL, True, ACTIVE, prev, DT).broken == ()
    assert vet(L, prev + rise + TOL, True, ACTIVE, prev, DT).broken == ()
    assert vet(L, -1.0 - TOL, True, FAULT, -1.0, DT).broken == ()  # held, in FAULT
    assert vet(L, 1.0 + TOL, True, FAULT, 1.0, DT).broken == ()


@pytest.mark.parametrize("t_next", [0.5, math.nan])
def test_a_frame_stamped_back_in_time_gets_no_room_to_move(t_next: float) -> None:
    safety = CommandSafety()
    safety.check(outputs(0.0), 1.0)
    assert safety.check(o := outputs(0.0), t_next) is o  # dt 0: standing still is lawful
    assert safety.check(outputs(0.1), t_next).accel_request_mps2 == 0.0
    assert safety.stopped == {JERK: 1}


def test_the_check_uses_the_limits_it_is_given() -> None:
    safety = CommandSafety(SafetyLimits(jerk_rise_mps3=1.0))
    safety.check(outputs(0.0), 1.0)
    assert safety.check(outputs(0.05), 1.0 + DT).accel_request_mps2 == pytest.approx(0.02)


def test_every_stop_is_logged_with_its_rules_and_values(caplog: pytest.LogCaptureFixture) -> None:
    safety = CommandSafety()
    with caplog.at_level("WARNING", logger="ecu.safety"):
        safety.check(outputs(-9.0), 2.0)
    assert caplog.messages == [
        "t=2.00 safety: envelope, jerk; request -9.0 active True -> 0.000 active True"
    ]
