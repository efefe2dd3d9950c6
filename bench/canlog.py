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
- the library paths the recorder does not take: the messages the recorder wrote (above)
  written again through ``mcap.writer.Writer.add_message`` alone (a chunk ended at each raw
  block, as the recorder does), against the recorder's whole time for them (decoding, rows,
  :class:`~ecu.buslog.mcapfile.McapFile` taking a channel's records at once); and the
  ``/ecu/outputs`` rows encoded by the protobuf runtime (one message object a row) against
  :class:`~ecu.buslog.proto.ProtoRows` (µs a row);
- the drive: ``run_drive`` without ``can_log`` and with it, alternating, ``--repeats`` each;
  the real-time factors (simulated s per wall s of the whole call) and their ratio, and the
  same against the drive thread's own CPU time (``time.thread_time``: what the recording
  costs the thread that runs the drive, whatever else loads the machine).

Best of ``--repeats`` (the machine is shared: the best run is the one least disturbed), the
medians printed beside. The last line is ``canlog: N x python-can BLF writer``.
"""

from __future__ import annotations

import argparse
import io
import statistics
import tempfile
import time
from pathlib import Path

import can
import numpy as np

from dbc.codec import load_codec
from ecu.buslog.format import OUTPUTS_TOPIC, RAW_TOPIC, TimeBase
from ecu.buslog.proto import ProtoRows
from ecu.buslog.reader import messages, read_canlog
from ecu.buslog.writer import CanLogWriter
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS


def _drive(sim_s: float, can_log: Path | None) -> tuple[float, float]:
    """One drive; its real-time factors over the whole ``run_drive`` call (the recorder's
    opening, its last blocks and the simulated world included, not only the loop): against
    the wall clock and the calling thread's CPU time (less disturbed by the machine's other
    loads)."""
    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(
        scenario="B", driver_id="d2", controller="predefined+oa", seed=1, duration_s=sim_s
    )
    table = predefined_table(driver)
    start, own = time.perf_counter(), time.thread_time()
    result = run_drive(cfg, driver, table, can_log=can_log)
    wall_s, own_s = time.perf_counter() - start, time.thread_time() - own
    return result.sim_s / wall_s, result.sim_s / own_s


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
        writer.frame_and_tick(m.timestamp, m, m.is_rx)  # the raw form, at the edge
    writer.close()
    return time.perf_counter() - start


def _recorded(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, data) of every message of the recording, in file order."""
    from mcap.reader import make_reader  # noqa: PLC0415

    with path.open("rb") as f:
        return [(c.topic, m.log_time, m.data) for _, c, m in make_reader(f).iter_messages()]


def _library_writer(recorded: list[tuple[str, int, bytes]]) -> float:
    """Seconds to write ``recorded`` through mcap's ``Writer.add_message``, a chunk ended at
    each raw block."""
    from mcap.writer import Writer  # noqa: PLC0415

    start = time.perf_counter()
    w = Writer(io.BytesIO())
    w.start("pacc.canlog/2", "bench")
    ids: dict[str, int] = {}
    for topic, t_ns, data in recorded:
        ch = ids.get(topic)
        if ch is None:
            ch = ids[topic] = w.register_channel(
                topic, "protobuf", w.register_schema(topic, "", b"")
            )
        w.add_message(ch, t_ns, data, t_ns)
        if topic == RAW_TOPIC:
            w.flush()  # type: ignore[no-untyped-call]
    w.finish()  # type: ignore[no-untyped-call]
    return time.perf_counter() - start


