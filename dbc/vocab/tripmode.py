"""Trip modes: how a trip log was driven (``meta["mode"]``), and the one classifier.

``manual`` (ACC off: a demonstration), ``acc`` (the ACC drove, takeovers inside) or
``takeover`` (one takeover cut out of an ACC drive). A log without a mode is ``acc`` when its
ACC state was Active at some sample, else ``manual``; an unknown mode is a
:class:`TripModeError`. The spool, the cloud's ingest and the learner all use :func:`mode_of`.
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
    """The trip mode from a trip's ``meta`` and its ACC-state column (n,) (TripModeError: an
    unknown ``meta["mode"]``)."""
    mode = meta.get("mode")
    if mode is None:
        active = np.asarray(acc_state) == int(AccState.ACTIVE)
        return TripMode.ACC if bool(np.any(active)) else TripMode.MANUAL
    try:
        return TripMode(mode)
    except ValueError:
        known = ", ".join(m.value for m in TripMode)
        raise TripModeError(f"unknown trip mode {mode!r} (known: {known})") from None
