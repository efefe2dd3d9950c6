"""The project's exception root.

Every package's own root derives from :class:`PaccError` (``dbc.errors.CodecError``,
``ecu.EcuError``, ``cloud_sync.errors.CloudSyncError``, ``sim_bus.errors.SimError``), so a
caller that drives the whole tool can catch one class. This module imports nothing.
"""


class PaccError(Exception):
    """Root of every error that pacc raises on purpose (bad input, bad configuration)."""


__all__ = ["PaccError"]
