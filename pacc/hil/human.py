"""The person's pedals and HMI buttons as the world's driver (a ``PedalSource``).

Page inputs arrive any time (:meth:`HumanPedals.keys`, :meth:`HumanPedals.axes`,
:meth:`HumanPedals.press`); :meth:`HumanPedals.tick` advances them one plant tick. A held
key ramps its pedal at ``KEY_RISE_PER_S`` from ``KEY_TOUCH`` (full after 2.4 s), a released
one falls at ``KEY_FALL_PER_S``; a gamepad gives positions 0..1 and overrides the keys.
Accelerator ``a = COAST_MPS2 + p·(ACCEL_FULL_MPS2 − COAST_MPS2)``, brake
``a = −p·DECEL_LIMIT_MPS2``; on the bus the synthetic drivers' scaling (:mod:`sim_bus.behaviour`).
"""

from __future__ import annotations

import math

from sim_bus.behaviour import (
    ACCEL_FULL_MPS2,
    BRAKE_BAR_PER_MPS2,
    BUTTON_HOLD_S,
    COAST_MPS2,
)
from sim_bus.idm import DECEL_LIMIT_MPS2

#: keyboard ramps, fractions of full pedal travel per second
KEY_TOUCH = 0.05
KEY_RISE_PER_S = 0.4
KEY_FALL_PER_S = 3.0
#: a pedal counts as pressed above this fraction of its travel
PRESSED_AT = 0.005
#: the HMI buttons a person presses (momentary); ``main`` toggles, ``gap`` cycles 1..3
BUTTONS = ("set", "resume", "cancel", "main", "gap")


def ramp(position: float, held: bool, dt_s: float) -> float:
    """A keyboard pedal's position after ``dt_s`` s with its key ``held`` (pure, 0..1)."""
    if held:
        return min(1.0, max(position, KEY_TOUCH) + KEY_RISE_PER_S * dt_s)
    return max(0.0, position - KEY_FALL_PER_S * dt_s)


def pedal_accel_mps2(accel: float, brake: float) -> float:
    """The acceleration (m/s²) the pedals ask for; positions 0..1, the brake wins."""
    if brake > PRESSED_AT:
        return -brake * DECEL_LIMIT_MPS2
    return COAST_MPS2 + accel * (ACCEL_FULL_MPS2 - COAST_MPS2)


class HumanPedals:
    """A person's pedals and buttons, advanced one plant tick at a time. ``main_on``: the main
    switch at the start; ``locked``: the buttons do nothing (manual drives); ``gap_setting``: 1..3.
    """

    def __init__(self, *, main_on: bool = True, locked: bool = False, gap_setting: int = 2):
        self.locked = locked
        self._keys = (False, False)
        self._axes: tuple[float, float] | None = None
        self._pending: list[str] = []
        self._hold: dict[str, float] = {}
        self.accel = 0.0  # pedal positions, fractions of full travel
        self.brake = 0.0
        self.t_s = 0.0
        self.main_on = main_on and not locked
        self.gap_setting = min(max(int(gap_setting), 1), 3)
        self.a_cmd_mps2 = COAST_MPS2
        self.accel_pressed = False
        self.brake_pressed = False
        self.accel_pct = 0.0
        self.brake_bar = 0.0
        self.set_button = False
        self.resume_button = False
        self.pref_gap_m = math.nan  # a person's preference is what the study measures
        self.hmi_buttons: dict[str, int] = {}
        self._publish_hmi()

    def keys(self, accel: bool, brake: bool) -> None:
        """The accelerator and brake keys held now (keyboard ramps; ends a gamepad's say)."""
        self._keys = (bool(accel), bool(brake))
        self._axes = None

    def axes(self, accel: float, brake: float) -> None:
        """Pedal positions 0..1 from a gamepad or pedal set (non-finite values read as 0)."""
        self._axes = (_unit(accel), _unit(brake))

    def press(self, name: str) -> None:
        """A momentary HMI button (one of :data:`BUTTONS`); unknown names are ignored."""
        if name in BUTTONS and not self.locked:
            self._pending.append(name)

    def tick(self, dt_s: float) -> None:
        """Advance the pedals and buttons by one plant tick of ``dt_s`` s."""
        self.t_s += dt_s
        if self._axes is not None:
            self.accel, self.brake = self._axes
        else:
            ka, kb = self._keys
            self.accel = ramp(self.accel, ka, dt_s)
            self.brake = ramp(self.brake, kb, dt_s)
        while self._pending:
            name = self._pending.pop(0)
            if name == "main":
                self.main_on = not self.main_on
            elif name == "gap":
                self.gap_setting = self.gap_setting % 3 + 1
            else:
                self._hold[name] = self.t_s + BUTTON_HOLD_S
        held = {k for k, until in self._hold.items() if self.t_s < until}
        self.set_button = "set" in held
        self.resume_button = "resume" in held
        self.accel_pressed = self.accel > PRESSED_AT and self.brake <= PRESSED_AT
        self.brake_pressed = self.brake > PRESSED_AT
        self.a_cmd_mps2 = pedal_accel_mps2(self.accel, self.brake)
        self.accel_pct = 100.0 * self.accel if self.accel_pressed else 0.0
        self.brake_bar = -self.a_cmd_mps2 * BRAKE_BAR_PER_MPS2 if self.brake_pressed else 0.0
        self._publish_hmi(cancel="cancel" in held)

    def step(self, v_mps: float, v_lead_mps: float, gap_m: float, acc_state: int) -> None:
        """The world's driver step: nothing to decide, the person decides (see :meth:`tick`)."""

    def _publish_hmi(self, cancel: bool = False) -> None:
        self.hmi_buttons = {
            "main_switch": 1 if self.main_on else 0,
            "cancel": 1 if cancel else 0,
            "gap_setting": self.gap_setting,
        }


def _unit(x: float) -> float:
    x = float(x)
    return 0.0 if not math.isfinite(x) or x < 0.0 else min(x, 1.0)
