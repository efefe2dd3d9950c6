"""Trip modes: how a trip log was driven, and the one rule that classifies a trip.

A trip log's ``meta["mode"]`` says how it was driven (:class:`TripMode`):

- ``manual``: the driver drove with the ACC off (a demonstration for the learner);
- ``acc``: the ACC drove (the whole trip, the driver's takeovers inside it);
- ``takeover``: one takeover segment the ECU's recorder cut out of an ACC drive.

A trip log **without** a mode (an older or foreign file) is classified by what it records:
``acc`` when its ACC state was Active at some sample (the ECU drove part of it), else
``manual``. A mode that is none of the three is a :class:`TripModeError`, never a guess.

The vehicle's spool, the cloud's ingest and the learner
(:func:`cloud_sync.irl.demos.is_acc_trip`) all classify through :func:`mode_of`
(:func:`dbc.vocab.triplog.trip_mode` for a ``Trip``).
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

import numpy as np

from dbc.vocab import FormatError
from dbc.vocab.acc_state import AccState


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


def mode_of(meta: dict[str, Any], acc_state: np.ndarray) -> TripMode:
    """The trip mode from a trip's ``meta`` and its ACC-state column (n,).

    Raises:
        TripModeError: ``meta["mode"]`` is given but is not a :class:`TripMode` value.
    """
    mode = meta.get("mode")
    if mode is None:
        active = np.asarray(acc_state) == int(AccState.ACTIVE)
        return TripMode.ACC if bool(np.any(active)) else TripMode.MANUAL
    try:
        return TripMode(mode)
    except ValueError:
        known = ", ".join(m.value for m in TripMode)
        raise TripModeError(f"unknown trip mode {mode!r} (known: {known})") from None


__all__ = ["TripMode", "TripModeError", "mode_of"]
