"""The codec's exception tree, named by phase (load, encode, decode)."""

from __future__ import annotations

from pacc.errors import PaccError


class CodecError(PaccError):
    """Root of every error raised by the dbc package."""


class DbcError(CodecError):
    """Load time: the DBC or the binding table is missing, malformed or inconsistent."""


class EncodeError(CodecError):
    """A value to send is missing, not a number, or outside the DBC range."""


class DecodeError(CodecError):
    """A received frame cannot be used."""


class UnknownFrameError(DecodeError):
    """The frame id belongs to no bound message."""


class DlcError(DecodeError):
    """The frame's length differs from the DBC's."""


class CrcError(DecodeError):
    """The frame's E2E CRC does not match its payload and data id."""


class RangeError(DecodeError):
    """A decoded signal lies outside its DBC [minimum, maximum]."""


class BindingError(DbcError):
    """Load time: the binding table is malformed, or does not fit the DBC or pacc's roles."""
