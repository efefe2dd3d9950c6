"""What an ACC node is built of, from its configuration: the plug-ins and the trip recorders.

:func:`plugins`: the guarded plug-in methods :class:`~ecu.config.EcuConfig` names
(:mod:`ecu.methods.guard`); :func:`recorders`: the takeover and manual-driving recorders for
the sinks given, with the trip metadata of the table and the configuration.
"""

from __future__ import annotations

from collections.abc import Callable

from dbc.vocab.dgpt import Dgpt
from ecu.config import EcuConfig
from ecu.manual import ManualRecorder
from ecu.methods import make_adaptation, make_controller
from ecu.methods.guard import (
    ADAPTATION_BUDGET_S,
    CONTROLLER_BUDGET_S,
    GuardedAdaptation,
    GuardedController,
)
from ecu.recorder import TakeoverRecorder, TripSink


def plugins(config: EcuConfig) -> tuple[GuardedController | None, GuardedAdaptation | None]:
    """The guarded plug-in methods ``config`` names (None: the built-in called directly;
    PluginError: nothing loadable, or the factory refuses the arguments)."""
    law = adaptation = None
    budget = config.plugin_budget_s
    if config.gap_controller:
        args = dict(config.controller_args)
        if config.gap_controller == "pid" and not args:
            args = {"params": config.controller}
        law = GuardedController(
            make_controller(config.gap_controller, args),
            config.controller,
            name=config.gap_controller,
            budget_s=CONTROLLER_BUDGET_S if budget is None else budget,
        )
    if config.adaptation_method:
        adaptation = GuardedAdaptation(
            make_adaptation(config.adaptation_method, dict(config.adaptation_args)),
            name=config.adaptation_method,
            budget_s=ADAPTATION_BUDGET_S if budget is None else budget,
        )
    return law, adaptation


def recorders(
    config: EcuConfig,
    table: Dgpt,
    takeover_sink: TripSink | None,
    manual_sink: TripSink | None,
    *,
    utc_of: Callable[[float], str] | None,
    manual_min_s: float,
) -> tuple[TakeoverRecorder | None, ManualRecorder | None]:
    """The node's takeover and manual-driving recorders (None where no sink is given)."""
    meta = {
        "driver_id": table.driver_id,
        "condition": table.condition,
        "brake_mode": config.brake_mode,
        **dict(config.trip_meta),
    }
    recorder: TakeoverRecorder | None = None
    if takeover_sink is not None:
        recorder = TakeoverRecorder(
            takeover_sink,
            period_s=config.record_period_s,
            pre_s=config.pre_trigger_s,
            post_s=config.post_trigger_s,
            meta=meta,
            utc_of=utc_of,
        )
    manual: ManualRecorder | None = None
    if manual_sink is not None:
        manual = ManualRecorder(
            manual_sink,
            period_s=config.record_period_s,
            cycle_s=config.cycle_s,
            min_s=manual_min_s,
            meta=meta,
            utc_of=utc_of,
        )
    return recorder, manual
