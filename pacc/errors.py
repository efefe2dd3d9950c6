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


def error_line(exc: BaseException) -> str:
    """An error's text on one line; an OSError as ``strerror: filename`` (no errno repr)."""
    if isinstance(exc, OSError) and exc.strerror:
        where = f": {exc.filename}" if exc.filename else ""
        return f"{exc.strerror}{where}"
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


__all__ = ["PaccError", "UsageError", "error_line"]
