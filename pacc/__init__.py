"""pacc: personalized adaptive cruise control on a CAN bus.

This package is the top and the bottom of the house, and nothing in between:

- :mod:`pacc.errors` — ``PaccError``, the root of every error the project raises on purpose;
  it imports nothing, so every package can build its own error tree on it;
- :mod:`pacc.cli` — the ``pacc`` console script, which dispatches to the sub-commands that
  live in their packages (imported only when chosen).

The packages themselves depend one way: ``dbc`` ← ``ecu`` ← ``cloud_sync`` ← ``sim_bus``
(tests/test_layering.py enforces it).
"""
