"""How manual car-following is sampled, shared by the ECU's recorder (:mod:`ecu.manual`) and
the bus-log extraction (:mod:`cloud_sync.irl.sources.bus_demos`): a cycle is kept ``period_s``
less half a cycle after the last kept one (:func:`keep_sample`); a manual run of at least
:data:`MANUAL_MIN_S` becomes a trip, cut at :data:`MANUAL_MAX_S`.
"""

from __future__ import annotations

#: Shortest manual stretch that becomes a trip, s (``pacc demos extract``'s default too).
MANUAL_MIN_S = 10.0
#: Longest manual trip, s: a longer stretch is handed over in pieces of this length.
MANUAL_MAX_S = 600.0
#: Round-off margin of the sampling period and of a stretch's length, s.
PERIOD_EPS_S = 1e-6


def keep_interval_s(period_s: float, cycle_s: float) -> float:
    """The least time after a kept cycle at which the next one is kept, s: ``period_s`` less
    half a cycle (``cycle_s``, s; at least :data:`PERIOD_EPS_S`)."""
    return period_s - max(0.5 * cycle_s, PERIOD_EPS_S)


def keep_sample(t_s: float, last_kept_s: float, period_s: float, cycle_s: float) -> bool:
    """Whether the cycle at ``t_s`` (s) is kept: :func:`keep_interval_s` after the last kept
    one (``last_kept_s``, s; -inf: none yet)."""
    return t_s - last_kept_s >= keep_interval_s(period_s, cycle_s)
