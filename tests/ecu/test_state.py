"""Engagement state machine: a named transition table, then every state x every input."""

from __future__ import annotations

import itertools
from dataclasses import fields, replace

import pytest

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState, FaultCode
from ecu.cycle.state import Events, transition

S = AccState
ON = Events(main_on=True)

# (from, events, brake_mode, expected)
TABLE = [
    (S.OFF, Events(), "resume", S.OFF),
    (S.OFF, ON, "resume", S.STANDBY),
    (S.OFF, replace(ON, set_edge=True), "resume", S.STANDBY),  # one step at a time
    (S.STANDBY, ON, "resume", S.STANDBY),
    (S.STANDBY, Events(), "resume", S.OFF),
    (S.STANDBY, replace(ON, set_edge=True), "resume", S.ACTIVE),
    (S.STANDBY, replace(ON, set_edge=True, inputs_settled=False), "resume", S.STANDBY),
    (S.STANDBY, replace(ON, set_edge=True, inputs_valid=False), "resume", S.STANDBY),
    (S.STANDBY, replace(ON, set_edge=True, brake_pressed=True), "resume", S.STANDBY),
    (S.STANDBY, replace(ON, set_edge=True, accel_pressed=True), "resume", S.OVERRIDE),
    (S.STANDBY, replace(ON, resume_edge=True), "resume", S.STANDBY),
    (S.STANDBY, replace(ON, resume_edge=True, has_set_speed=True), "resume", S.ACTIVE),
    (S.ACTIVE, ON, "resume", S.ACTIVE),
    (S.ACTIVE, Events(), "resume", S.OFF),
    (S.ACTIVE, replace(ON, cancel_edge=True), "resume", S.STANDBY),
    (S.ACTIVE, replace(ON, accel_pressed=True), "resume", S.OVERRIDE),
    (S.ACTIVE, replace(ON, accel_pressed=True), "cancel", S.OVERRIDE),
    (S.ACTIVE, replace(ON, brake_pressed=True), "resume", S.OVERRIDE),
    (S.ACTIVE, replace(ON, brake_pressed=True), "cancel", S.STANDBY),
    (S.ACTIVE, replace(ON, inputs_valid=False), "resume", S.FAULT),
    (S.ACTIVE, replace(ON, inputs_valid=False, cancel_edge=True), "resume", S.FAULT),
    (S.OVERRIDE, replace(ON, accel_pressed=True), "resume", S.OVERRIDE),
    (S.OVERRIDE, ON, "resume", S.ACTIVE),
    (S.OVERRIDE, replace(ON, brake_pressed=True), "resume", S.OVERRIDE),
    (S.OVERRIDE, replace(ON, brake_pressed=True), "cancel", S.STANDBY),
    (S.OVERRIDE, replace(ON, accel_pressed=True, cancel_edge=True), "resume", S.STANDBY),
    (S.OVERRIDE, replace(ON, accel_pressed=True, inputs_valid=False), "resume", S.FAULT),
    (S.FAULT, ON, "resume", S.FAULT),
    (S.FAULT, Events(), "resume", S.OFF),
    (S.FAULT, replace(ON, set_edge=True, inputs_settled=False), "resume", S.FAULT),
    (S.FAULT, replace(ON, set_edge=True), "resume", S.ACTIVE),
    (S.FAULT, replace(ON, cancel_edge=True), "resume", S.STANDBY),
    (S.FAULT, replace(ON, resume_edge=True, has_set_speed=True), "resume", S.FAULT),
]


@pytest.mark.parametrize(("state", "ev", "mode", "expected"), TABLE)
def test_named_transitions(state: AccState, ev: Events, mode: str, expected: AccState) -> None:
    assert transition(state, ev, mode) is expected  # type: ignore[arg-type]


NAMES = [f.name for f in fields(Events)]
ALL_EVENTS = [
    Events(**dict(zip(NAMES, bits, strict=True)))
    for bits in itertools.product((False, True), repeat=len(NAMES))
]


def _check_engaged(state: AccState, ev: Events, new: AccState, mode: str) -> None:
    """The rules of a transition into ACTIVE or OVERRIDE."""
    engaged_before = state in (S.ACTIVE, S.OVERRIDE)
    if new is S.ACTIVE:  # engaged and nobody on a pedal, inputs valid
        assert ev.inputs_valid and not ev.accel_pressed and not ev.brake_pressed
        if state is S.FAULT:  # re-engage only by SET after 1 s of valid inputs
            assert ev.inputs_settled and ev.set_edge
        elif not engaged_before:
            assert ev.inputs_settled and (ev.set_edge or (ev.resume_edge and ev.has_set_speed))
    if new is S.OVERRIDE:
        assert ev.accel_pressed or ev.brake_pressed
        assert ev.inputs_valid
        if mode == "cancel":
            assert not ev.brake_pressed


@pytest.mark.parametrize("mode", ["resume", "cancel"])
@pytest.mark.parametrize("state", list(AccState))
def test_exhaustive_invariants(state: AccState, mode: str) -> None:
    """Every state x all 2^9 input combinations: the safety rules hold."""
    seen: set[AccState] = set()
    for ev in ALL_EVENTS:
        new = transition(state, ev, mode)  # type: ignore[arg-type]
        seen.add(new)
        engaged_before = state in (S.ACTIVE, S.OVERRIDE)
        if not ev.main_on:
            assert new is S.OFF
            continue
        if state is S.OFF:
            assert new is S.STANDBY
        if new is S.FAULT:  # FAULT only from an engaged state on invalid input, or stays
            assert (engaged_before and not ev.inputs_valid) or state is S.FAULT
        if engaged_before and not ev.inputs_valid:
            assert new is S.FAULT
        _check_engaged(state, ev, new, mode)
        if state in (S.STANDBY, S.FAULT) and new in (S.ACTIVE, S.OVERRIDE):
            assert not ev.brake_pressed
        if state is S.STANDBY:
            assert new in (S.STANDBY, S.ACTIVE, S.OVERRIDE)
    expected_reachable = {
        S.OFF: {S.OFF, S.STANDBY},
        S.STANDBY: {S.OFF, S.STANDBY, S.ACTIVE, S.OVERRIDE},
        S.ACTIVE: {S.OFF, S.STANDBY, S.ACTIVE, S.OVERRIDE, S.FAULT},
        S.OVERRIDE: {S.OFF, S.STANDBY, S.ACTIVE, S.OVERRIDE, S.FAULT},
        S.FAULT: {S.OFF, S.STANDBY, S.ACTIVE, S.OVERRIDE, S.FAULT},
    }
    assert seen == expected_reachable[state]


def _value_table(message: str, signal: str) -> dict[int, str]:
    choices = load_codec().db.get_message_by_name(message).get_signal_by_name(signal).choices
    return {int(k): str(v).replace(" ", "").upper() for k, v in choices.items()}


def test_codes_match_the_dbc_value_tables() -> None:
    """AccState and FaultCode are the one definition of the codes; the DBC's value tables
    name the same codes (no code the ECU never sends, e.g. a dead INTERNAL fault)."""
    assert _value_table("ACC_Command", "AccState") == {int(s): s.name for s in AccState}
    faults = {int(f): f.name.replace("_", "") for f in FaultCode}
    assert _value_table("ACC_Status", "FaultCode") == faults
    assert load_codec().by_role["command"].bounds("acc_state") == (0, int(max(AccState)))
