"""What a synthetic driver does each step: manual following (IDM+) and ACC interventions.

Manual following (ACC off) is IDM+ (:mod:`sim_bus.idm`) around the driver's own preferred gap
g*(v), its equilibrium gap in car following. The driver sees the lead (gap, speed)
``reaction_s`` late but feels its own speed at once, and its control is noisy (AR(1),
``accel_noise_mps2``). It also estimates the lead's acceleration from what it sees (its brake
lights, low-passed over ``LEAD_ACCEL_TAU_S``).

Under ACC the driver monitors the gap. Too close (or closing so fast that the gap predicted
``lookahead_s`` ahead is too close) for longer than ``patience_s``, or time-to-collision below
``ttc_brake_s``: it brakes. Too far for longer than ``patience_far_s``: it presses the
accelerator, unless the lead is closing in or seen braking. While pressing it drives by its own
IDM+ (sign-restricted to the pedal); an accelerator press ends at once when that IDM+ asks to
slow down or the lead is seen braking (before, a driver 1 s late kept pressing
toward a braking lead until the time-to-collision was 1.2 s). Otherwise it releases when the
gap it anticipates ``anticipation_s`` ahead is within ``release_band`` of its preference,
holding the pedal ``prolong_s`` longer (the anticipation and prolonging the paper observed).
When ACC is not engaged (before SET, after a brake cancel, after a fault) it drives by hand,
and presses SET (RESUME after a cancel) once the gap feels right with the pedals released.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState
from dbc.vocab.pedals import PedalScale
from sim_bus.drivers import DriverParams
from sim_bus.idm import DECEL_LIMIT_MPS2, idm_plus_accel, interp_float

#: acceleration of a coasting car with no pedal pressed (drag, engine braking), m/s²
COAST_MPS2 = -0.3
#: manual pedal mapping: full accelerator gives this acceleration; brake pressure per m/s²
#: (the pedals' full scale, 100 % and 250 bar, is the network's: dbc.vocab.pedals.PedalScale)
ACCEL_FULL_MPS2 = 3.0
BRAKE_BAR_PER_MPS2 = 12.0
#: the AccState codes in which the ACC drives the car
_ENGAGED = (AccState.ACTIVE, AccState.OVERRIDE)
#: a lead slowing harder than this (its brake lights, seen ``reaction_s`` late) ends an
#: accelerator press and keeps one from starting, m/s²; coasting is about -0.3
LEAD_BRAKING_MPS2 = -0.5
#: time constant of the driver's estimate of the lead's acceleration, s
LEAD_ACCEL_TAU_S = 0.3
#: while pressing a pedal the driver watches the lead: it sees it at most this late, s (an
#: expected event; Green, "How long does it take to stop?", Transportation Human Factors 2(3),
#: 2000, puts a fully aware driver's brake reaction at about 0.7-0.75 s)
ATTENTIVE_REACTION_S = 0.75
#: seconds of its speed a driver keeps to spare when it brakes to stop short of a lead, s
STOP_SPARE_S = 1.2
BUTTON_HOLD_S = 0.3
#: a lead farther than this is out of the driver's sight: a free road, nothing to follow, m
LEAD_SIGHT_M = 200.0
#: standing behind a lead that pulls away faster than this (as seen), the driver presses
#: RESUME (a full-speed-range ACC waits for it after a long stop, ISO 15622), m/s
RESUME_LEAD_MPS = 1.0
STANDSTILL_MPS = 0.1
RESUME_DELAY_S = 1.0
FAULT_RETRY_S = 5.0  # after a fault, the driver tries SET once it has lasted this long
#: a driver that set out to drive with the ACC engages it by this time even if the gap never
#: felt right (not closing, not too close), s: one whose cautious following (IDM's small
#: comfortable deceleration) never closed to its short preferred gap drove 120 s by hand
ENGAGE_ANYWAY_S = 30.0


class DriverAgent:
    """A driver's state across steps of ``dt_s``; outputs are attributes (no allocation).

    Outputs after :meth:`step`: ``a_cmd_mps2`` (the acceleration its pedals ask for, used when
    a pedal is pressed or ACC is not engaged), ``accel_pressed``, ``brake_pressed``,
    ``accel_pct``, ``brake_bar``, ``set_button``, ``resume_button``, ``pref_gap_m``.
    ``acc_mode`` False: manual driving throughout (ACC off). ``pedals``: the pedals' full
    scale (default: the packaged network's), which bounds ``accel_pct`` and ``brake_bar``.
    """

    def __init__(
        self,
        p: DriverParams,
        rng: np.random.Generator,
        dt_s: float = 0.05,
        acc_mode: bool = True,
        engage_s: float = 0.5,
        pedals: PedalScale | None = None,
    ) -> None:
        scale = pedals if pedals is not None else PedalScale.from_codec(load_codec())
        self._accel_full_pct = scale.accel_full_pct
        self._brake_full_bar = scale.brake_full_bar
        self.p = p
        self.dt_s = dt_s
        self.acc_mode = acc_mode
        self.engage_s = engage_s
        self._rng = rng
        #: the headway table as floats (:func:`interp_float`, what np.interp reads)
        self._head_table = (
            tuple(float(x) for x in p.headway_speeds_mps),
            tuple(float(x) for x in p.headway_s),
        )
        n_delay = max(0, int(round(p.reaction_s / dt_s)))
        n_attentive = max(0, int(round(min(p.reaction_s, ATTENTIVE_REACTION_S) / dt_s)))
        # the lead's (speed, gap) of the last n_delay + 1 steps, newest last
        self._seen: deque[tuple[float, float]] = deque(maxlen=n_delay + 1)
        self._lag = (n_delay, n_attentive)  # steps back: (general, while pressing)
        self.condition = 1.0
        self._log_c = 0.0
        self._noise = 0.0
        self._vl_seen = [math.nan, math.nan]  # per channel: general, while pressing
        self._accel_seen = [0.0, 0.0]
        self.lead_accel_seen_mps2 = 0.0
        self._accel_k = dt_s / (LEAD_ACCEL_TAU_S + dt_s)
        self._noise_k = math.exp(-dt_s / 1.0)
        self._noise_s = p.accel_noise_mps2 * math.sqrt(1.0 - self._noise_k**2)
        self._sd_c = p.condition_drift_per_min * math.sqrt(dt_s / 60.0)
        # this trip's shift of the time headway, s (drawn only if the driver shifts at all,
        # so that the random stream of every other driver is the one it always was)
        self._trip_shift = (
            p.trip_shift_sd_s * float(rng.standard_normal()) if p.trip_shift_sd_s else 0.0
        )
        self._tap_p = p.spurious_press_per_min * dt_s / 60.0
        self.t_s = 0.0
        self.mode = "idle"  # idle | brake | accel | tap
        self._close_t = 0.0
        self._far_t = 0.0
        self._press_t = 0.0
        self._ok_t = -1.0
        self._last_release_t = -1e9
        self._button_until = -1.0
        self._button = ""
        self._engaged_once = False
        self._fault_t = 0.0
        self._resumed = False  # RESUME pressed during this standstill
        self.a_cmd_mps2 = 0.0
        self.accel_pressed = False
        self.brake_pressed = False
        self.accel_pct = 0.0
        self.brake_bar = 0.0
        self.set_button = False
        self.resume_button = False
        self.pref_gap_m = 0.0

    # -- perception ---------------------------------------------------------------------
    def _perceive(self, v_lead: float, gap: float) -> tuple[float, float]:
        """The lead's (speed m/s, gap m) as the driver sees it now: ``reaction_s`` late, at
        most ``ATTENTIVE_REACTION_S`` late while it presses a pedal; also updates
        ``lead_accel_seen_mps2``, the lead's acceleration seen on the same channel."""
        seen = self._seen
        seen.append((v_lead, gap))
        out = (v_lead, gap)
        newest = len(seen) - 1
        used = int(self.mode != "idle")  # the channel the driver looks through now
        vl_seen, accel_seen, k_accel, dt = self._vl_seen, self._accel_seen, self._accel_k, self.dt_s
        for channel, lag in enumerate(self._lag):
            k = newest - lag
            vl, g = seen[0 if k < 0 else k]
            if math.isfinite(vl):  # a non-finite sample must not poison the estimate for good
                last = vl_seen[channel]
                if not math.isnan(last):
                    a = accel_seen[channel]
                    a += k_accel * ((vl - last) / dt - a)
                    accel_seen[channel] = a
                vl_seen[channel] = vl
            if channel == used:
                out = (vl, g)
                self.lead_accel_seen_mps2 = accel_seen[channel]
        return out

    def _draws(self) -> tuple[float, float, float]:
        zn, zc = self._rng.standard_normal(2).tolist()  # the same floats as float(z[i])
        return zn, zc, self._rng.random()

    # -- one step -----------------------------------------------------------------------
    def step(self, v_mps: float, v_lead_mps: float, gap_m: float, acc_state: int) -> None:
        """Advance ``dt_s``: perceive (delayed), update preference drift, decide the pedals."""
        p = self.p
        dt = self.dt_s
        self.t_s += dt
        zn, zc, u = self._draws()
        self._noise = self._noise_k * self._noise + self._noise_s * zn
        if self._sd_c > 0.0:
            log_c = self._log_c + self._sd_c * zc
            log_c = -0.3 if log_c < -0.3 else log_c
            self._log_c = 0.4 if log_c > 0.4 else log_c
            self.condition = math.exp(self._log_c)
        vl, g = self._perceive(v_lead_mps, gap_m)
        v = v_mps  # own speed is felt at once; the lead is seen late
        c = p.condition_factor * self.condition
        head = interp_float(float(v), *self._head_table) + self._trip_shift
        pref = float(p.standstill_m + c * (0.3 if head < 0.3 else head) * v)
        self.set_button = self.resume_button = False
        if self.t_s < self._button_until:
            self.set_button = self._button == "set"
            self.resume_button = self._button == "resume"
        engaged = acc_state in _ENGAGED
        self._fault_t = self._fault_t + dt if acc_state == AccState.FAULT else 0.0
        if engaged:
            self._engaged_once = True
        supervising = self.acc_mode and (engaged or self.mode != "idle")
        if supervising:
            pref = (pref + c * p.acc_offset_s * v) * p.acc_preference_factor
        self.pref_gap_m = pref
        a_plan = idm_plus_accel(v, vl, g, pref, p)  # what it means to do, before the noise
        a_idm = a_plan + self._noise
        if not self.acc_mode:
            self._drive_by_hand(a_idm)
        elif supervising:
            if engaged and self.mode == "idle":
                self._standstill_resume(v, vl, g)
            self._supervise(v, vl, g, pref, a_idm, u, engaged, a_plan)
        else:
            self._not_engaged(v, vl, g, pref, a_idm, acc_state)

    def _drive_by_hand(self, a: float) -> None:
        self.a_cmd_mps2 = a
        self._set_pedals(a, "brake" if a < COAST_MPS2 else "accel")

    def _set_pedals(self, a: float, which: str) -> None:
        if which == "brake":
            self.accel_pressed, self.brake_pressed = False, True
            self.accel_pct = 0.0
            bar = -a * BRAKE_BAR_PER_MPS2
            bar = 1.0 if bar < 1.0 else bar
            self.brake_bar = self._brake_full_bar if bar > self._brake_full_bar else bar
        elif which == "accel":
            self.accel_pressed, self.brake_pressed = True, False
            pct = a / ACCEL_FULL_MPS2 * 100.0
            pct = 1.0 if pct < 1.0 else pct
            self.accel_pct = self._accel_full_pct if pct > self._accel_full_pct else pct
            self.brake_bar = 0.0
        else:
            self.accel_pressed = self.brake_pressed = False
            self.accel_pct = self.brake_bar = 0.0

    def _press_button(self, name: str) -> None:
        self._button = name
        self._button_until = self.t_s + BUTTON_HOLD_S
        self.set_button = name == "set"
        self.resume_button = name == "resume"

    def _not_engaged(
        self, v: float, vl: float, g: float, pref: float, a: float, acc_state: int
    ) -> None:
        """ACC not engaged: drive by hand; engage (SET, then RESUME) once the gap feels right."""
        p = self.p
        band = max(p.comfort_band * pref, p.comfort_band_min_m)
        quiet = self.t_s - self._last_release_t >= RESUME_DELAY_S
        late = not self._engaged_once and self.t_s >= ENGAGE_ANYWAY_S and g >= pref - band
        feels_right = ((abs(g - pref) <= band or late) and vl - v > -1.0) or g >= LEAD_SIGHT_M
        can_engage = self.t_s >= self.engage_s and (
            acc_state == AccState.STANDBY or self._fault_t >= FAULT_RETRY_S
        )
        if can_engage and feels_right and quiet:
            self.a_cmd_mps2 = COAST_MPS2
            self._set_pedals(0.0, "none")
            if self.t_s >= self._button_until + BUTTON_HOLD_S:
                # RESUME after a cancel; SET at first and after a fault (a new set speed)
                again = self._engaged_once and acc_state == AccState.STANDBY
                self._press_button("resume" if again else "set")
            return
        if can_engage and feels_right:
            self.a_cmd_mps2 = COAST_MPS2
            self._set_pedals(0.0, "none")
            return
        if p.revision >= 2:
            # by hand, its foot on the pedals, it sees closing as attentively as when it
            # presses under the ACC and brakes at least as hard as stopping short needs
            # (its IDM+, seeing the lead late, braked at 1.9 m/s^2 at 2.9 s TTC
            # and hit a lead braking at 1.9 m/s^2)
            vl1, g1 = self._seen[max(len(self._seen) - 1 - self._lag[1], 0)]
            closing = v - vl1
            if closing > 0.1:
                a = min(a, self._needed_mps2(v, vl1, g1, self._accel_seen[1]))
        self._drive_by_hand(a)
        self._last_release_t = self.t_s if not can_engage else self._last_release_t

    def _standstill_resume(self, v: float, vl: float, g: float) -> None:
        """Standing behind a lead that pulls away: press RESUME once (the ACC's go request)."""
        if v >= STANDSTILL_MPS:
            self._resumed = False
            return
        if not self._resumed and g < LEAD_SIGHT_M and vl >= RESUME_LEAD_MPS:
            self._resumed = True
            self._press_button("resume")

    def _supervise(
        self,
        v: float,
        vl: float,
        g: float,
        pref: float,
        a: float,
        u: float,
        engaged: bool,
        a_plan: float | None = None,
    ) -> None:
        """ACC engaged (or a press in progress): monitor, press, release. ``a``: its IDM+
        with control noise, ``a_plan``: without (what it decides by; default ``a``)."""
        p = self.p
        dt = self.dt_s
        band = p.comfort_band * pref
        band = p.comfort_band_min_m if band < p.comfort_band_min_m else band
        closing = v - vl
        ttc = self._ttc_now(g, closing)
        if self.mode == "idle":
            g_pred = g - (0.0 if closing < 0.0 else closing) * p.lookahead_s
            self._close_t = self._close_t + dt if (g < pref - band or g_pred < pref - band) else 0.0
            steady = closing <= 0.3 and self.lead_accel_seen_mps2 > LEAD_BRAKING_MPS2
            in_sight = g < LEAD_SIGHT_M  # a free road is not a gap too long
            if p.revision >= 2 and vl < RESUME_LEAD_MPS:
                in_sight = False  # nobody nudges up to a standing queue (to 0.9 m)
            self._far_t = self._far_t + dt if g > pref + band and steady and in_sight else 0.0
            rested = self.t_s - self._last_release_t >= p.refractory_s
            if ttc < p.ttc_brake_s or g < 0.5 * pref or (rested and self._close_t >= p.patience_s):
                self._start("brake")
            elif rested and self._far_t >= p.patience_far_s:
                self._start("accel")
            elif (
                rested
                and u < self._tap_p
                and steady
                and (vl >= RESUME_LEAD_MPS or g >= LEAD_SIGHT_M)
            ):
                self._start("tap")  # never toward a lead it closes on, that brakes or stands
            else:
                self.a_cmd_mps2 = a
                self._set_pedals(0.0, "none")
                return
        self._press_t += dt
        g_ant = g + (vl - v) * p.anticipation_s
        if self.mode == "brake":
            # at least what stopping short of the lead needs as it sees it (a
            # driver that took over with a weaker brake than the ACC's came within 1.1 s)
            need = self._needed_mps2(v, vl, g) if p.revision >= 2 else 0.0
            self.a_cmd_mps2 = min(a, -0.5, need)
            ok = g_ant >= pref * (1.0 - p.release_band) and ttc > p.ttc_brake_s
        elif self.mode == "accel":
            plan = a if a_plan is None or p.revision < 2 else a_plan
            # the decision is its following model's, not its control noise's
            if plan < 0.0 or self.lead_accel_seen_mps2 <= LEAD_BRAKING_MPS2:
                # its own following model asks to slow down, or the lead brakes: lift off
                self._release(a)
                return
            self.a_cmd_mps2 = max(a, 0.3)
            ok = g_ant <= pref * (1.0 + p.release_band)
        else:  # a press not about the gap: a tap, mistrust, habit
            self.a_cmd_mps2 = max(a, 0.2)
            ok = self._press_t >= p.tap_s
        if ok and self._ok_t < 0.0:
            self._ok_t = self._press_t
        hold = 0.0 if self.mode == "tap" else p.prolong_s
        done = ok and self._press_t - self._ok_t >= hold and self._press_t >= p.press_min_s
        # a brake press is not cut short while the gap still closes fast
        urgent = self.mode == "brake" and ttc < p.ttc_brake_s and p.revision >= 2
        if done or (self._press_t >= p.press_max_s and not urgent):
            self._release(a)
            return
        self._set_pedals(self.a_cmd_mps2, "brake" if self.mode == "brake" else "accel")

    def _ttc_now(self, g: float, closing: float) -> float:
        """Its time-to-collision (s) from the gap ``g`` it sees and the ``closing`` speed
        (m/s). Revision 2: the closing speed now (the lead's braking as seen, over its
        reaction time) and the gap now, reckoned from its late view and that closing speed (a
        late view of a lead it closes on looks far; traced: behind a stopped car, the ACC
        at -3.5 m/s^2, it saw 3 s of TTC while 1.3 s was left, and never braked)."""
        if self.p.revision >= 2:
            lag_s = self._lag[int(self.mode != "idle")] * self.dt_s
            # the lead's speed now from its braking as seen (brake lights, looming): a lead
            # braking at 3 m/s^2 seen 1 s late is 3 m/s slower than it looks
            seen = self.lead_accel_seen_mps2
            closing -= (0.0 if seen > 0.0 else seen) * lag_s
            g -= (0.0 if closing < 0.0 else closing) * lag_s
        if closing <= 0.1:
            return math.inf
        return (0.0 if g < 0.0 else g) / closing

    def _needed_mps2(
        self, v: float, vl: float, g: float, lead_accel_mps2: float | None = None
    ) -> float:
        """The constant deceleration (m/s², < 0) that matches the lead's speed (as seen,
        with its braking: ``lead_accel_mps2``, default the one it sees now) its standstill
        distance plus ``STOP_SPARE_S`` of its speed short of it, the closing speed and the gap
        reckoned now from its late view (``ATTENTIVE_REACTION_S`` at most), the lead's braking
        and the closing speed; 0 when not closing."""
        a_f = self.lead_accel_seen_mps2 if lead_accel_mps2 is None else lead_accel_mps2
        lag_s = self._lag[1] * self.dt_s
        closing = v - vl - min(a_f, 0.0) * lag_s  # the lead's speed now, from its braking
        if closing <= 0.0:
            return 0.0
        g -= closing * lag_s  # the gap now, from the late view and the closing speed
        # stop with STOP_SPARE_S of its speed to spare: braking front-loaded, as drivers do
        # (a constant-deceleration stop exactly at standstill_m passes below 2 s TTC;
        # with s to spare the stop keeps s + sqrt(2 standstill / decel): 0.5 s left 1.74 s)
        room = max(g - self.p.standstill_m - STOP_SPARE_S * v, 0.5)
        need = min(a_f, 0.0) - closing * closing / (2.0 * room)
        return max(need, -DECEL_LIMIT_MPS2)

    def _release(self, a: float) -> None:
        """End the press: pedals released, ``a`` (m/s²) is what the driver would do by hand."""
        self.mode = "idle"
        self._last_release_t = self.t_s
        self._close_t = self._far_t = 0.0
        self.a_cmd_mps2 = a
        self._set_pedals(0.0, "none")

    def _start(self, mode: str) -> None:
        self.mode = mode
        self._press_t = 0.0
        self._ok_t = -1.0
