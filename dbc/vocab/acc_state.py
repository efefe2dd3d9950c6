"""The ACC's engagement state and fault codes: the DBC's ``AccState`` and ``FaultCode`` values
(transitions: :mod:`ecu.cycle.state`)."""

from __future__ import annotations

from enum import IntEnum


class AccState(IntEnum):
    """ACC engagement state; values are the DBC ``AccState`` codes."""

    OFF = 0
    STANDBY = 1
    ACTIVE = 2
    OVERRIDE = 3
    FAULT = 4


class FaultCode(IntEnum):
    """Reason of the last FAULT; values are the DBC ``FaultCode`` codes."""

    NONE = 0
    SPEED_INPUT = 1
    PEDAL_INPUT = 2
    RADAR_INPUT = 3
    HMI_INPUT = 4
    PROFILE = 5
