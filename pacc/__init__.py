"""pacc: personalized adaptive cruise control on a CAN bus: the harness and the commands.

This package is the top of the house; everything below it is a library it wires together:

- :mod:`pacc.study` — the harness: one closed-loop drive (the ECU and the simulator on one
  bus, the cloud beside them), the paper's Table I, the population, the bench;
- :mod:`pacc.hil` — a person drives in a browser page against the ECU (``pacc hil``);
- :mod:`pacc.commands` — one module per ``pacc`` sub-command: they only parse options and
  call libraries;
- :mod:`pacc.cli` — the ``pacc`` console script, which dispatches to those modules (imported
  only when chosen).

The floors (docs/architecture.md; tests/test_layering.py enforces them)::

    dbc (network, vocabulary, errors) <- ecu, sim_bus, cloud_sync <- pacc.study, pacc.hil
        <- pacc.commands
"""
