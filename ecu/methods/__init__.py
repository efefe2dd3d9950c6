"""Plug-in methods of the ECU: the gap controller and the online adaptation (docs/plugins.md).

- :class:`GapController`: ``desired_accel(obs, memory, dt_s) -> (accel_mps2, memory)``, the
  unlimited request (m/s^2) of one 20 ms ACTIVE cycle from :class:`~ecu.controller.ControlInput`;
  ``memory`` a float the ECU keeps (the PID's gap-error integral, m*s). The ECU clips and
  rate-limits the result (:func:`ecu.controller.limit_command`).
- :class:`Adaptation`: ``update(table, takeover, *, bounds, short_run, created_utc) ->
  (new table or None, Decision)`` at each takeover release; the ECU clips the table into
  ``bounds``.

Built-ins: ``pid``, ``timegap``, ``paper`` and ``bayes`` (:mod:`ecu.methods.bayes`: a Kalman
filter per speed bin); others from entry points (``pacc.controllers``, ``pacc.adaptations``)
or ``module:attribute``. :mod:`ecu.methods.guard` calls them inside a wall-time budget and
falls back to the built-in PID / no change when one raises, returns NaN or overruns.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

from dbc.vocab.dgpt import Dgpt, SafetyBounds
from dbc.vocab.plugins import PluginError, build
from ecu.adaptation import AdaptationParams, Decision, TakeoverSummary, adapt
from ecu.controller import ControlInput, ControllerParams, desired_accel

CONTROLLER_GROUP = "pacc.controllers"
ADAPTATION_GROUP = "pacc.adaptations"
#: built-in gap controllers: name -> factory
BUILTIN_CONTROLLERS: dict[str, str] = {"pid": "ecu.methods:PidController"}
#: built-in adaptations: name -> factory
BUILTIN_ADAPTATIONS: dict[str, str] = {
    "timegap": "ecu.methods:TimegapAdaptation",
    "paper": "ecu.methods:PaperAdaptation",
    "bayes": "ecu.methods.bayes:BayesAdaptation",
}


@runtime_checkable
class GapController(Protocol):
    """A longitudinal gap law (see the package docstring for units and the envelope)."""

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        """``(acceleration request m/s^2, next memory)`` for one ACTIVE cycle."""
        ...


@runtime_checkable
class Adaptation(Protocol):
    """An online adaptation of the DGPT at each takeover release (see the package docstring)."""

    def update(
        self,
        table: Dgpt,
        takeover: TakeoverSummary,
        *,
        bounds: SafetyBounds,
        short_run: bool,
        created_utc: str,
    ) -> tuple[Dgpt | None, Decision]:
        """The new table (None: unchanged) and the decision with its reason."""
        ...


class PidController:
    """The built-in PID gap law with cruise cap (:func:`ecu.controller.desired_accel`).

    Parameters: any field of :class:`~ecu.controller.ControllerParams` (gains as tables)."""

    def __init__(self, params: ControllerParams | None = None, **fields: Any) -> None:
        base = params if params is not None else ControllerParams()
        self.params = dataclasses.replace(base, **fields) if fields else base

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        """The PID's request; ``memory`` is the gap-error integral, m*s."""
        return desired_accel(self.params, obs, memory, dt_s, integrate=True)


class RuleAdaptation:
    """The built-in rule adaptations (:func:`ecu.adaptation.adapt`): ``mode`` ``"timegap"``
    or ``"paper"``; parameters: any field of :class:`~ecu.adaptation.AdaptationParams`."""

    mode = "timegap"

    def __init__(self, params: AdaptationParams | None = None, **fields: Any) -> None:
        base = params if params is not None else AdaptationParams(mode=self.mode)  # type: ignore[arg-type]
        self.params = dataclasses.replace(base, **fields) if fields else base

    def update(
        self, table: Dgpt, takeover: TakeoverSummary, **kw: Any
    ) -> tuple[Dgpt | None, Decision]:
        """Algorithm 1 (``paper``) or its time-gap successor on one finished takeover."""
        new, decision = adapt(table, takeover, self.params, **kw)
        return (new if decision.applied else None), decision


class TimegapAdaptation(RuleAdaptation):
    """``timegap``: the measured successor of Algorithm 1 (the ECU's default)."""

    mode = "timegap"


class PaperAdaptation(RuleAdaptation):
    """``paper``: Algorithm 1 as printed (a local window of bins)."""

    mode = "paper"


def make_controller(spec: str, params: Mapping[str, Any]) -> GapController:
    """The gap controller named by ``spec`` built with ``params`` (PluginError if none)."""
    obj = build(CONTROLLER_GROUP, spec, BUILTIN_CONTROLLERS, params)
    if not callable(getattr(obj, "desired_accel", None)):
        raise PluginError(f"controller {spec!r} has no desired_accel(obs, memory, dt_s)")
    return obj  # type: ignore[no-any-return]


def make_adaptation(spec: str, params: Mapping[str, Any]) -> Adaptation:
    """The adaptation named by ``spec`` built with ``params`` (PluginError if none)."""
    obj = build(ADAPTATION_GROUP, spec, BUILTIN_ADAPTATIONS, params)
    if not callable(getattr(obj, "update", None)):
        raise PluginError(f"adaptation {spec!r} has no update(table, takeover, ...)")
    return obj  # type: ignore[no-any-return]
