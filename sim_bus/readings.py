"""What the simulator's sensors read at a tick: each transmitted role's values off the world,
limited to the field's DBC bounds (above: hi; below or NaN: lo) so encoding never fails. The
radar reports no lead beyond its range or while it confirms a new track. One dict per role,
updated in place.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from dbc.codec import RoleCodec
from dbc.schema import resting_values
from sim_bus.world import World


class Readings:
    """The transmitted roles' values of ``world`` at the current tick (``roles``: their
    codecs, for the bounds; ``gap_setting``, ``profile_id``: the HMI's)."""

    def __init__(
        self,
        world: World,
        roles: Mapping[str, RoleCodec],
        gap_setting: int = 2,
        profile_id: int = 0,
    ) -> None:
        self.world = world
        #: each role's values, updated in place by its filler
        self.values: dict[str, dict[str, Any]] = resting_values(
            hmi={"gap_setting": int(gap_setting), "profile_id": int(profile_id)}
        )
        ego, pedals, radar = roles["ego"], roles["pedals"], roles["radar"]
        self._b_ego = ego.bounds("speed_mps"), ego.bounds("accel_mps2")
        self._b_pedals = pedals.bounds("accel_pedal_pct"), pedals.bounds("brake_pressure_bar")
        self._b_radar = tuple(
            radar.bounds(k) for k in ("gap_m", "rel_speed_mps", "lead_accel_mps2")
        )

    def ego(self) -> dict[str, Any]:
        """ESC: the ego speed (m/s) and acceleration (m/s^2)."""
        car = self.world.plant
        vals = self.values["ego"]
        (lo, hi), (alo, ahi) = self._b_ego
        x = car.v_mps
        vals["speed_mps"] = x if lo <= x <= hi else hi if x > hi else lo
        x = car.a_mps2
        vals["accel_mps2"] = x if alo <= x <= ahi else ahi if x > ahi else alo
        return vals

    def pedals(self) -> dict[str, Any]:
        """PEDAL: the switches, the accelerator travel (%) and the brake pressure (bar)."""
        agent = self.world.agent
        vals = self.values["pedals"]
        (lo, hi), (blo, bhi) = self._b_pedals
        vals["accel_pressed"] = 1 if agent.accel_pressed else 0
        vals["brake_pressed"] = 1 if agent.brake_pressed else 0
        x = agent.accel_pct
        vals["accel_pedal_pct"] = x if lo <= x <= hi else hi if x > hi else lo
        x = agent.brake_bar
        vals["brake_pressure_bar"] = x if blo <= x <= bhi else bhi if x > bhi else blo
        return vals

    def radar(self) -> dict[str, Any]:
        """RADAR: lead valid, the gap (m), the relative speed (m/s), the lead's acceleration."""
        w = self.world
        car = w.plant
        vals = self.values["radar"]
        (lo, hi), (rlo, rhi), (alo, ahi) = self._b_radar
        gap = car.gap_m
        seen = lo <= gap <= hi and w.t_s >= w.radar_blank_until
        vals["lead_valid"] = 1 if seen else 0
        vals["gap_m"] = gap if lo <= gap <= hi else hi if gap > hi else lo
        x = w.v_lead_mps - car.v_mps
        vals["rel_speed_mps"] = x if rlo <= x <= rhi else rhi if x > rhi else rlo
        x = w.a_lead_mps2
        vals["lead_accel_mps2"] = x if alo <= x <= ahi else ahi if x > ahi else alo
        return vals

    def hmi(self) -> dict[str, Any]:
        """HMI: the SET and RESUME buttons, and a person's other buttons (:mod:`pacc.hil`)."""
        agent = self.world.agent
        vals = self.values["hmi"]
        vals["set"] = 1 if agent.set_button else 0
        vals["resume"] = 1 if agent.resume_button else 0
        vals.update(getattr(agent, "hmi_buttons", None) or {})  # a person's other buttons
        return vals
