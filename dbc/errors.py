"""The project's exception root, and the codec's tree named by phase (load, encode, decode).

Every package's root derives from :class:`PaccError`, which ``pacc.cli.main`` catches once
(one line on stderr, exit 2).
"""


class PaccError(Exception):
    """Root of every error that pacc raises on purpose (bad input, bad configuration)."""


class UsageError(PaccError):
    """Options that contradict each other or name unusable paths (beyond argparse)."""


def error_line(exc: BaseException) -> str:
    """An error's text on one line; an OSError as ``strerror: filename`` (no errno repr)."""
    if isinstance(exc, OSError) and exc.strerror:
        where = f": {exc.filename}" if exc.filename else ""
        return f"{exc.strerror}{where}"
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


class CodecError(PaccError):
    """Root of every error raised by the dbc package."""


class DbcError(CodecError):
    """Load time: the DBC or the binding table is missing, malformed or inconsistent."""


class EncodeError(CodecError):
    """A value to send is missing, not a number, or outside the DBC range."""


class DecodeError(CodecError):
    """A received frame cannot be used."""


class DlcError(DecodeError):
    """The frame's length differs from the DBC's."""


class CrcError(DecodeError):
    """The frame's E2E CRC does not match its payload and data id."""


class RangeError(DecodeError):
    """A decoded signal lies outside its DBC [minimum, maximum]."""


class BindingError(DbcError):
    """Load time: the binding table is malformed, or does not fit the DBC or pacc's roles."""
