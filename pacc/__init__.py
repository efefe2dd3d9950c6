"""pacc: personalized adaptive cruise control on a CAN bus: the harness and the commands.

The top floor of the house (docs/architecture.md): :mod:`pacc.study` (one drive, the studies,
the bench), :mod:`pacc.hil` (a person drives in a browser page), :mod:`pacc.commands` (one
module per sub-command) and :mod:`pacc.cli` (the ``pacc`` console script).
"""
