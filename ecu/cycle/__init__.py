"""One control cycle of the ACC node, as pure functions (no I/O, no state of their own).

:class:`ecu.node.EcuNode` holds the state between cycles and calls these in order:

- :mod:`ecu.cycle.phases` — the phases of one control cycle: the cycle's time, the inputs'
  check, state entry, plan, the takeover's pedal, outputs.
- :mod:`ecu.cycle.state` — the engagement state machine (pure transition function).
- :mod:`ecu.cycle.command` — the control phase: the cycle's request and the controller's memory.
- :mod:`ecu.cycle.road` — the road rules: target switches, lead loss, standstill.
- :mod:`ecu.cycle.stops` — stopping behind a lead that stops or stands (the request's bound).
"""
