"""Benchmark: the MCAP bus recorder against python-can's BLF writer, and its cost to a drive.

Run: ``.venv/bin/python bench/canlog.py [--sim-s 120] [--repeats 3]``.

- frames: the frames of one lockstep drive (scenario B, driver d2, predefined+OA,
  ``--sim-s`` simulated seconds), read back from its recording as python-can messages;
- recorder: :class:`ecu.buslog.writer.CanLogWriter` writing them all — ``/can/raw`` blocks,
  one protobuf message per decoded frame, a zstd chunk ended every 1 s of message time (the
  crash-safety flush), the decoded rows built every 10 s — frames per second and bytes per
  frame;
- the named peer: python-can's ``can.BLFWriter`` (zlib-compressed Vector BLF, raw frames
  only) on the same messages, same measures;
- the drive: ``run_drive`` without ``can_log``, with it as pacc records by default (on the
  drive's thread), and with ``PACC_RECORDER_PROCESS=1`` (the file written by the recorder's
  writer process, :mod:`ecu.buslog.process.remote`), alternating, ``--repeats`` each; the real-time
  factors (simulated s per wall s of the whole call) and their ratios to off; the same against
  the drive thread's own CPU time (``time.thread_time``: what the recording costs the thread
  that runs the drive, whatever else loads the machine; the wall clock still waits for a
  writer process when no core is free); the writer process's CPU time per recorded drive;
  and the bench process's first recording with ``PACC_RECORDER_PROCESS=1`` (a writer started
  and waited for, about 0.2 s, inside the drive's call).

Best of ``--repeats`` for the writers and for the drives' real-time factors (the machine is
shared: the best run is the one least disturbed), the medians printed beside.
The last line is ``canlog: N x python-can BLF writer``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import can

from dbc.codec import load_codec
from ecu.buslog.format import TimeBase
from ecu.buslog.process import writers
from ecu.buslog.reader import messages, read_canlog
from ecu.buslog.recording import PROCESS_ENV
from ecu.buslog.writer import CanLogWriter
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS


def _drive(sim_s: float, can_log: Path | None, process: bool = True) -> tuple[float, float]:
    """One drive; its real-time factors over the whole ``run_drive`` call (the recorder's
    opening, its last blocks and the simulated world included, not only the loop): against
    the wall clock and the calling thread's CPU time (less disturbed by the machine's other
    loads). ``process``: a file recording goes to a writer process
    (``PACC_RECORDER_PROCESS=1``), else on the drive's thread."""
    os.environ[PROCESS_ENV] = "1" if process else "0"
    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(
        scenario="B", driver_id="d2", controller="predefined+oa", seed=1, duration_s=sim_s
    )
    table = predefined_table(driver)
    start, own = time.perf_counter(), time.thread_time()
    result = run_drive(cfg, driver, table, can_log=can_log)
    wall_s, own_s = time.perf_counter() - start, time.thread_time() - own
    return result.sim_s / wall_s, result.sim_s / own_s


def _writers_cpu_s() -> float:
    """CPU time (user + system) of this process's idle writer processes so far, s (Linux's
    /proc; 0 elsewhere)."""
    total = 0.0
    for proc in writers._idle:
        try:
            fields = Path(f"/proc/{proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


def _blf(msgs: list[can.Message], path: Path) -> float:
    start = time.perf_counter()
    writer = can.BLFWriter(path)
    for m in msgs:
        writer.on_message_received(m)
    writer.stop()
    return time.perf_counter() - start


def _mcap(msgs: list[can.Message], path: Path) -> float:
    db = load_codec().db
    start = time.perf_counter()
    writer = CanLogWriter(path, db, TimeBase(0, 0.0), node="bench")
    for m in msgs:
        writer.frame(m.timestamp, m, m.is_rx)
        writer.tick(m.timestamp)
    writer.close()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim-s", type=float, default=120.0, help="simulated s per drive")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each side")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _drive(args.sim_s, None)  # warm: imports, caches
        cold = _drive(args.sim_s, d / "drive.mcap")  # the first with a writer: it starts one
        msgs = list(messages(read_canlog(d / "drive.mcap")))
        n = len(msgs)
        blf_s = min(_blf(msgs, d / "x.blf") for _ in range(args.repeats))
        mcap_s = min(_mcap(msgs, d / "x.mcap") for _ in range(args.repeats))
        blf_b = (d / "x.blf").stat().st_size / n
        mcap_b = (d / "x.mcap").stat().st_size / n
        off: list[tuple[float, float]] = []
        on: list[tuple[float, float]] = []
        thread: list[tuple[float, float]] = []
        writer_s = 0.0
        for _ in range(args.repeats):
            off.append(_drive(args.sim_s, None))
            before = _writers_cpu_s()
            on.append(_drive(args.sim_s, d / "drive.mcap"))
            writer_s += _writers_cpu_s() - before
            thread.append(_drive(args.sim_s, d / "drive.mcap", process=False))
    rt_off, rt_thr, rt_on = (max(x[0] for x in runs) for runs in (off, thread, on))
    med_off, med_thr = (statistics.median(x[0] for x in runs) for runs in (off, thread))
    own_off, own_thr, own_on = (max(x[1] for x in runs) for runs in (off, thread, on))
    print(f"frames: {n} of a {args.sim_s:g}-s drive (scenario B, d2, predefined+oa)")
    print(f"python-can BLFWriter:           {n / blf_s:10,.0f} frames/s  {blf_b:6.2f} bytes/frame")
    print(
        f"pacc recorder (raw + decoded):  {n / mcap_s:10,.0f} frames/s  {mcap_b:6.2f} bytes/frame"
        f"  ({mcap_b / blf_b:.2f}x BLF's bytes)"
    )
    print(
        f"drive real-time factor, best: {rt_off:.1f}x recording off, {rt_thr:.1f}x on "
        f"({rt_thr / rt_off:.3f} of off); median: {med_off:.1f}x off, {med_thr:.1f}x on "
        f"({med_thr / med_off:.3f} of off); on the drive thread's CPU time: {own_off:.1f}x off, "
        f"{own_thr:.1f}x on ({own_thr / own_off:.3f} of off)"
    )
    print(
        f"with PACC_RECORDER_PROCESS=1 (a writer process), best: {rt_on:.1f}x "
        f"({rt_on / rt_off:.3f} of off); on the drive thread's CPU time {own_on:.1f}x "
        f"({own_on / own_off:.3f} of off); the writer process: "
        f"{1e3 * writer_s / args.repeats:.1f} ms of CPU per recorded drive (mean)"
    )
    print(
        f"the process's first recording with PACC_RECORDER_PROCESS=1 (a writer started and "
        f"waited for): {cold[0]:.1f}x ({cold[0] / rt_off:.3f} of the best off)"
    )
    print(f"canlog: {blf_s / mcap_s:.2f}x python-can BLF writer")


if __name__ == "__main__":
    main()
