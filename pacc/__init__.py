"""pacc: personalized adaptive cruise control on a CAN bus.

This package holds the bottom and the top of the house:

- :mod:`pacc.errors` — ``PaccError``, the root of every error the project raises on purpose;
  it imports nothing, so every package builds its own error tree on it;
- :mod:`pacc.vocab` — the vocabulary the ECU, the simulator and the cloud share (the DGPT and
  trip-log formats, ACC state, pedal scaling);
- :mod:`pacc.commands` — one module per ``pacc`` sub-command: they only wire libraries together;
- :mod:`pacc.cli` — the ``pacc`` console script, which dispatches to those modules (imported
  only when chosen).

The shape is a diamond (docs/architecture.md; tests/test_layering.py enforces it)::

    pacc.errors <- dbc <- pacc.vocab <- ecu, sim_bus, cloud_sync <- sim_bus.study <- commands
"""
