"""The bus recorder and its reader: frames in = frames out, cantools' values, UTC, refusals."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import can
import cantools
import numpy as np
import pytest
from mcap.reader import make_reader

from dbc import BINDING_PATH, DBC_PATH
from dbc.codec import load_codec
from dbc.endpoint import Outbox
from dbc.vocab.dgpt import predefined
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import write_trip
from ecu.buslog.format import (
    FLAG_ERROR,
    FLAG_EXTENDED,
    FLAG_REMOTE,
    FLAG_RX,
    CanLogError,
    TimeBase,
)
from ecu.buslog.reader import messages, read_canlog
from ecu.buslog.recording import config_from_json, config_to_json, open_recording
from ecu.config import EcuConfig
from ecu.controller import ControllerParams

UTC0_NS = 1_790_000_000_000_000_000  # 2026-09-21T...Z


def _frames(n: int, seed: int) -> list[tuple[float, can.Message, bool]]:
    """``n`` frames of every bound role (real payloads from the codec) plus odd ones."""
    rng = np.random.default_rng(seed)
    codec = load_codec()
    out = Outbox(codec)
    values = {
        "ego": {"speed_mps": 13.5, "accel_mps2": -0.3, "speed_valid": 1},
        "radar": {
            "gap_m": 31.25,
            "lead_valid": 1,
            "rel_speed_mps": -1.2,
            "lead_accel_mps2": 0.4,
            "lead_accel_valid": 1,
        },
        "command": {
            "accel_request_mps2": -1.23,
            "request_active": 1,
            "acc_state": 2,
            "takeover_request": 0,
        },
    }
    frames: list[tuple[float, can.Message, bool]] = []
    for i in range(n):
        t = i * 0.01
        role = ("ego", "radar", "command")[i % 3]
        v = dict(values[role])
        first = next(iter(v))
        v[first] = float(v[first]) + float(rng.uniform(-1, 1))
        frames.append((t, out.pack(role, v, timestamp=t), role != "command"))
    frames.append((n * 0.01, can.Message(arbitration_id=0x1ABCDEF, data=b"\x01\x02"), True))
    frames.append(
        (n * 0.01, can.Message(arbitration_id=0x0B0, data=b"\x01", is_extended_id=False), True)
    )
    frames.append((n * 0.01, can.Message(is_error_frame=True, arbitration_id=0, data=b""), True))
    frames.append(
        (
            n * 0.01,
            can.Message(arbitration_id=0x120, is_remote_frame=True, dlc=8, is_extended_id=False),
            False,
        )
    )
    return frames


def _record(
    path: Path, frames: list[tuple[float, can.Message, bool]], flush_s: float = 1.0
) -> None:
    table = predefined(1.5)
    rec = open_recording(
        path,
        load_codec(),
        TimeBase(UTC0_NS, 0.0),
        node="test",
        config=EcuConfig(),
        table=table,
        metadata={"drive": {"seed": "3"}},
    )
    rec.flush_s = flush_s
    for t, msg, rx in frames:
        rec.frame_and_tick(t, msg, rx)
    rec.close()


def test_frames_in_equal_frames_out_and_decoded_values_are_cantools(tmp_path: Path) -> None:
    frames = _frames(700, seed=1)
    path = tmp_path / "bus.mcap"
    _record(path, frames)
    assert not (tmp_path / "bus.mcap.part").exists()
    log = read_canlog(path)
    f = log.frames
    assert len(f) == len(frames)
    assert f.t_s.tolist() == [t for t, _, _ in frames]
    assert f.id.tolist() == [m.arbitration_id for _, m, _ in frames]
    assert f.data == [bytes(m.data) for _, m, _ in frames]
    assert f.dlc.tolist() == [m.dlc for _, m, _ in frames]
    assert f.rx.tolist() == [rx for _, _, rx in frames]
    assert bool(f.flags[-4] & FLAG_EXTENDED) and bool(f.flags[-2] & FLAG_ERROR)
    assert bool(f.flags[-1] & FLAG_REMOTE) and not f.flags[-1] & FLAG_RX
    db: Any = cantools.database.load_file(str(DBC_PATH), database_format="dbc", strict=True)
    for name in ("ESC_Speed", "RADAR_Lead", "ACC_Command"):
        message = db.get_message_by_name(name)
        mine = [(t, m) for t, m, _ in frames if m.arbitration_id == message.frame_id]
        ok = [(t, m) for t, m in mine if len(m.data) == message.length and not m.is_remote_frame]
        cols = log.decoded[name]
        assert cols["t_s"].tolist() == [t for t, _ in ok]  # wrong length / remote: raw only
        for i, (_, m) in enumerate(ok):
            want = message.decode(bytes(m.data), decode_choices=False)
            assert {k: cols[k][i].item() for k in want} == want


def test_times_are_utc_and_the_file_carries_what_ran(tmp_path: Path) -> None:
    path = tmp_path / "bus.mcap"
    _record(path, _frames(400, seed=2))
    with path.open("rb") as fh:
        reader = make_reader(fh)
        stamps = [(ch.topic, msg.log_time) for _, ch, msg in reader.iter_messages()]
        attachments = {a.name: a.data for a in reader.iter_attachments()}
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    raw = [s for topic, s in stamps if topic == "/can/raw"]
    assert raw[0] == UTC0_NS and raw[1] == UTC0_NS + 1_010_000_000  # a block per 1 s
    assert all(s >= UTC0_NS for _, s in stamps)
    assert attachments["network.dbc"] == DBC_PATH.read_bytes()
    assert attachments["binding.toml"] == BINDING_PATH.read_bytes()
    assert config_from_json(attachments["ecu_config.json"]) == EcuConfig()
    assert json.loads(attachments["dgpt_start.json"])["driver_id"] == "guest"
    assert meta["pacc"]["start_utc"].startswith("2026-09-21T")
    assert meta["drive"] == {"seed": "3"}
    log = read_canlog(path)
    assert log.node == "test" and log.time_base == TimeBase(UTC0_NS, 0.0)
    first = next(messages(log))
    assert first.timestamp == pytest.approx(UTC0_NS / 1e9) and first.is_rx


def test_config_json_round_trip_of_a_changed_config() -> None:
    cfg = EcuConfig(
        adaptation=False,
        brake_mode="cancel",
        set_speed_mps=31.3,
        controller=ControllerParams(kp=((0.0, 40.0), (0.3, 0.1))),
        trip_meta={"driver_id": "x"},
    )
    assert config_from_json(config_to_json(cfg)) == cfg


def test_refuses_truncated_foreign_and_missing_files(tmp_path: Path) -> None:
    path = tmp_path / "bus.mcap"
    _record(path, _frames(300, seed=3))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(CanLogError, match="cut.mcap: truncated"):
        read_canlog(cut)
    trip = tmp_path / "trip.mcap"
    write_trip(trip, Trip.manual(np.arange(3.0), np.ones(3), np.ones(3), np.ones(3), np.zeros(3)))
    with pytest.raises(CanLogError, match="not a pacc bus recording"):
        read_canlog(trip)
    with pytest.raises(CanLogError, match="no such recording"):
        read_canlog(tmp_path / "none.mcap")
    with pytest.raises(CanLogError, match="is a directory"):
        open_recording(tmp_path, load_codec(), TimeBase(0, 0.0), node="x")


def test_mcaps_own_readers_decode_every_frame_and_foxglove_logs(tmp_path: Path) -> None:
    """The peer: mcap's indexed reader and its protobuf support library decode every decoded
    frame to cantools' values at the frame's UTC time; events are foxglove.Log JSON."""
    pytest.importorskip("mcap_protobuf")
    from mcap.reader import make_reader  # noqa: PLC0415
    from mcap_protobuf.decoder import DecoderFactory  # noqa: PLC0415

    frames = _frames(500, seed=4)
    path = tmp_path / "bus.mcap"
    _record(path, frames, flush_s=0.5)
    db = load_codec().db
    want: dict[str, list[tuple[float, Any]]] = {}
    for t, msg, _ in frames:
        try:
            m = db.get_message_by_frame_id(msg.arbitration_id)
        except KeyError:
            continue
        if len(msg.data) == m.length and not msg.is_error_frame and not msg.is_remote_frame:
            want.setdefault(m.name, []).append((t, m.decode(msg.data, decode_choices=False)))
    got: dict[str, list[tuple[int, Any]]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert len(summary.chunk_indexes) >= 2  # one chunk per flush
        for _, channel, message, proto in reader.iter_decoded_messages(
            topics=[f"/can/{n}" for n in want]
        ):
            got.setdefault(channel.topic.removeprefix("/can/"), []).append(
                (message.log_time, proto)
            )
    assert got.keys() == want.keys()
    for name, rows in want.items():
        assert len(got[name]) == len(rows)
        for (t, values), (log_time, proto) in zip(
            rows, sorted(got[name], key=lambda r: r[0]), strict=True
        ):
            assert log_time == TimeBase(UTC0_NS, 0.0).utc_ns(t) and proto.t_s == t
            assert {k: getattr(proto, k) for k in values} == values


def test_the_shipped_foxglove_layout_names_recorded_fields(tmp_path: Path) -> None:
    """Every message path of docs/foxglove-layout.json is a field of a drive's recording."""
    from pacc.study.drive import DriveConfig, predefined_table, run_drive  # noqa: PLC0415
    from sim_bus.drivers import BUILTIN_DRIVERS  # noqa: PLC0415

    layout = json.loads((Path(__file__).parents[2] / "docs" / "foxglove-layout.json").read_text())
    paths = [p["value"] for panel in layout["configById"].values() for p in panel.get("paths", [])]
    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(scenario="B", driver_id="d2", controller="predefined", seed=1, duration_s=3)
    run_drive(cfg, driver, predefined_table(driver), can_log=tmp_path / "d.mcap")
    log = read_canlog(tmp_path / "d.mcap")
    for path in paths:
        topic, _, name = path.rpartition(".")
        assert name in log.series[topic], path
    assert "/ecu/events" in log.topics
