"""pacc ECU: the personalized adaptive cruise control node.

Modules, one concept each:

- :mod:`ecu.adaptation` — online DGPT adaptation from one takeover (Algorithm 1): the table
  update (spread, safety filter).
- :mod:`ecu.controller` — PID gap controller with the acceleration/jerk envelope.
- :mod:`ecu.recorder` — takeover recorder (pre-trigger ring buffer, segments to a sink).
- :mod:`ecu.manual` — manual-driving recorder (the driver's car-following stretches as trips).
- :mod:`ecu.config` — ``EcuConfig``, the node's frozen configuration.
- :mod:`ecu.signals` — ``NodeInputs`` / ``NodeOutputs``, the node's boundary values.
- :mod:`ecu.cycle` — one control cycle as pure functions: its phases, the engagement state
  machine, the control phase, the road rules, stopping behind a lead.
- :mod:`ecu.node` — ``EcuNode.step(inputs, now) -> outputs``, pure of I/O.
- :mod:`ecu.parts` — what a node is built of, from its configuration: plug-ins, recorders.
- :mod:`ecu.busio` — frames <-> node values (Inbox/Outbox), the DBC fit check.
- :mod:`ecu.safety` — the independent check of every command frame before it is sent.
- :mod:`ecu.profiles` — driver profiles selected by the HMI.
- :mod:`ecu.clocks` — the cycle grid in lockstep or real time.
- :mod:`ecu.runtime` — ``EcuRuntime``, wiring bus I/O, profiles and clocks to a node.

The sub-package :mod:`ecu.buslog` records the bus (MCAP), reads, replays and converts it;
:mod:`ecu.methods` holds the plug-in methods of the ECU (the gap controller and the online
adaptation). Formats the ECU shares with the simulator and the cloud (DGPT, trip logs, ACC state,
pedals) live in :mod:`dbc.vocab`; the command line is :mod:`pacc.commands.ecu`.

Every error raised by this package derives from :class:`EcuError` (itself a
:class:`dbc.errors.PaccError`).
"""

from __future__ import annotations

import math

from dbc.errors import PaccError


class EcuError(PaccError):
    """Root of every exception raised by the :mod:`ecu` package."""


def finite_fields(obj: object, names: str, low: float = 0.0) -> bool:
    """Each attribute of ``obj`` named in ``names`` (space-separated) is finite and >= ``low``."""
    return all(math.isfinite(x) and x >= low for x in (getattr(obj, n) for n in names.split()))


__all__ = ["EcuError", "finite_fields"]
