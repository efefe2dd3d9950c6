"""``pacc plot LOG -o fig.png``: one recorded drive over time, from a bus recording.

Five panels sharing the time axis (s from the start of the recording, its UTC start in the
title): ego and lead speed; the gap and the ECU's desired gap; the pedals (0..1); the ACC's
acceleration request while active; the ACC state. The values are the ECU's own
(``/ecu/inputs``, ``/ecu/outputs``: what it saw and did each cycle); a recording without
them (``pacc sim``) is drawn from the simulated world (``/sim/world``), the driver's
preferred gap in place of the desired one. Drawn on a bare matplotlib Figure (no pyplot).
Exit status: 0, 2 on a bad recording or one with nothing to draw.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ecu import EcuError
from ecu.buslog.format import INPUTS_TOPIC, OUTPUTS_TOPIC, WORLD_TOPIC, CanLogError
from ecu.buslog.reader import CanLog, read_canlog
from pacc.commands._args import integer
from pacc.vocab import FormatError
from pacc.vocab.acc_state import AccState


@dataclass(frozen=True)
class Traces:
    """The curves of one plot; arrays of shape ``(n,)`` on the time ``t_s``."""

    t_s: np.ndarray
    v_mps: np.ndarray
    v_lead_mps: np.ndarray
    gap_m: np.ndarray
    target_gap_m: np.ndarray
    target_label: str
    accel_pedal: np.ndarray
    brake_pedal: np.ndarray
    request_mps2: np.ndarray
    acc_state: np.ndarray
    source: str


def traces(log: CanLog) -> Traces:
    """The curves of ``log``: the ECU's inputs and outputs, else the simulated world.

    Raises:
        CanLogError: the recording holds neither.
    """
    if INPUTS_TOPIC in log.series and OUTPUTS_TOPIC in log.series:
        i, o = log.series[INPUTS_TOPIC], log.series[OUTPUTS_TOPIC]
        lead = i["lead_valid"] > 0
        return Traces(
            t_s=i["t_s"],
            v_mps=i["v_mps"],
            v_lead_mps=np.where(lead, i["v_mps"] + i["rel_speed_mps"], np.nan),
            gap_m=np.where(lead, i["gap_m"], np.nan),
            target_gap_m=o["desired_gap_m"],
            target_label="desired gap (DGPT)",
            accel_pedal=i["accel_pedal"],
            brake_pedal=i["brake_pedal"],
            request_mps2=np.where(o["request_active"] > 0, o["accel_request_mps2"], np.nan),
            acc_state=o["acc_state"],
            source="the ECU's inputs and outputs",
        )
    if WORLD_TOPIC in log.series:
        w = log.series[WORLD_TOPIC]
        return Traces(
            t_s=w["t_s"],
            v_mps=w["v_mps"],
            v_lead_mps=w["v_lead_mps"],
            gap_m=w["gap_m"],
            target_gap_m=w["pref_gap_m"],
            target_label="driver's preferred gap",
            accel_pedal=np.clip(w["accel_pct"] / 100.0, 0.0, 1.0),
            brake_pedal=(w["brake_pressed"] > 0).astype(np.float64),
            request_mps2=np.where(w["request_active"] > 0, w["a_request_mps2"], np.nan),
            acc_state=w["acc_state"],
            source="the simulated world",
        )
    raise CanLogError(
        f"{log.path}: nothing to plot (no {INPUTS_TOPIC}/{OUTPUTS_TOPIC} or {WORLD_TOPIC}; "
        f"topics: {', '.join(log.topics)})"
    )


def plot(log: CanLog, out: Path, dpi: int = 120) -> None:
    """Draw ``log`` (:func:`traces`) into the PNG ``out``."""
    from matplotlib.figure import Figure  # noqa: PLC0415 - matplotlib only when drawing

    tr = traces(log)
    t = tr.t_s - tr.t_s[0] if len(tr.t_s) else tr.t_s
    fig = Figure(figsize=(10, 9), constrained_layout=True)
    ax = fig.subplots(5, 1, sharex=True, height_ratios=(3, 3, 2, 2, 1.5))
    ax[0].plot(t, tr.v_mps, label="ego")
    ax[0].plot(t, tr.v_lead_mps, label="lead", alpha=0.8)
    ax[0].set_ylabel("speed, m/s")
    ax[1].plot(t, tr.gap_m, label="gap")
    ax[1].plot(t, tr.target_gap_m, label=tr.target_label, linestyle="--")
    ax[1].set_ylabel("gap, m")
    ax[2].plot(t, tr.accel_pedal, label="accelerator")
    ax[2].plot(t, tr.brake_pedal, label="brake")
    ax[2].set_ylabel("pedal, 0..1")
    ax[3].plot(t, tr.request_mps2, color="tab:purple")
    ax[3].axhline(0.0, color="grey", linewidth=0.5)
    ax[3].set_ylabel("request, m/s²")
    ax[4].step(t, tr.acc_state, where="post", color="black")
    ax[4].set_yticks([int(s) for s in AccState], [s.name for s in AccState], fontsize=7)
    ax[4].set_ylabel("ACC")
    ax[4].set_xlabel("time since the start of the recording, s")
    for a in ax[:3]:
        a.legend(loc="upper right", fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    start = log.metadata.get("pacc", {}).get("start_utc", "?")
    fig.suptitle(f"{log.path.name}: {log.node or '?'} from {start} UTC ({tr.source})", fontsize=10)
    fig.savefig(out, dpi=dpi)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="pacc plot",
        description="plot one recorded drive: speed, gap vs desired gap, pedals, ACC request "
        "and state over time",
    )
    p.add_argument("log", type=Path, metavar="LOG", help="a pacc bus recording (.mcap)")
    p.add_argument("-o", "--out", type=Path, required=True, help="the PNG to write")
    p.add_argument(
        "--dpi", type=integer(10, 1200), default=120, help="resolution (default 120, 10..1200)"
    )
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc plot``; returns the exit status."""
    args = _parser().parse_args(argv)
    # matplotlib appends .png to a name without a suffix: name the file it writes
    out = args.out if args.out.suffix else args.out.with_name(args.out.name + ".png")
    try:
        plot(read_canlog(args.log), out, args.dpi)
    except (EcuError, FormatError, OSError, ValueError) as exc:
        print(f"pacc plot: error: {exc}", file=sys.stderr)
        return 2
    print(f"plot: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
