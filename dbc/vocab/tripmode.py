"""Trip modes: how a trip log was driven (``meta["mode"]``).

``manual`` (ACC off: a demonstration), ``acc`` (the ACC drove, takeovers inside) or
``takeover`` (one takeover cut out of an ACC drive). A log without a mode is ``acc`` when its
ACC state was Active at some sample, else ``manual``; an unknown mode is a
:class:`TripModeError`; the one classifier (the spool's, the ingest's, the learner's) is
:func:`dbc.vocab.triplog.trip_mode`.
"""

from __future__ import annotations

from enum import StrEnum

from dbc.vocab import FormatError


class TripModeError(FormatError):
    """A trip log's ``meta["mode"]`` is not one of the known trip modes."""


class TripMode(StrEnum):
    """How a trip was driven; the value is the ``meta["mode"]`` string of its trip log."""

    MANUAL = "manual"
    ACC = "acc"
    TAKEOVER = "takeover"

    @property
    def acc_on(self) -> bool:
        """Whether the ACC was on during the trip (``acc`` or ``takeover``)."""
        return self is not TripMode.MANUAL
