"""Calling a plug-in from the control loop without trusting it.

:class:`GuardedController` and :class:`GuardedAdaptation` call a plug-in inside a per-call
wall-time budget (``time.perf_counter`` around the call: no thread, no signal). A call that
raises, returns something malformed or non-finite, or overruns is discarded for the safe
output: the built-in PID's request (a controller; off after ``max_overruns`` overruns) or no
change of the table (an adaptation). A controller overruns at ``HARD_FACTOR`` times the
budget or on a third call in a row over it, so one preempted call on a busy host does not
change a lockstep drive. Faults are counted by kind in :attr:`PluginReport.counts`.
"""

from __future__ import annotations

import logging
import math
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dbc.vocab.dgpt import Dgpt, SafetyBounds, clamp_to_bounds
from ecu.adaptation import Decision, Reason, TakeoverSummary
from ecu.controller import ControlInput, ControllerParams, desired_accel
from ecu.methods import Adaptation, GapController

log = logging.getLogger(__name__)

#: default per-call budget of a controller, s (half the 20 ms control cycle)
CONTROLLER_BUDGET_S = 0.010
#: default per-call budget of an adaptation, s (it runs once per takeover, not every cycle)
ADAPTATION_BUDGET_S = 0.100
#: a controller call over this many budgets overruns at once
HARD_FACTOR = 10.0
#: calls in a row over the budget that make an overrun
LATE_STREAK = 3
#: overruns after which a controller plug-in is switched off for the rest of the trip
MAX_OVERRUNS = 3
_REFUSED = Decision(applied=False, reason=Reason.INVALID_INPUT)


@dataclass
class PluginReport:
    """What a guarded plug-in did: faults by kind."""

    name: str
    counts: Counter[str] = field(default_factory=Counter)

    def fault(self, kind: str, detail: str) -> None:
        """Count one fault of ``kind``; the first of each kind is logged."""
        if not self.counts[kind]:
            log.warning("plug-in %s: %s (%s); safe output used", self.name, kind, detail)
        self.counts[kind] += 1


