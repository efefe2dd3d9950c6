"""Demonstrations: from trips to the segments, feature counts and start states IRL needs.

A sample is usable when the driver is in control (``acc_state`` not Active; in an ACC trip
only after the first engagement), a lead is present (gap 0..``max_gap_m`` m) and the speeds are
finite within 0..70 m/s. Trips are resampled at the decision interval at every phase offset;
the action is ``(v[t+1] − v[t])/dt`` (m/s²); usable runs are cut into segments of at most
``horizon`` steps; in an ACC trip a run shorter than a step (a short takeover) is one decision,
its first state and its mean acceleration. :func:`takeover_weighted` weighs ACC-trip
corrections above manual drives.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from cloud_sync.errors import DemoError
from cloud_sync.irl.mce_irl import CompiledMdp, DemoStats
from cloud_sync.irl.mdp import interp_weights
from dbc.vocab.acc_state import AccState
from dbc.vocab.triplog import Trip, trip_mode

MAX_SPEED_MPS = 70.0  # faster samples are sensor garbage, not car following


@dataclass(frozen=True)
class Samples:
    """The usable samples of a set of trips, (k,) each: speed, gap, ``v_lead − v``, ego
    acceleration (+inf where none: never steady), the time each stands for (s)."""

    v_mps: np.ndarray
    gap_m: np.ndarray
    dv_mps: np.ndarray
    a_mps2: np.ndarray
    dt_s: np.ndarray


@dataclass(frozen=True)
class Transitions:
    """Demonstrated state-action pairs, (n,) each: the state, the action ``a_mps2``, ``pos``
    the steps to go within the segment (``h`` at a segment's start), the trip weight."""

    v_mps: np.ndarray
    gap_m: np.ndarray
    dv_mps: np.ndarray
    a_mps2: np.ndarray
    pos: np.ndarray
    seg_len: np.ndarray
    weight: np.ndarray

    @property
    def n(self) -> int:
        """Number of pairs."""
        return int(self.v_mps.size)


def is_acc_trip(trip: Trip) -> bool:
    """Whether ``trip`` was driven with the ACC on (trip mode ``acc`` or ``takeover``,
    :func:`dbc.vocab.tripmode.trip_mode`)."""
    return trip_mode(trip).acc_on


def usable_mask(trip: Trip, max_gap_m: float) -> np.ndarray:
    """Boolean (n,): the driver is in control and following a lead (module docstring)."""
    in_control = trip.acc_state != AccState.ACTIVE  # Active: the ECU drives, not the driver
    if is_acc_trip(trip):
        engaged = np.cumsum(trip.acc_state == AccState.ACTIVE) > 0
        in_control = in_control & engaged
    with np.errstate(invalid="ignore"):
        return np.asarray(
            in_control
            & np.isfinite(trip.v_mps)
            & np.isfinite(trip.gap_m)
            & np.isfinite(trip.v_lead_mps)
            & (trip.v_mps >= -0.5)
            & (trip.v_mps <= MAX_SPEED_MPS)
            & (np.abs(trip.v_lead_mps) <= MAX_SPEED_MPS)
            & (trip.gap_m >= 0.0)
            & (trip.gap_m <= max_gap_m)
        )


def pooled_samples(trips: Sequence[Trip], max_gap_m: float) -> Samples:
    """The usable samples (:func:`usable_mask`) of every trip with two samples or more."""
    cols: dict[str, list[np.ndarray]] = {k: [] for k in Samples.__dataclass_fields__}
    for trip in trips:
        if len(trip) < 2:
            continue
        m = usable_mask(trip, max_gap_m)
        dt = np.diff(trip.t_s, append=trip.t_s[-1] + np.median(np.diff(trip.t_s)))
        a = np.where(np.isfinite(trip.a_mps2), trip.a_mps2, np.inf)
        cols["v_mps"].append(trip.v_mps[m])
        cols["gap_m"].append(trip.gap_m[m])
        cols["dv_mps"].append((trip.v_lead_mps - trip.v_mps)[m])
        cols["a_mps2"].append(a[m])
        cols["dt_s"].append(dt[m])
    return Samples(**{k: np.concatenate(v) if v else np.zeros(0) for k, v in cols.items()})


def check_demos(
    trips: Sequence[Trip], *, max_gap_m: float, min_total_s: float, dt_s: float = 1.0
) -> float:
    """The usable seconds; DemoError for no trip, one under two samples or NaN-filled, a
    sample period not dividing ``dt_s`` (s), or under ``min_total_s`` s usable in all."""
    if len(trips) == 0:
        raise DemoError("no demonstrations given (empty list of trips)")
    total = 0.0
    for i, trip in enumerate(trips):
        name = trip.meta.get("source") or trip.meta.get("scenario") or f"trip {i}"
        if len(trip) < 2:
            raise DemoError(f"{name}: empty demonstration ({len(trip)} samples)")
        finite = np.isfinite(trip.v_mps) & np.isfinite(trip.gap_m) & np.isfinite(trip.v_lead_mps)
        if not finite.any():
            raise DemoError(f"{name}: demonstration is NaN-filled (no finite speed/gap sample)")
        dt = float(np.median(np.diff(trip.t_s)))
        stride = max(int(round(dt_s / dt)), 1)
        if abs(stride * dt - dt_s) > 0.1 * dt_s:
            raise DemoError(
                f"{name}: sampled every {dt:g} s, which does not divide the {dt_s:g} s decision "
                "interval (resample the trip, e.g. to 10 Hz)"
            )
        total += float(usable_mask(trip, max_gap_m).sum()) * dt
    if total < min_total_s:
        raise DemoError(
            f"demonstrations too short: {total:.1f} s of usable car following "
            f"(driver in control, lead within range), need at least {min_total_s:.0f} s"
        )
    return total


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges of True runs in ``mask`` (1-D bool)."""
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def extract_transitions(
    trips: Sequence[Trip], weights: Sequence[float], *, dt_s: float, horizon: int, max_gap_m: float
) -> Transitions:
    """All demonstrated state-action pairs of ``trips`` at decision interval ``dt_s``."""
    cols: dict[str, list[np.ndarray]] = {k: [] for k in Transitions.__dataclass_fields__}
    for trip, w in zip(trips, weights, strict=True):
        if len(trip) < 2:
            continue
        sample_dt = float(np.median(np.diff(trip.t_s)))
        stride = max(int(round(dt_s / sample_dt)), 1)
        ok = usable_mask(trip, max_gap_m)
        for offset in range(stride):
            idx = np.arange(offset, len(trip), stride)
            good = ok[idx]
            # a step is valid when both ends are usable and evenly spaced in time
            step_ok = good[:-1] & good[1:]
            step_ok &= np.abs(np.diff(trip.t_s[idx]) - stride * sample_dt) < 0.5 * sample_dt
            for start, stop in true_runs(step_ok):
                i0 = idx[start:stop]
                i1 = idx[start + 1 : stop + 1]
                m = stop - start
                k = np.arange(m)
                seg_start = (k // horizon) * horizon
                seg_len = np.minimum(horizon, m - seg_start)
                cols["v_mps"].append(trip.v_mps[i0])
                cols["gap_m"].append(trip.gap_m[i0])
                cols["dv_mps"].append(trip.v_lead_mps[i0] - trip.v_mps[i0])
                cols["a_mps2"].append((trip.v_mps[i1] - trip.v_mps[i0]) / (stride * sample_dt))
                cols["pos"].append(seg_len - (k - seg_start))
                cols["seg_len"].append(seg_len)
                cols["weight"].append(np.full(m, float(w)))
        if is_acc_trip(trip):  # a takeover shorter than a step is one decision
            for a, b in true_runs(ok):
                span_s = float(trip.t_s[b - 1] - trip.t_s[a])
                if b - a > stride or span_s <= 0.0:
                    continue  # stepped above, or a single sample
                for name, value in (
                    ("v_mps", trip.v_mps[a]),
                    ("gap_m", trip.gap_m[a]),
                    ("dv_mps", trip.v_lead_mps[a] - trip.v_mps[a]),
                    ("a_mps2", (trip.v_mps[b - 1] - trip.v_mps[a]) / span_s),
                    ("pos", 1),
                    ("seg_len", 1),
                    ("weight", float(w)),
                ):
                    cols[name].append(np.array([value], dtype=np.float64))
    arrays = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in cols.items()}
    arrays["pos"] = arrays["pos"].astype(np.int64)
    arrays["seg_len"] = arrays["seg_len"].astype(np.int64)
    return Transitions(**arrays)


def demo_stats(mdp: CompiledMdp, tr: Transitions, horizon: int) -> DemoStats:
    """Weighted per-segment feature counts and start distributions of ``tr`` on ``mdp``,
    spread on the grid as the transitions are (the (v, g) counts weighted by κ(dv))."""
    if tr.n == 0:
        raise DemoError("no usable state-action pair in the demonstrations")
    grid, feats = mdp.grid, mdp.features
    n_v, n_g, n_dv = grid.shape
    starts = tr.pos == tr.seg_len
    w_total = float(tr.weight[starts].sum())
    w = tr.weight / w_total
    vi0, vi1, wv = interp_weights(grid.v_mps, tr.v_mps)
    gi0, gi1, wg = interp_weights(grid.gap_m, tr.gap_m)
    di0, di1, wd = interp_weights(grid.dv_mps, tr.dv_mps)
    ai0, ai1, wa = interp_weights(grid.accels_mps2, tr.a_mps2)
    m_vg = np.zeros((n_v, n_g))
    k_dv = (1 - wd) * feats.k_dv[di0] + wd * feats.k_dv[di1]
    p0 = np.zeros((horizon, grid.n_states))
    for vi, vw in ((vi0, 1 - wv), (vi1, wv)):
        for gi, gw in ((gi0, 1 - wg), (gi1, wg)):
            np.add.at(m_vg, (vi, gi), w * vw * gw * k_dv)
            for di, dw in ((di0, 1 - wd), (di1, wd)):
                s = (vi * n_g + gi) * n_dv + di
                np.add.at(p0, (tr.seg_len[starts] - 1, s[starts]), (w * vw * gw * dw)[starts])
    f_dv = (1 - wd) * feats.f_dv[di0] + wd * feats.f_dv[di1]
    f_a = (1 - wa) * feats.f_a[ai0] + wa * feats.f_a[ai1]
    mu = np.concatenate([feats.counts(m_vg), [float(w @ f_dv), float(w @ f_a)]])
    return DemoStats(mu=mu, p0=p0, n_segments=int(starts.sum()))


def digest(trips: Sequence[Trip], weights: Sequence[float]) -> str:
    """SHA-256 (hex) of the training data: every trip's arrays and weight, in order."""
    h = hashlib.sha256()
    for trip, w in zip(trips, weights, strict=True):
        for name in ("t_s", "v_mps", "gap_m", "v_lead_mps", "a_mps2", "acc_state"):
            h.update(np.ascontiguousarray(getattr(trip, name)).tobytes())
        h.update(np.float64(w).tobytes())
    return h.hexdigest()


def takeover_weighted(trips: Sequence[Trip], takeover_weight: float) -> list[float]:
    """Per-trip weights: ``takeover_weight`` for ACC trips (their usable samples are the
    driver's takeovers), 1 for manual drives."""
    return [takeover_weight if is_acc_trip(t) else 1.0 for t in trips]
