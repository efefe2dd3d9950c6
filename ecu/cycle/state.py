"""Engagement state machine of the ACC: a pure transition function.

States (the DBC's ``AccState`` codes): OFF 0, STANDBY 1 (main switch on), ACTIVE 2,
OVERRIDE 3 (a driver pedal is pressed: the paper's takeover), FAULT 4.

Transitions, first matching rule wins::

    any      --main off-->                          OFF
    OFF      --main on-->                           STANDBY
    ACTIVE, OVERRIDE --input invalid-->             FAULT
    ACTIVE, OVERRIDE --cancel-->                    STANDBY
    ACTIVE, OVERRIDE --brake, brake_mode=cancel-->  STANDBY   (production behaviour)
    ACTIVE   --accelerator or brake-->              OVERRIDE  (brake: the paper's study)
    OVERRIDE --both pedals released-->              ACTIVE
    STANDBY, FAULT --SET (STANDBY also: RESUME with a set speed), inputs valid >= 1 s,
                     no brake-->                    ACTIVE, or OVERRIDE if the accelerator
                                                    is pressed
    FAULT    --cancel-->                            STANDBY
    otherwise                                       unchanged

"Input invalid" means a safety-relevant input (speed, pedals, radar, buttons) is stale or
failed its E2E check; the caller also passes whether the inputs have been valid for the
re-engagement hold time (1 s).
"""

from __future__ import annotations

from typing import Literal

from dbc.vocab.acc_state import AccState, FaultCode
from ecu.signals import cycle_value

BrakeMode = Literal["resume", "cancel"]


@cycle_value
class Events:
    """Inputs of one transition.

    Attributes:
        main_on: main switch level.
        set_edge: rising edge of SET.
        resume_edge: rising edge of RESUME.
        cancel_edge: rising edge of CANCEL.
        accel_pressed: accelerator pedal pressed.
        brake_pressed: brake pedal pressed.
        inputs_valid: every safety-relevant input is fresh and passed E2E this cycle.
        inputs_settled: inputs have been valid continuously for the re-engagement hold time.
        has_set_speed: a set speed exists (RESUME can engage).
    """

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


__all__ = ["AccState", "BrakeMode", "Events", "FaultCode", "transition"]
