"""The ACC node: ``EcuNode.step(inputs, now_s) -> outputs``, pure of I/O.

One call per 20 ms control cycle: the engagement state machine, takeovers (recorded, the DGPT
adapted at pedal release), plan and control within the envelope, each phase a pure function
of :mod:`ecu.cycle.phases`; the node holds the state between cycles. It never touches a bus,
a clock or a file; the trip sinks are injected. An invalid input while engaged goes to FAULT
(the request ramps to zero within the jerk limit); ``takeover_request`` is set in FAULT and
while the braking needed exceeds the ACC's authority (counted in ``limit_requests``).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Callable
from functools import partial

from dbc.vocab import FormatError
from dbc.vocab.acc_state import AccState, FaultCode
from dbc.vocab.dgpt import Dgpt, utc_now_iso
from dbc.vocab.sampling import MANUAL_MIN_S
from ecu import EcuError
from ecu.adaptation import (
    Decision,
    Reason,
    ShortPresses,
    TakeoverSummary,
    adapt,
    count_short_press,
)
from ecu.config import EcuConfig
from ecu.cycle.command import ControlMemory, control
from ecu.cycle.phases import (
    Engagement,
    InputCheck,
    check_inputs,
    cycle_time,
    enter_state,
    outputs,
    plan,
    reported_fault,
    sample_of,
    takeover_pedal,
)
from ecu.cycle.state import transition
from ecu.manual import ManualRecorder
from ecu.parts import plugins, recorders
from ecu.recorder import TakeoverRecorder, TripSink
from ecu.signals import NodeInputs, NodeOutputs

log = logging.getLogger(__name__)


class EcuNode:
    """The ACC node's state and its :meth:`step` (module docstring). The sinks get the takeover
    segments and manual trips (None: not recorded); ``utc_now``: ``created_utc`` of adapted tables;
    ``utc_of``: node clock (s) -> ISO 8601 UTC; ``manual_min_s``: shortest manual stretch, s."""

    def __init__(
        self,
        config: EcuConfig,
        table: Dgpt,
        takeover_sink: TripSink | None = None,
        *,
        utc_now: Callable[[], str] = utc_now_iso,
        utc_of: Callable[[float], str] | None = None,
        manual_sink: TripSink | None = None,
        manual_min_s: float = MANUAL_MIN_S,
    ) -> None:
        self.config = config
        self._utc_now = utc_now
        self._table = table
        self.state = AccState.OFF
        self.fault_code = FaultCode.NONE
        self.set_speed_mps = 0.0
        self.decisions: Counter[Reason] = Counter()
        #: adaptations applied so far (decisions[Reason.APPLIED], read every cycle)
        self.adaptations = 0
        #: FAULT entries by the input that caused them
        self.faults: Counter[FaultCode] = Counter()
        self.takeovers = 0
        #: takeover requests because the braking needed exceeded the ACC's (their onsets)
        self.limit_requests = 0
        self._beyond = False
        self._control_mem = ControlMemory()
        self._fault_ramp = False
        self._last_now: float | None = None
        self._valid_since: float | None = None
        self._buttons = (False, False, False)
        self._takeover_start: float | None = None
        self._takeover_pedal = ""
        self._takeover_after_switch = math.inf
        self._short_presses = ShortPresses()  # the run of short presses (adaptation evidence)
        self.last_decision: Decision | None = None
        self._profile_fault = False
        self._pending_events: list[str] = []
        self._law, self._adaptation = plugins(config)
        self.recorder: TakeoverRecorder | None
        self.manual: ManualRecorder | None
        self.recorder, self.manual = recorders(
            config, table, takeover_sink, manual_sink, utc_of=utc_of, manual_min_s=manual_min_s
        )

    @property
    def table(self) -> Dgpt:
        """The DGPT in use (replaced by each applied adaptation)."""
        return self._table

    @property
    def plugin_faults(self) -> dict[str, int]:
        """Faults of the plug-in methods, ``"controller <kind>"`` / ``"adaptation <kind>"`` ->
        count (empty with the built-ins called directly or plug-ins that behaved)."""
        out: dict[str, int] = {}
        for role, guard in (("controller", self._law), ("adaptation", self._adaptation)):
            if guard is not None:
                out.update({f"{role} {k}": n for k, n in guard.report.counts.items() if n})
        return out

    def step(self, inp: NodeInputs, now_s: float) -> NodeOutputs:
        """Run one control cycle at time ``now_s`` (s, monotonic); never raises on bad input."""
        config = self.config
        events = self._pending_events
        self._pending_events = []
        now_s, dt = cycle_time(now_s, self._last_now, config.cycle_s)
        self._last_now = now_s
        check = check_inputs(
            inp,
            now_s,
            state=self.state,
            buttons=self._buttons,
            valid_since_s=self._valid_since,
            settle_s=config.settle_s,
            has_set_speed=self.set_speed_mps > 0.0,
        )
        self._valid_since, self._buttons = check.valid_since_s, check.buttons
        ev = check.events
        old = self.state
        new = transition(old, ev, config.brake_mode)
        if new is not old:  # entering a state
            mem, reset = enter_state(
                old,
                new,
                Engagement(self.fault_code, self.set_speed_mps, self._fault_ramp),
                fault=check.fault,
                set_edge=ev.set_edge,
                v_mps=inp.v_mps,
                config=config,
            )
            self.fault_code, self.set_speed_mps, self._fault_ramp = (
                mem.fault_code,
                mem.set_speed_mps,
                mem.fault_ramp,
            )
            if reset:
                self._control_mem = ControlMemory(0.0, self._control_mem.prev_accel_mps2)
            if new is AccState.FAULT:
                self.faults[check.fault] += 1
                events.append(f"fault: {check.fault.name} input invalid while {old.name}")
            events.append(f"state {old.name} -> {new.name}")
            log.info("ACC state %s -> %s", old.name, new.name)
        self.state = new
        self._track_takeover(old, new, check, inp, now_s, events)
        p = plan(self._table, inp.v_mps)
        command, self._control_mem = control(
            config,
            new,
            inp,
            p,
            set_speed_mps=self.set_speed_mps,
            fault_ramp=self._fault_ramp,
            mem=self._control_mem,
            dt_s=dt,
            law=self._law,
            resume=ev.resume_edge or ev.accel_pressed,  # a go at a standstill
        )
        if command.ramp_done:
            self._fault_ramp = False
            events.append("fault ramp complete: request inactive")
        if command.beyond_limit and not self._beyond:
            self.limit_requests += 1
            events.append("takeover request: the braking needed exceeds the ACC's")
        self._beyond = command.beyond_limit
        sample = None
        if self.recorder is not None:
            sample = sample_of(inp, now_s, new)
            self.recorder.sample(sample)
        manual = self.manual  # a sample only for the cycles it may keep (every 5th)
        if manual is not None and now_s >= manual.next_due_s:
            manual.sample(sample or sample_of(inp, now_s, new), check.fault)
        return outputs(
            new,
            command,
            p,
            table=self._table,
            adaptation_count=self.adaptations,
            fault_code=reported_fault(self.fault_code, self._profile_fault),
            set_speed_mps=self.set_speed_mps,
            events=tuple(events),
        )

    def report_profile_fault(self, message: str = "") -> None:
        """The requested profile was refused: report FaultCode PROFILE on the status."""
        self._profile_fault = True
        if message:
            self._pending_events.append(message)

    def set_table(self, table: Dgpt, message: str = "") -> None:
        """Use ``table`` from the next cycle on (a driver profile switch); clears the profile
        fault; later trips carry its driver and condition (unless ``trip_meta`` sets them)."""
        self._table = table
        self._profile_fault = False
        ids = {"driver_id": table.driver_id, "condition": table.condition}
        ids = {k: v for k, v in ids.items() if k not in self.config.trip_meta}
        if self.recorder is not None:  # later takeover segments are the new driver's
            self.recorder.meta.update(ids)
        if self.manual is not None:  # an open manual stretch ends with a new driver
            self.manual.set_meta(ids)
        if message:
            self._pending_events.append(message)

    def finish(self) -> None:
        """End of trip: hand any open takeover segment and manual stretch to the sinks."""
        if self.recorder is not None:
            self.recorder.flush()
        if self.manual is not None:
            self.manual.flush()

    def _track_takeover(
        self,
        old: AccState,
        new: AccState,
        check: InputCheck,
        inp: NodeInputs,
        now_s: float,
        events: list[str],
    ) -> None:
        """A pedal pressed while ACTIVE starts a takeover; its release ends it (adaptation)."""
        accel, brake = check.events.accel_pressed, check.events.brake_pressed
        if self._takeover_start is None:
            if old is AccState.ACTIVE and (accel or brake) and new is not AccState.ACTIVE:
                pedal = self._takeover_pedal = takeover_pedal(accel, brake)
                self._takeover_start = now_s
                # how long after a target switch (a cut-in) it started: not preference evidence
                self._takeover_after_switch = self._control_mem.road.since_switch_s
                self.takeovers += 1
                events.append(f"takeover {self.takeovers} ({pedal})")
                if self.recorder is not None:
                    self.recorder.start(now_s, pedal)
        elif not (accel or brake):
            self._release_takeover(new, check.valid, inp, now_s, events)

    def _release_takeover(
        self, new: AccState, valid: bool, inp: NodeInputs, now_s: float, events: list[str]
    ) -> None:
        assert self._takeover_start is not None
        summary = TakeoverSummary(
            duration_s=now_s - self._takeover_start,
            v_mps=inp.v_mps,
            v_lead_mps=inp.v_mps + inp.rel_speed_mps,
            gap_m=inp.gap_m,
            lead_valid=inp.lead_valid,
            pedal=self._takeover_pedal,
            after_switch_s=self._takeover_after_switch,
        )
        self._takeover_start = None
        if not self.config.adaptation:
            label = "adaptation off"
        elif not valid or new in (AccState.OFF, AccState.FAULT):
            decision = Decision(applied=False, reason=Reason.INVALID_INPUT)
            label = self._record_decision(decision, events)
        else:
            label = self._record_decision(self._adapt(summary, now_s), events)
        if self.recorder is not None:
            self.recorder.release(now_s, label)

    def _adapt(self, summary: TakeoverSummary, now_s: float) -> Decision:
        """Run the adaptation on the finished takeover; the table changes if it applies."""
        params = self.config.adaptation_params
        self._short_presses, short_run = count_short_press(
            self._short_presses, summary, now_s, params
        )
        # a plug-in is guarded, its table clipped by the ECU
        update = self._adaptation or partial(adapt, params=params)
        try:
            self._table, decision = update(
                self._table,
                summary,
                bounds=self.config.bounds,
                short_run=short_run,
                created_utc=self._utc_now(),
            )
        except (EcuError, FormatError, ArithmeticError, ValueError) as exc:  # absurd finite inputs
            log.warning("adaptation refused: %s", exc)
            decision = Decision(applied=False, reason=Reason.INVALID_INPUT)
        return decision

    def _record_decision(self, decision: Decision, events: list[str]) -> str:
        self.decisions[decision.reason] += 1
        self.adaptations += decision.reason is Reason.APPLIED
        self.last_decision = decision
        text = str(decision)
        if decision.applied:
            text += f" -> DGPT v{self._table.version}"
        events.append(text)
        log.info("%s", text)
        return decision.reason.value
