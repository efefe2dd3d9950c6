"""A bus recording killed mid-run is readable up to its last flush.

One subprocess imports the recorder once, then forks a recording process per trial: each child
records frames it sends and receives on a python-can virtual bus (a counter in every payload,
the monotonic clock as the node's clock) until the parent SIGKILLs it at a random instant: every
other trial after it opened the recording, the rest after the file grew (a flush was written).
The test reads every ``.part`` left behind with ``recover=True`` and checks that the frames are
an unbroken prefix of what was sent, that every frame older than the flush interval at the kill
is there once a flush was written, and that ``pacc export`` turns it into a complete file.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ecu.buslog.format import CanLogError
from ecu.buslog.reader import read_canlog

FLUSH_S = 0.05
#: a frame's time and the flush that writes it may be this far apart on a loaded machine
SLACK_S = 0.15
TRIALS = 30  # the acceptance: SIGKILL at >= 30 random instants

_RECORDER = r"""
import json, os, random, signal, sys, time
import can
from dbc.codec import load_codec
from ecu.buslog.format import TimeBase
from ecu.buslog.writer import CanLogWriter

out, trials, flush_s, seed = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
db = load_codec().db
esc = db.get_message_by_name("ESC_Speed")
rng = random.Random(seed)
# a bus and a recording of one frame opened and closed here first: the children fork with
# their lazy imports done
can.Bus(interface="virtual", channel="warm").shutdown()
warm = CanLogWriter(os.path.join(out, "warm.mcap"), db, TimeBase.now(0.0), node="kill")
warm.frame_and_tick(0.0, can.Message(arbitration_id=esc.frame_id, data=bytes(esc.length)), True)
warm.close()
for trial in range(trials):
    path = os.path.join(out, f"rec{trial}.mcap")
    started_r, started_w = os.pipe()
    pid = os.fork()
    if pid == 0:
        tx = can.Bus(interface="virtual", channel=f"k{trial}")
        rx = can.Bus(interface="virtual", channel=f"k{trial}")
        base = TimeBase.now(time.monotonic())
        w = CanLogWriter(path, db, base, node="kill", flush_s=flush_s, rows_s=2 * flush_s)
        os.write(started_w, b"1")  # the recording is open: from now on it must be readable
        i = 0
        while True:
            data = i.to_bytes(4, "little") + bytes(esc.length - 4)
            tx.send(can.Message(arbitration_id=esc.frame_id, is_extended_id=False, data=data))
            msg = rx.recv(1.0)
            w.frame_and_tick(time.monotonic(), msg, True)
            i += 1
            time.sleep(0.0005)
    os.read(started_r, 1)
    part = path + ".part"
    opened = os.path.getsize(part)
    if trial % 2 == 0:  # kill after the first flush grew the file
        deadline = time.monotonic() + 30.0
        while os.path.getsize(part) == opened and time.monotonic() < deadline:
            time.sleep(0.001)
    time.sleep(rng.uniform(0.0, 3 * flush_s))
    flushed = os.path.getsize(part) > opened
    os.kill(pid, signal.SIGKILL)
    t_kill = time.monotonic()
    os.waitpid(pid, 0)
    print(json.dumps({"path": path, "t_kill": t_kill, "flushed": flushed}), flush=True)
"""


@pytest.mark.slow
def test_sigkilled_recordings_are_readable_up_to_the_last_flush(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", _RECORDER, str(tmp_path), str(TRIALS), str(FLUSH_S), "22"],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    trials = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(trials) == TRIALS
    assert sum(t["flushed"] for t in trials) >= TRIALS // 2
    frames_read = 0
    for trial in trials:
        part = Path(trial["path"] + ".part")
        assert part.exists() and not Path(trial["path"]).exists()
        with pytest.raises(CanLogError, match="truncated"):
            read_canlog(part)
        log = read_canlog(part, recover=True)
        assert not log.complete and "unfinished recording" in log.note
        f = log.frames
        counters = [int.from_bytes(d[:4], "little") for d in f.data]
        assert counters == list(range(len(counters))), "frames lost or out of order"
        # once a flush was written, every frame older than the flush interval (and the slack)
        # at the kill is there
        t_last = f.t_s[-1] if len(f) else -np.inf
        if trial["flushed"]:
            assert t_last >= trial["t_kill"] - FLUSH_S - SLACK_S, trial
        # the decoded rows (written every rows_s) are a prefix of the frames
        decoded = log.decoded.get("ESC_Speed", {}).get("t_s", np.zeros(0))
        assert np.array_equal(decoded, f.t_s[: len(decoded)])
        frames_read += len(f)
    assert frames_read > 10 * TRIALS


def test_export_turns_a_killed_recording_into_a_complete_one(tmp_path: Path) -> None:
    from ecu.buslog.repair import repair  # noqa: PLC0415

    proc = subprocess.run(
        [sys.executable, "-c", _RECORDER, str(tmp_path), "1", "0.1", "5"],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    path = Path(json.loads(proc.stdout)["path"])
    part = path.with_name(path.name + ".part")
    n = repair(part, path)
    log = read_canlog(path)
    assert log.complete and len(log.frames) == n == len(read_canlog(part, recover=True).frames)
