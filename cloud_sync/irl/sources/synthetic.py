"""A synthetic car follower with a known gap preference ``g*(v)`` (m), for the IRL tests and
bench/sync.py: ``a = k_g·(g − g*(v)) + k_v·(v_lead − v) + ε`` (m/s², ε AR(1)) behind a lead
ramping between random speeds, all drawn from a seeded Generator.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from dbc.vocab.triplog import Trip


def lead_speed(rng: np.random.Generator, n: int, dt: float, v_lo: float, v_hi: float) -> np.ndarray:
    """Lead speed (n,), m/s: a new random target every 30 s, approached at ≤ 1 m/s²."""
    v = np.empty(n)
    cur = float(rng.uniform(v_lo, v_hi))
    tgt = cur
    for i in range(n):
        if i % 300 == 0:
            tgt = float(rng.uniform(v_lo, v_hi))
        cur = max(cur + float(np.clip(0.3 * (tgt - cur), -1.0, 0.8)) * dt, 0.0)
        v[i] = cur
    return v


def follower_trip(
    seed: int,
    *,
    d0: float = 4.0,
    headway_s: float = 1.6,
    minutes: float = 5.0,
    v_lo: float = 5.0,
    v_hi: float = 30.0,
    noise: float = 0.3,
    preference: Callable[[float], float] | None = None,
) -> Trip:
    """A 10 Hz manual trip of the synthetic follower (preference ``d0 + headway_s·v``, or
    ``preference(v)`` in m for v in m/s when given)."""

    def want(v_mps: float) -> float:
        return preference(v_mps) if preference is not None else d0 + headway_s * v_mps

    dt = 0.1
    rng = np.random.default_rng(seed)
    n = int(minutes * 60 / dt)
    vl = lead_speed(rng, n, dt, v_lo, v_hi)
    v, g, a = np.empty(n), np.empty(n), np.empty(n)
    v[0], g[0] = vl[0], want(float(vl[0]))
    eps = 0.0
    for i in range(n):
        eps = 0.95 * eps + noise * np.sqrt(1 - 0.95**2) * float(rng.normal())
        acc = 0.08 * (g[i] - want(float(v[i]))) + 0.5 * (vl[i] - v[i]) + eps
        a[i] = float(np.clip(acc, -3.5, 2.0))
        if i + 1 < n:
            v[i + 1] = max(v[i] + a[i] * dt, 0.0)
            g[i + 1] = g[i] + (vl[i] - v[i]) * dt
    return Trip(
        t_s=np.arange(n) * dt,
        v_mps=v,
        gap_m=g,
        v_lead_mps=vl,
        a_mps2=a,
        accel_pedal=np.zeros(n),
        brake_pedal=np.zeros(n),
        acc_state=np.zeros(n, dtype=np.int64),
        meta={"driver_id": "syn", "mode": "manual", "seed": seed},
    )