class GuardedController:
    """A :class:`GapController` behind the budget (see the module docstring); call it as
    the gap law of :func:`ecu.cycle.command.control`: ``(obs, memory, dt_s) -> (accel, memory)``."""

    def __init__(
        self,
        plugin: GapController,
        fallback: ControllerParams,
        *,
        name: str,
        budget_s: float = CONTROLLER_BUDGET_S,
        max_overruns: int = MAX_OVERRUNS,
    ) -> None:
        self.plugin = plugin
        self.fallback = fallback
        self.budget_s = budget_s
        self.max_overruns = max_overruns
        self.report = PluginReport(name)
        self.disabled = False
        self._late = 0  # calls in a row over the budget
        self._call = plugin.desired_accel

    def __call__(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        report = self.report
        if self.disabled:
            report.counts["disabled"] += 1
        else:
            start = time.perf_counter()
            fault: tuple[str, str] | None = None
            checked = None
            try:  # the plug-in's numbers become plain floats inside the timed, guarded call
                out = self._call(obs, memory, dt_s)
                checked = _checked_pair(out)
                if checked is None:
                    fault = ("non_finite" if _is_pair(out) else "bad_output", repr(out)[:80])
            except KeyboardInterrupt:
                raise
            except BaseException as exc:  # noqa: BLE001 - SystemExit too: the safe output
                fault = ("raised", _describe(exc))
            elapsed = time.perf_counter() - start
            late = elapsed > self.budget_s  # an overrun: see the module docstring
            self._late = self._late + 1 if late else 0
            if late and (self._late >= LATE_STREAK or elapsed > HARD_FACTOR * self.budget_s):
                self._overrun(elapsed)
            elif checked is not None:
                return checked
            elif fault is not None:
                report.fault(*fault)
        # the memory is the plug-in's: the PID reads it as its integral only inside its own
        # clamp (a plug-in's large memory would otherwise hold the PID on the cruise law)
        limit = self.fallback.integral_limit_m_s
        integral = min(max(memory, -limit), limit) if math.isfinite(memory) else 0.0
        return desired_accel(self.fallback, obs, integral, dt_s, integrate=True)

    def _overrun(self, elapsed_s: float) -> None:
        self.report.fault("overrun", f"{elapsed_s * 1e3:.1f} ms > {self.budget_s * 1e3:.1f} ms")
        if self.report.counts["overrun"] >= self.max_overruns:
            self.disabled = True
            log.warning(
                "plug-in %s switched off after %d overruns", self.report.name, self.max_overruns
            )


def _describe(exc: BaseException) -> str:
    """``Type: text`` of a plug-in's exception (its ``__str__`` is the plug-in's too)."""
    try:
        return f"{type(exc).__name__}: {exc}"[:200]
    except Exception:  # noqa: BLE001
        return type(exc).__name__


def _is_pair(out: object) -> bool:
    return isinstance(out, tuple) and len(out) == 2


def _checked_pair(out: object) -> tuple[float, float] | None:
    """``out`` as two finite floats, else None."""
    if not _is_pair(out):
        return None
    assert isinstance(out, tuple)
    try:
        accel, memory = float(out[0]), float(out[1])
    except (TypeError, ValueError, OverflowError):  # not numbers, or 10**400
        return None
    if math.isfinite(accel) and math.isfinite(memory):
        return accel, memory
    return None


class GuardedAdaptation:
    """An :class:`Adaptation` behind the budget; the returned table is checked (a DGPT on
    the same speed axis, finite gaps) and clipped into the safety bounds by the ECU."""

    def __init__(
        self, plugin: Adaptation, *, name: str, budget_s: float = ADAPTATION_BUDGET_S
    ) -> None:
        self.plugin = plugin
        self.budget_s = budget_s
        self.report = PluginReport(name)

    def __call__(self, table: Dgpt, takeover: TakeoverSummary, **kw: Any) -> tuple[Dgpt, Decision]:
        """The table after the takeover (``table`` itself when nothing applies); ``kw`` as
        :meth:`Adaptation.update`'s (``bounds``, ``short_run``, ``created_utc``)."""
        start = time.perf_counter()
        try:  # the result is checked inside the timed, guarded call
            new, decision = self.plugin.update(table, takeover, **kw)
            result = self._checked(table, new, decision, kw["bounds"])
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # noqa: BLE001 - SystemExit too: no change
            self.report.fault("raised", _describe(exc))
            return table, _REFUSED
        elapsed = time.perf_counter() - start
        if elapsed > self.budget_s:
            self.report.fault("overrun", f"{elapsed * 1e3:.1f} ms > {self.budget_s * 1e3:.1f} ms")
            return table, _REFUSED
        return result

    def _checked(
        self, table: Dgpt, new: object, decision: object, bounds: SafetyBounds
    ) -> tuple[Dgpt, Decision]:
        if not isinstance(decision, Decision):
            self.report.fault("bad_output", f"decision {type(decision).__name__}")
            return table, _REFUSED
        if new is None or not decision.applied:
            return table, decision if not decision.applied else _REFUSED
        if not isinstance(new, Dgpt) or new.gap_m.shape != table.gap_m.shape:
            self.report.fault("bad_output", f"table {type(new).__name__}")
            return table, _REFUSED
        if not np.array_equal(new.speed_mps, table.speed_mps):
            self.report.fault("bad_output", "table on another speed axis")
            return table, _REFUSED
        if not np.all(np.isfinite(new.gap_m)):
            self.report.fault("non_finite", "table with non-finite gaps")
            return table, _REFUSED
        clipped = np.asarray(clamp_to_bounds(new.speed_mps, new.gap_m, bounds))
        if not np.array_equal(clipped, new.gap_m):
            new = new.with_gaps(clipped, "adapted", created_utc=new.created_utc)
        return new, decision
