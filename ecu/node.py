"""The ACC node: ``EcuNode.step(inputs, now_s) -> outputs``, pure of I/O.

One call per 20 ms control cycle: read the checked inputs (the runtime builds
:class:`NodeInputs` from the bus; tests and the simulator may build them directly), run the
engagement state machine, the controller and the envelope, track takeovers (record them,
adapt the DGPT at pedal release) and return :class:`NodeOutputs`. The node never touches a
bus, a clock or a file; the only I/O is the optional takeover sink, injected.

Usage (the simulator drives it in lockstep through :class:`ecu.runtime.EcuRuntime`)::

    from ecu.node import EcuNode, EcuConfig
    node = EcuNode(EcuConfig(adaptation=True, brake_mode="resume"), predefined(1.5))
    out = node.step(NodeInputs(...), now_s)
    node.table, node.takeovers, node.adaptations

Safety behaviour:
- an invalid input (stale, failed E2E, flagged invalid or non-finite) while ACTIVE or
  OVERRIDE goes to FAULT: the request ramps to zero within the jerk limit while
  ``request_active`` stays 1, then goes inactive; ``takeover_request`` is set in FAULT;
- every emitted request is inside the envelope and rate-limited, active or not;
- outside ACTIVE (and the FAULT ramp) the request is inactive;
- a FAULT forgets the set speed: only SET re-engages afterwards (RESUME has nothing to
  resume, also after CANCEL or the main switch off and on).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Callable

from ecu import EcuError
from ecu.adaptation import Decision, Reason, TakeoverSummary, adapt
from ecu.config import MAX_DT_S, ConfigError, EcuConfig
from ecu.controller import (
    ControlInput,
    desired_accel,
    limit_command,
    time_to_collision_s,
)
from ecu.dgpt import Dgpt, utc_now_iso
from ecu.recorder import Sample, TakeoverRecorder, TripSink
from ecu.signals import NodeInputs, NodeOutputs, all_finite, input_fault
from ecu.state import AccState, Events, FaultCode, transition

log = logging.getLogger(__name__)


class EcuNode:
    """The ACC node's state and its :meth:`step` (see the module docstring).

    Args:
        config: node configuration.
        table: the DGPT to start with.
        takeover_sink: receives each recorded takeover segment; None disables recording.
        utc_now: clock giving the ISO 8601 ``created_utc`` of adapted tables (injected so a
            lockstep drive can make its tables reproducible; default: the wall clock).
    """

    def __init__(
        self,
        config: EcuConfig,
        table: Dgpt,
        takeover_sink: TripSink | None = None,
        *,
        utc_now: Callable[[], str] = utc_now_iso,
    ) -> None:
        self.config = config
        self._utc_now = utc_now
        self._table = table
        self.state = AccState.OFF
        self.fault_code = FaultCode.NONE
        self.set_speed_mps = 0.0
        self.decisions: Counter[Reason] = Counter()
        #: FAULT entries by the input that caused them
        self.faults: Counter[FaultCode] = Counter()
        self.takeovers = 0
        self._integral = 0.0
        self._prev_accel = 0.0
        self._fault_ramp = False
        self._last_now: float | None = None
        self._valid_since: float | None = None
        self._buttons = (False, False, False)
        self._takeover_start: float | None = None
        self._takeover_pedal = ""
        self.last_decision: Decision | None = None
        self._profile_fault = False
        self._pending_events: list[str] = []
        self.recorder: TakeoverRecorder | None = None
        if takeover_sink is not None:
            self.recorder = TakeoverRecorder(
                takeover_sink,
                period_s=config.record_period_s,
                pre_s=config.pre_trigger_s,
                post_s=config.post_trigger_s,
                meta={
                    "driver_id": table.driver_id,
                    "condition": table.condition,
                    "brake_mode": config.brake_mode,
                    **dict(config.trip_meta),
                },
            )

    @property
    def table(self) -> Dgpt:
        """The DGPT in use (replaced by each applied adaptation)."""
        return self._table

    @property
    def adaptations(self) -> int:
        """Adaptations applied so far."""
        return self.decisions[Reason.APPLIED]

    def step(self, inp: NodeInputs, now_s: float) -> NodeOutputs:
        """Run one control cycle at time ``now_s`` (s, monotonic); never raises on bad input.

        A non-finite ``now_s`` (a host clock fault) is taken as no time passing since the
        previous cycle."""
        cfg = self.config
        events: list[str] = []
        if self._pending_events:
            events += self._pending_events
            self._pending_events.clear()
        if not math.isfinite(now_s):  # a host clock fault: time stands still this cycle
            now_s = self._last_now if self._last_now is not None else 0.0
        dt = cfg.cycle_s if self._last_now is None else now_s - self._last_now
        dt = min(max(dt, 0.0), MAX_DT_S) if math.isfinite(dt) else 0.0
        self._last_now = now_s

        fault = input_fault(inp)
        valid = fault is FaultCode.NONE
        if valid:
            if self._valid_since is None:
                self._valid_since = now_s
        else:
            self._valid_since = None
        settled = self._valid_since is not None and now_s - self._valid_since >= cfg.settle_s - 1e-9

        # Buttons: levels -> rising edges; a stale HMI counts as all released.
        levels = (
            (inp.set_button, inp.resume_button, inp.cancel_button) if inp.hmi_ok else (False,) * 3
        )
        set_edge, resume_edge, cancel_edge = (
            lv and not prev for lv, prev in zip(levels, self._buttons, strict=True)
        )
        self._buttons = levels
        pedals_known = inp.pedals_ok and all_finite(inp.accel_pedal, inp.brake_pedal)
        accel = inp.accel_pressed if pedals_known else False
        brake = inp.brake_pressed if pedals_known else False
        ev = Events(
            main_on=inp.main_switch if inp.hmi_ok else self.state is not AccState.OFF,
            set_edge=set_edge,
            resume_edge=resume_edge,
            cancel_edge=cancel_edge,
            accel_pressed=accel,
            brake_pressed=brake,
            inputs_valid=valid,
            inputs_settled=settled,
            has_set_speed=self.set_speed_mps > 0.0,
        )
        old = self.state
        new = transition(old, ev, cfg.brake_mode)
        if new is not old:
            self._on_change(old, new, fault, set_edge, inp, events)
        self.state = new

        self._track_takeover(old, new, accel, brake, valid, inp, now_s, events)

        v = inp.v_mps if all_finite(inp.v_mps) else 0.0
        table = self._table
        desired_gap = table.lookup(v)
        emergency = False
        if new is AccState.ACTIVE:
            obs = ControlInput(
                v_mps=v,
                a_mps2=inp.a_mps2,
                set_speed_mps=self.set_speed_mps,
                lead_valid=inp.lead_valid,
                gap_m=inp.gap_m,
                rel_speed_mps=inp.rel_speed_mps,
                lead_accel_mps2=inp.lead_accel_mps2 if inp.lead_accel_valid else 0.0,
                desired_gap_m=desired_gap,
                desired_gap_slope_s=table.slope(v),
            )
            target, self._integral = desired_accel(
                cfg.controller, obs, self._integral, dt, integrate=True
            )
            ttc = time_to_collision_s(inp.lead_valid, inp.gap_m, inp.rel_speed_mps)
            emergency = ttc < cfg.controller.emergency_ttc_s and target < self._prev_accel
            accel_cmd = limit_command(
                cfg.controller, self._prev_accel, target, dt, emergency=emergency
            )
            active = True
        else:
            accel_cmd = limit_command(cfg.controller, self._prev_accel, 0.0, dt, emergency=False)
            active = new is AccState.FAULT and self._fault_ramp and accel_cmd != 0.0
            if new is AccState.FAULT and self._fault_ramp and not active:
                self._fault_ramp = False
                events.append("fault ramp complete: request inactive")
        self._prev_accel = accel_cmd

        if self.recorder is not None:
            self.recorder.sample(
                Sample(
                    t_s=now_s,
                    v_mps=inp.v_mps,
                    gap_m=inp.gap_m if inp.lead_valid else math.nan,
                    v_lead_mps=inp.v_mps + inp.rel_speed_mps if inp.lead_valid else math.nan,
                    a_mps2=inp.a_mps2,
                    accel_pedal=inp.accel_pedal,
                    brake_pedal=inp.brake_pedal,
                    acc_state=int(new),
                )
            )
        return NodeOutputs(
            accel_request_mps2=accel_cmd,
            request_active=active,
            acc_state=new,
            takeover_request=new is AccState.FAULT,
            desired_gap_m=desired_gap if math.isfinite(desired_gap) else 0.0,
            dgpt_version=table.version,
            adaptation_count=self.adaptations,
            fault_code=(
                FaultCode.PROFILE
                if self._profile_fault and self.fault_code is FaultCode.NONE
                else self.fault_code
            ),
            set_speed_mps=self.set_speed_mps,
            emergency=emergency,
            events=tuple(events),
        )

    def report_profile_fault(self, message: str = "") -> None:
        """The requested profile was refused: report FaultCode PROFILE on the status.

        The node keeps running on the table it has (the last good one, or the predefined
        fallback); the code shows whenever no input fault is being reported. ``message``
        appears among the next step's events.
        """
        self._profile_fault = True
        if message:
            self._pending_events.append(message)

    def set_table(self, table: Dgpt, message: str = "") -> None:
        """Use ``table`` from the next cycle on (a driver profile switch); clears the profile
        fault; takeover segments started from now on carry the table's driver and condition
        (unless ``trip_meta`` fixes them). The request's jerk limit smooths the change of the
        desired gap."""
        self._table = table
        self._profile_fault = False
        if self.recorder is not None:  # later takeover segments are the new driver's
            ids = {"driver_id": table.driver_id, "condition": table.condition}
            self.recorder.meta.update(
                {k: v for k, v in ids.items() if k not in self.config.trip_meta}
            )
        if message:
            self._pending_events.append(message)

    def finish(self) -> None:
        """End of trip: hand any open takeover segment to the sink."""
        if self.recorder is not None:
            self.recorder.flush()

    # -- internals -------------------------------------------------------------------------

    def _on_change(
        self,
        old: AccState,
        new: AccState,
        fault: FaultCode,
        set_edge: bool,
        inp: NodeInputs,
        events: list[str],
    ) -> None:
        if new is AccState.FAULT:
            self.fault_code = fault
            self.faults[fault] += 1
            # ramp only a request that was being executed; after an override it stays off
            self._fault_ramp = old is AccState.ACTIVE
            # forget the set speed: only SET re-engages, not RESUME after CANCEL or main off/on
            self.set_speed_mps = 0.0
            events.append(f"fault: {fault.name} input invalid while {old.name}")
        if new in (AccState.ACTIVE, AccState.OVERRIDE) and old in (
            AccState.STANDBY,
            AccState.FAULT,
        ):
            self._integral = 0.0
            self._fault_ramp = False
            self.fault_code = FaultCode.NONE
            if set_edge or self.set_speed_mps <= 0.0:
                speed = self.config.set_speed_mps
                self.set_speed_mps = min(inp.v_mps, 63.75) if speed is None else speed
        events.append(f"state {old.name} -> {new.name}")
        log.info("ACC state %s -> %s", old.name, new.name)

    def _track_takeover(
        self,
        old: AccState,
        new: AccState,
        accel: bool,
        brake: bool,
        valid: bool,
        inp: NodeInputs,
        now_s: float,
        events: list[str],
    ) -> None:
        pressed = accel or brake
        if self._takeover_start is None:
            if old is AccState.ACTIVE and pressed and new is not AccState.ACTIVE:
                self._takeover_start = now_s
                pedal = "both" if accel and brake else ("accel" if accel else "brake")
                self._takeover_pedal = pedal
                self.takeovers += 1
                events.append(f"takeover {self.takeovers} ({self._takeover_pedal})")
                if self.recorder is not None:
                    self.recorder.start(now_s, self._takeover_pedal)
            return
        if pressed:
            return
        summary = TakeoverSummary(
            duration_s=now_s - self._takeover_start,
            v_mps=inp.v_mps,
            v_lead_mps=inp.v_mps + inp.rel_speed_mps,
            gap_m=inp.gap_m,
            lead_valid=inp.lead_valid,
            pedal=self._takeover_pedal,
        )
        self._takeover_start = None
        if not self.config.adaptation:
            label = "adaptation off"
        elif not valid or new in (AccState.OFF, AccState.FAULT):
            decision = Decision(applied=False, reason=Reason.INVALID_INPUT)
            label = self._record_decision(decision, events)
        else:
            try:
                self._table, decision = adapt(
                    self._table, summary, self.config.adaptation_params, created_utc=self._utc_now()
                )
            except (EcuError, ArithmeticError, ValueError) as exc:  # absurd finite inputs
                log.warning("adaptation refused: %s", exc)
                decision = Decision(applied=False, reason=Reason.INVALID_INPUT)
            label = self._record_decision(decision, events)
        if self.recorder is not None:
            self.recorder.release(now_s, label)

    def _record_decision(self, decision: Decision, events: list[str]) -> str:
        self.decisions[decision.reason] += 1
        self.last_decision = decision
        text = str(decision)
        if decision.applied:
            text += f" -> DGPT v{self._table.version}"
        events.append(text)
        log.info("%s", text)
        return decision.reason.value


__all__ = ["ConfigError", "EcuConfig", "EcuNode", "NodeInputs", "NodeOutputs", "input_fault"]