def _protobuf_rows(path: Path) -> tuple[float, float, int]:
    """Seconds to encode the recording's ``/ecu/outputs`` rows by the protobuf runtime (a
    message object a row) and by :class:`ProtoRows`, and the number of rows."""
    from google.protobuf import (  # type: ignore[import-untyped]  # noqa: PLC0415
        descriptor_pb2,
        descriptor_pool,
    )
    from google.protobuf.message_factory import (  # type: ignore[import-untyped]  # noqa: PLC0415
        GetMessageClass,
    )

    cols = read_canlog(path).series[OUTPUTS_TOPIC]
    names = list(cols)
    integral = [cols[k].dtype.kind == "i" for k in names]
    rows = ProtoRows("pacc.ecu.outputs", names, integral)
    table = np.column_stack([cols[k].astype(np.float64) for k in names])
    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(rows.descriptor()).file:
        pool.Add(file)
    cls = GetMessageClass(pool.FindMessageTypeByName("pacc.ecu.outputs"))
    values = [
        {k: int(x) if i else x for k, x, i in zip(names, r, integral, strict=True)}
        for r in table.tolist()
    ]
    start = time.perf_counter()
    for v in values:
        cls(**v).SerializeToString()
    runtime_s = time.perf_counter() - start
    start = time.perf_counter()
    rows.format_into(table)
    return runtime_s, time.perf_counter() - start, len(values)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim-s", type=float, default=120.0, help="simulated s per drive")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each side")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _drive(args.sim_s, None)  # warm: imports, caches
        _drive(args.sim_s, d / "drive.mcap")
        msgs = list(messages(read_canlog(d / "drive.mcap")))
        n = len(msgs)
        blf_s = min(_blf(msgs, d / "x.blf") for _ in range(args.repeats))
        mcap_s = min(_mcap(msgs, d / "x.mcap") for _ in range(args.repeats))
        blf_b = (d / "x.blf").stat().st_size / n
        mcap_b = (d / "x.mcap").stat().st_size / n
        recorded = _recorded(d / "x.mcap")
        lib_s = min(_library_writer(recorded) for _ in range(args.repeats))
        pb = [_protobuf_rows(d / "drive.mcap") for _ in range(args.repeats)]
        pb_runtime_s, pb_numpy_s, n_rows = min(p[0] for p in pb), min(p[1] for p in pb), pb[0][2]
        off: list[tuple[float, float]] = []
        on: list[tuple[float, float]] = []
        for _ in range(args.repeats):
            off.append(_drive(args.sim_s, None))
            on.append(_drive(args.sim_s, d / "drive.mcap"))
    rt_off, rt_on = (max(x[0] for x in runs) for runs in (off, on))
    med_off, med_on = (statistics.median(x[0] for x in runs) for runs in (off, on))
    own_off, own_on = (max(x[1] for x in runs) for runs in (off, on))
    m = len(recorded)
    print(f"frames: {n} of a {args.sim_s:g}-s drive (scenario B, d2, predefined+oa)")
    print(f"python-can BLFWriter:           {n / blf_s:10,.0f} frames/s  {blf_b:6.2f} bytes/frame")
    print(
        f"pacc recorder (raw + decoded):  {n / mcap_s:10,.0f} frames/s  {mcap_b:6.2f} bytes/frame"
        f"  ({mcap_b / blf_b:.2f}x BLF's bytes)"
    )
    print(
        f"its {m} messages: mcap.writer.Writer.add_message alone {1e6 * lib_s / m:.2f} us "
        f"each, the whole recorder {1e6 * mcap_s / m:.2f} ({lib_s / mcap_s:.1f}x); "
        f"{n_rows} /ecu/outputs rows: protobuf runtime {1e6 * pb_runtime_s / n_rows:.2f} us "
        f"each, ProtoRows {1e6 * pb_numpy_s / n_rows:.3f} us each"
    )
    print(
        f"drive real-time factor, best: {rt_off:.1f}x recording off, {rt_on:.1f}x on "
        f"({rt_on / rt_off:.3f} of off); median: {med_off:.1f}x off, {med_on:.1f}x on "
        f"({med_on / med_off:.3f} of off); on the drive thread's CPU time: {own_off:.1f}x off, "
        f"{own_on:.1f}x on ({own_on / own_off:.3f} of off)"
    )
    print(f"canlog: {blf_s / mcap_s:.2f}x python-can BLF writer")


if __name__ == "__main__":
    main()
