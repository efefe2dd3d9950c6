"""Engagement state machine of the ACC: a pure transition function.

States (the DBC's ``AccState`` codes): OFF 0, STANDBY 1, ACTIVE 2, OVERRIDE 3 (a driver pedal
pressed: the paper's takeover), FAULT 4. Transitions, first matching rule wins::

    any      --main off-->                          OFF
    OFF      --main on-->                           STANDBY
    ACTIVE, OVERRIDE --input invalid-->             FAULT
    ACTIVE, OVERRIDE --cancel, or brake with brake_mode=cancel-->  STANDBY
    ACTIVE   --accelerator or brake-->              OVERRIDE
    OVERRIDE --both pedals released-->              ACTIVE
    STANDBY, FAULT --SET (STANDBY also RESUME with a set speed), inputs valid >= 1 s,
                     no brake-->                    ACTIVE (OVERRIDE if accelerator pressed)
    FAULT    --cancel-->                            STANDBY
"""

from __future__ import annotations

from typing import Literal

from dbc.vocab.acc_state import AccState
from ecu.signals import cycle_value

BrakeMode = Literal["resume", "cancel"]


@cycle_value
class Events:
    """Inputs of one transition: levels, rising edges of the buttons, pedals, input validity."""

    main_on: bool = False
    set_edge: bool = False
    resume_edge: bool = False
    cancel_edge: bool = False
    accel_pressed: bool = False
    brake_pressed: bool = False
    inputs_valid: bool = True
    inputs_settled: bool = True
    has_set_speed: bool = False


def transition(state: AccState, ev: Events, brake_mode: BrakeMode = "resume") -> AccState:
    """The next state from ``state`` under ``ev`` (pure; see the module docstring)."""
    if not ev.main_on:
        return AccState.OFF
    if state is AccState.OFF:
        return AccState.STANDBY
    if state in (AccState.ACTIVE, AccState.OVERRIDE):
        return _from_engaged(ev, brake_mode)
    return _from_disengaged(state, ev)


def _from_engaged(ev: Events, brake_mode: BrakeMode) -> AccState:
    """ACTIVE or OVERRIDE, main switch on: a pedal pressed overrides, released resumes."""
    if not ev.inputs_valid:
        return AccState.FAULT
    if ev.cancel_edge or (ev.brake_pressed and brake_mode == "cancel"):
        return AccState.STANDBY
    return AccState.OVERRIDE if ev.accel_pressed or ev.brake_pressed else AccState.ACTIVE


def _from_disengaged(state: AccState, ev: Events) -> AccState:
    """STANDBY or FAULT, main switch on; after a fault only SET re-engages (a deliberate new
    set speed)."""
    engage = ev.set_edge or (state is AccState.STANDBY and ev.resume_edge and ev.has_set_speed)
    if engage and ev.inputs_valid and ev.inputs_settled and not ev.brake_pressed:
        return AccState.OVERRIDE if ev.accel_pressed else AccState.ACTIVE
    if state is AccState.FAULT and ev.cancel_edge:
        return AccState.STANDBY
    return state
