"""The project's exception root.

Every package's own root derives from :class:`PaccError` (``dbc.errors.CodecError``,
``ecu.EcuError``, ``cloud_sync.errors.CloudSyncError``, ``sim_bus.errors.SimError``), so a
caller that drives the whole tool can catch one class: ``pacc.cli.main`` catches it once,
prints one line (``pacc <cmd>: error: ...``) on stderr and exits 2. This module imports
nothing.
"""


class PaccError(Exception):
    """Root of every error that pacc raises on purpose (bad input, bad configuration)."""


class UsageError(PaccError):
    """Options that contradict each other or name unusable paths (the commands' own checks
    beyond what argparse sees)."""


__all__ = ["PaccError", "UsageError"]
