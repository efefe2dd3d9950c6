"""What ``pacc drive`` prints: one drive's figures as text (:func:`format_result`).

PoI and NIM (``n/a`` without ACC-ON time), min gap (m), min time-to-collision (s), the time
below 2 s TTC by whose control it was (s), RMS jerk (m/s^3), the gap error against the
driver's preference (m), takeovers, adaptations, collisions, the frames sent and faulted,
the seconds in ACC FAULT (:func:`fault_time`) and the road events played.
"""

from __future__ import annotations

import numpy as np

from dbc.vocab.acc_state import AccState
from pacc.study.drive import DriveResult


def fault_time(t_s: np.ndarray, acc_state: np.ndarray) -> tuple[float, int]:
    """Seconds the ECU spent in FAULT over a drive's log (samples at times ``t_s``, s; the
    last sample counts one period) and how often it entered FAULT."""
    fault = np.asarray(acc_state) == int(AccState.FAULT)
    if len(t_s) < 2 or not fault.any():
        return 0.0, 0
    dt = np.diff(t_s, append=t_s[-1] + (t_s[-1] - t_s[-2]))
    entries = int(fault[0]) + int(np.count_nonzero(fault[1:] & ~fault[:-1]))
    return float(dt[fault].sum()), entries


def fig(value: float, spec: str, unit: str, na: str = f"{'n/a':>7}") -> str:
    """``value`` formatted with its unit, or ``na`` (no ACC-ON time: no PoI, no NIM)."""
    return f"{value:{spec}}{unit}" if np.isfinite(value) else na


def format_result(r: DriveResult) -> str:
    """The human-readable report printed by ``pacc drive``."""
    m = r.metrics
    c = r.config
    safety = r.safety()
    col = f"1 at t = {r.collision_t_s:.2f} s" if r.collision else "0"
    lines = [
        f"drive: scenario {c.scenario}, driver {c.driver_id}, controller {c.controller}"
        + (
            f" ({c.adaptation.mode} adaptation)"
            if c.adaptation is not None and c.controller.endswith("+oa")
            else ""
        )
        + f", seed {c.seed}, {r.sim_s:.1f} s simulated in {r.wall_s:.2f} s "
        f"({r.realtime_factor:.0f}x real time)",
        f"  PoI            {fig(m.poi_pct, '7.2f', ' %  ')} (ACC-ON {m.acc_on_s:.1f} s)",
        f"  NIM            {fig(m.nim_per_min, '7.2f', ' /min')} ({m.press_onsets} presses)",
        f"  min gap        {m.min_gap_m:7.2f} m",
        f"  min TTC        {m.min_ttc_s:7.2f} s",
        f"  TTC < 2 s      {safety.below_own_s:7.2f} s under the ACC, "
        f"{safety.below_override_s:.2f} s while the driver's accelerator overrode it, "
        f"{safety.below_cut_in_s:.2f} s after a cut-in that began below 2 s",
        f"  RMS jerk       {m.rms_jerk_mps3:7.3f} m/s^3",
        f"  gap error      {m.gap_error_mean_m:7.2f} m mean, {m.gap_error_rms_m:.2f} m RMS "
        "(vs. the driver's preference)",
        f"  takeovers      {r.takeovers:7d}",
        f"  adaptations    {r.adaptations:7d}",
        f"  collisions     {col}",
        f"  frames         {r.frames_sent} sent by the simulator, {r.frames_faulted} faulted; "
        f"ECU E2E errors {r.summary.e2e_errors or 'none'}",
    ]
    fault_s, entries = fault_time(r.log.t_s, r.log.acc_state)
    if c.faults or fault_s > 0:
        lines.append(f"  ACC FAULT      {fault_s:7.1f} s   ({entries} time(s) entered)")
    if r.road_events:
        played = ", ".join(
            f"{kind} at {t:.0f} s" + (f" ({gap:.1f} m)" if gap is not None else " (skipped)")
            for t, kind, gap in r.road_events
            if gap is not None or kind != "lead_loss"
        )
        losses = sum(1 for _, kind, _ in r.road_events if kind == "lead_loss")
        lines.append(f"  road events    {played}" + (f"; {losses} lead loss(es)" if losses else ""))
    return "\n".join(lines)
