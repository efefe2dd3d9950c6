"""Lead speed profiles (10 Hz): the paper's stochastic generator (section IV-A) over the real data.

A random sequence of average speeds, each matched by a random real leader segment of that
mean (else the nearest one scaled, the scale recorded), concatenated and filtered to bounded
accelerations. Every profile records where its pieces come from. :func:`canonical_profiles`:
``manual1``..``manual4`` (5-30 m/s), ``A`` (seen: from the manual profiles, 30 to 5 m/s) and
``B`` (unseen), 300 s each.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from sim_bus.dataset import load_human_pairs
from sim_bus.errors import ScenarioError
from sim_bus.lead.profile import DT_S, LeadProfile, SegmentRef


@dataclass(frozen=True)
class GeneratorConfig:
    """Stochastic generator settings."""

    segment_s: float = 20.0
    stride_s: float = 1.0
    tolerance_mps: float = 1.5
    accel_max_mps2: float = 2.0
    decel_max_mps2: float = 3.0
    smooth_s: float = 1.0
    duration_s: float = 300.0
    max_spread_mps: float = 8.0

    @property
    def n_segments(self) -> int:
        """How many segments of ``segment_s`` cover ``duration_s`` with one to spare."""
        return int(np.ceil(self.duration_s / self.segment_s)) + 1


@dataclass(frozen=True)
class _Library:
    """All usable speed windows of the sources: source index, start sample, mean speed."""

    names: tuple[str, ...]
    speeds: tuple[np.ndarray, ...]
    source_index: np.ndarray
    start: np.ndarray
    mean_mps: np.ndarray
    length: int


def _library(sources: list[tuple[str, np.ndarray]], cfg: GeneratorConfig) -> _Library:
    """Index every window of ``cfg.segment_s`` (stride ``cfg.stride_s``) of the sources but
    those touching standstill (< 1 m/s) or spreading more than ``max_spread_mps``."""
    n = int(round(cfg.segment_s / DT_S))
    stride = max(1, int(round(cfg.stride_s / DT_S)))
    idx_l, start_l, mean_l = [], [], []
    for i, (_, v) in enumerate(sources):
        if len(v) < n:
            continue
        starts = np.arange(0, len(v) - n + 1, stride)
        windows = np.lib.stride_tricks.sliding_window_view(v, n)[starts]
        keep = (windows.min(axis=1) >= 1.0) & (np.ptp(windows, axis=1) <= cfg.max_spread_mps)
        idx_l.append(np.full(int(keep.sum()), i))
        start_l.append(starts[keep])
        mean_l.append(windows[keep].mean(axis=1))
    if not idx_l or sum(len(x) for x in idx_l) == 0:
        raise ScenarioError("the sources hold no usable segment of the requested length")
    return _Library(
        tuple(name for name, _ in sources),
        tuple(v for _, v in sources),
        np.concatenate(idx_l),
        np.concatenate(start_l),
        np.concatenate(mean_l),
        n,
    )


def bound_filter(v_mps: np.ndarray, cfg: GeneratorConfig) -> np.ndarray:
    """Rate-limit to [−decel_max, accel_max]·Δt per sample, then a centred moving average
    (which keeps the bounds); float64 (n,), speeds >= 0 m/s."""
    out = np.empty_like(v_mps, dtype=np.float64)
    up, down = cfg.accel_max_mps2 * DT_S, cfg.decel_max_mps2 * DT_S
    prev = float(v_mps[0])
    for i, x in enumerate(v_mps.tolist()):
        prev = min(max(x, prev - down), prev + up)
        out[i] = prev
    k = max(1, int(round(cfg.smooth_s / DT_S)))
    if k > 1 and len(out) > k:
        padded = np.concatenate([np.full(k // 2, out[0]), out, np.full(k - 1 - k // 2, out[-1])])
        out = np.convolve(padded, np.ones(k) / k, mode="valid")
    return np.maximum(out, 0.0)


def synthesize(
    speeds_mps: np.ndarray,
    seed: int,
    name: str,
    cfg: GeneratorConfig | None = None,
    sources: list[tuple[str, np.ndarray]] | None = None,
) -> LeadProfile:
    """Random segments matching each average speed of ``speeds_mps`` (k,), m/s, cut from
    ``sources`` (named 10-Hz traces; default the real leaders), concatenated, bound-filtered
    and trimmed to ``cfg.duration_s``."""
    cfg = cfg or GeneratorConfig()
    speeds = np.asarray(speeds_mps, dtype=np.float64)
    if speeds.ndim != 1 or len(speeds) == 0 or not np.all(np.isfinite(speeds)):
        raise ScenarioError("the speed sequence must be a non-empty 1-D array of finite values")
    if np.any(speeds <= 0):
        raise ScenarioError("average speeds must be > 0 m/s")
    if sources is None:
        sources = [(p.pair_id, p.v_leader_mps) for p in load_human_pairs()]
    lib = _library(sources, cfg)
    rng = np.random.default_rng(seed)
    pieces: list[np.ndarray] = []
    refs: list[SegmentRef] = []
    for target in speeds.tolist():
        err = np.abs(lib.mean_mps - target)
        ok = np.flatnonzero(err <= cfg.tolerance_mps)
        # a random matching segment, else the nearest one scaled to the target
        j = int(ok[rng.integers(len(ok))]) if len(ok) else int(np.argmin(err))
        scale = 1.0 if len(ok) else target / float(lib.mean_mps[j])
        src = int(lib.source_index[j])
        s = int(lib.start[j])
        pieces.append(scale * lib.speeds[src][s : s + lib.length])
        refs.append(SegmentRef(lib.names[src], s, lib.length, scale))
    raw = np.concatenate(pieces)
    n = int(round(cfg.duration_s / DT_S)) + 1
    if len(raw) < n:
        raise ScenarioError(
            f"{len(speeds)} segments of {cfg.segment_s} s are shorter than {cfg.duration_s} s"
        )
    raw = raw[:n]
    return LeadProfile(name, np.arange(n) * DT_S, bound_filter(raw, cfg), tuple(refs), raw)


def random_speed_sequence(
    lo_mps: float, hi_mps: float, n: int, rng: np.random.Generator, max_step_mps: float = 5.0
) -> np.ndarray:
    """A bounded random walk of ``n`` average speeds (n,), m/s, steps up to ``max_step_mps``,
    stretched to visit both ``lo_mps`` and ``hi_mps``."""
    if not (0 < lo_mps < hi_mps) or n < 2:
        raise ScenarioError("need 0 < lo < hi and at least two speeds")
    x = np.empty(n)
    x[0] = rng.uniform(lo_mps, hi_mps)
    for i in range(1, n):
        x[i] = np.clip(x[i - 1] + rng.uniform(-max_step_mps, max_step_mps), lo_mps, hi_mps)
    span = x.max() - x.min()
    if span < 1e-9:
        return np.linspace(lo_mps, hi_mps, n)
    scaled: np.ndarray = lo_mps + (x - x.min()) * (hi_mps - lo_mps) / span
    return scaled


#: speed ranges of the four manual-driving profiles (m/s); together they cover 5-30 m/s
MANUAL_RANGES_MPS: tuple[tuple[float, float], ...] = (
    (5.0, 12.0),
    (10.0, 18.0),
    (16.0, 24.0),
    (22.0, 30.0),
)


def canonical_profiles(seed: int = 0) -> dict[str, LeadProfile]:
    """The evaluation set of ``seed`` >= 0 (else ScenarioError): cached, arrays read-only."""
    if not seed >= 0:
        raise ScenarioError(f"a seed is an integer >= 0, got {seed}")
    return dict(_canonical_profiles(int(seed)))


@lru_cache(maxsize=8)
def _canonical_profiles(seed: int) -> dict[str, LeadProfile]:
    cfg = GeneratorConfig()
    n_seg = cfg.n_segments
    ss = np.random.SeedSequence(seed)
    children = ss.spawn(len(MANUAL_RANGES_MPS) + 1)
    out: dict[str, LeadProfile] = {}
    manual: list[LeadProfile] = []
    for k, (lo, hi) in enumerate(MANUAL_RANGES_MPS):
        rng = np.random.default_rng(children[k])
        seq = random_speed_sequence(lo, hi, n_seg, rng, max_step_mps=3.0)
        prof = synthesize(seq, int(rng.integers(2**31)), f"manual{k + 1}", cfg)
        manual.append(prof)
        out[prof.name] = prof
    # A, seen: segments of the manual profiles, average speed from 30 down to 5 m/s
    seed_a = int(np.random.default_rng(children[-1]).integers(2**31))
    sources = [(p.name, p.v_lead_mps) for p in manual]
    out["A"] = synthesize(np.linspace(30.0, 5.0, n_seg), seed_a, "A", cfg, sources)
    rng = np.random.default_rng(ss.spawn(1)[0])
    seq = random_speed_sequence(5.0, 30.0, n_seg, rng, max_step_mps=6.0)
    out["B"] = synthesize(seq, int(rng.integers(2**31)), "B", cfg)
    for prof in out.values():
        for arr in (prof.t_s, prof.v_lead_mps, prof.raw_v_mps):
            if arr is not None:
                arr.flags.writeable = False
    return out


def shorten(profile: LeadProfile, duration_s: float) -> LeadProfile:
    """The first ``duration_s`` seconds (>= 0.1 s, else ScenarioError; inf: all) of a
    profile."""
    if not duration_s >= DT_S:  # NaN too
        raise ScenarioError(
            f"a drive lasts at least one profile step ({DT_S} s), not {duration_s} s"
        )
    n = len(profile.t_s) if duration_s >= profile.duration_s else int(round(duration_s / DT_S)) + 1
    raw = None if profile.raw_v_mps is None else profile.raw_v_mps[:n]
    end = float(profile.t_s[n - 1])
    events = tuple(e for e in profile.events if e.t_s <= end)
    return replace(
        profile,
        t_s=profile.t_s[:n],
        v_lead_mps=profile.v_lead_mps[:n],
        raw_v_mps=raw,
        events=events,
    )
