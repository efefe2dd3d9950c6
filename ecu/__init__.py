"""pacc ECU: the personalized adaptive cruise control node.

Modules, one concept each:

- :mod:`ecu.dgpt` — the Driving Gap Preference Table (desired gap per speed), JSON I/O.
- :mod:`ecu.adaptation` — online DGPT adaptation from one takeover (Algorithm 1).
- :mod:`ecu.controller` — PID gap controller with the acceleration/jerk envelope.
- :mod:`ecu.state` — engagement state machine (pure transition function).
- :mod:`ecu.recorder` — takeover recorder (pre-trigger ring buffer, segments to a sink).
- :mod:`ecu.config` — ``EcuConfig``, the node's frozen configuration.
- :mod:`ecu.signals` — ``NodeInputs`` / ``NodeOutputs``, the node's boundary values.
- :mod:`ecu.node` — ``EcuNode.step(inputs, now) -> outputs``, pure of I/O.
- :mod:`ecu.runtime` — wires a python-can bus, the codec, the clock and the log.
- :mod:`ecu.triplog` — ``Trip`` and its MCAP trip-log format (written here, read by the cloud).
- :mod:`ecu.cli` — ``pacc ecu`` / ``python -m ecu``.

Every error raised by this package derives from :class:`EcuError` (itself a
:class:`pacc.errors.PaccError`).
"""

from __future__ import annotations

from pacc.errors import PaccError


class EcuError(PaccError):
    """Root of every exception raised by the :mod:`ecu` package."""


__all__ = ["EcuError"]
