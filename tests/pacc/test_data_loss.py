"""Nothing lost: each test here failed before its fix.

- the README's takeover flow, ``pacc ecu --takeovers spool/`` then ``pacc cloud sync --spool
  spool/``, uploads the segments under a real driver (they were quarantined as foreign files);
- takeovers of no driver (``guest``) are said so, by the ECU and by the sync;
- two outputs on one path are refused before anything runs;
- ``pacc cloud register`` is one transaction;
- a killed service's ``.part`` files are removed when the store opens;
- a failed ``pacc export`` leaves neither OUT nor OUT.part.
"""

from __future__ import annotations

import itertools
import shutil
import socket
import sqlite3
from pathlib import Path

import pytest

from cloud_sync.service.rules import CloudService
from cloud_sync.vehicle.spool import Spool
from dbc.vocab.triplog_file import read_trip
from pacc import cli
from tests.conftest import TakeoverRun

_ids = itertools.count()


def _one_error_line(err: str, prog: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines and lines[-1].startswith(f"{prog}: error:"), err
    assert "Traceback" not in err


def _registered(data: Path) -> list[str]:
    with sqlite3.connect(data / "index.sqlite") as db:
        return [row[0] for row in db.execute("SELECT vehicle_id FROM vehicles")]


@pytest.mark.slow
def test_readme_takeover_flow_uploads_every_segment(
    takeover_run: TakeoverRun, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, err = takeover_run.out, takeover_run.err
    assert takeover_run.rc == 0, err
    assert "takeover segments: 1 of 1 written" in out and "guest" not in err
    assert " UTC  state STANDBY -> ACTIVE" in out  # wall-clock times, not the boot clock
    spool, cloud, token = tmp_path / "spool", tmp_path / "cloud", tmp_path / "car1.token"
    shutil.copytree(takeover_run.folder / "spool", spool)  # the sync empties it: a copy
    (batch,) = Spool(spool).pending()
    assert batch.kind == "takeover" and read_trip(batch.path).meta["driver_id"] == "d2"
    register = ["cloud", "register", "--data", str(cloud), "--vehicle", "car1"]
    assert cli.main([*register, "--driver", "d2", "--token-file", str(token)]) == 0
    capsys.readouterr()
    sync = ["cloud", "sync", "--spool", str(spool), "--cloud", str(cloud)]
    assert cli.main([*sync, "--token-file", str(token)]) == 0
    out, err = capsys.readouterr()
    assert "uploaded 1 batch(es)" in out and "0 still spooled" in out, (out, err)
    assert not (spool / "quarantine").exists() and not Spool(spool).pending()
    service = CloudService.open(cloud)
    try:
        (row,) = service.store.batches("d2", "default")
        assert row.kind == "takeover" and row.vehicle_id == "car1"
    finally:
        service.store.close()


def test_guest_takeovers_are_said_so_by_the_ecu_and_the_sync(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spool, cloud, token = tmp_path / "spool", tmp_path / "cloud", tmp_path / "t"
    argv = ["ecu", "-i", "virtual", "-c", f"guest-{next(_ids)}", "--duration", "0"]
    assert cli.main([*argv, "--takeovers", str(spool)]) == 0
    assert "tagged driver 'guest'" in capsys.readouterr().err
    # a guest segment as the ECU spools it: the cloud answers 403, the sync says why
    segment = read_trip(_a_trip(tmp_path))
    Spool(spool).put_trip(
        type(segment)(**{**segment.__dict__, "meta": {"driver_id": "guest", "mode": "takeover"}})
    )
    register = ["cloud", "register", "--data", str(cloud), "--vehicle", "car1"]
    assert cli.main([*register, "--driver", "d2", "--token-file", str(token)]) == 0
    sync = ["cloud", "sync", "--spool", str(spool), "--cloud", str(cloud)]
    assert cli.main([*sync, "--token-file", str(token), "--retry-s", "1"]) == 1
    out, err = capsys.readouterr()
    assert "1 still spooled" in out
    assert "HTTP 403" in err and "--driver" in err and "guest" in err


def _a_trip(tmp_path: Path) -> Path:
    """A short real trip log (``pacc drive --log``)."""
    path = tmp_path / "trip.mcap"
    if not path.exists():
        assert cli.main(["drive", "--duration", "3", "--log", str(path)]) == 0
    return path


@pytest.mark.parametrize(
    "argv",
    [
        ["drive", "--duration", "3", "--log", "{d}/x.mcap", "--can-log", "{d}/x.mcap"],
        ["drive", "--duration", "3", "--log", "{d}/x.mcap", "--can-log", "{d}/./x.mcap"],
        ["ecu", "-i", "virtual", "-c", "two-out", "--duration", "0", "--can-log", "{d}/x.mcap",
         "--save-profile", "{d}/x.mcap"],
        ["sim", "-i", "virtual", "-c", "two-out", "--duration", "1", "--log", "{d}/x.mcap",
         "--can-log", "{d}/x.mcap"],
    ],
)  # fmt: skip
def test_two_outputs_on_one_path_are_refused(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main([a.replace("{d}", str(tmp_path)) for a in argv]) == 2
    _one_error_line(capsys.readouterr().err, f"pacc {argv[0]}")
    assert not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize(
    ("first", "why"),
    [
        (["--driver", "../x"], "not a plain name"),
        (["--driver", "d1\n"], "not a plain name"),
        (["--driver", "d1", "--token-file", "{d}/no/such/dir/t"], "No such file"),
        (["--driver", "taken"], "already registered"),
    ],
)
def test_register_is_one_transaction(
    first: list[str], why: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, token = tmp_path / "cloud", tmp_path / "car1.token"
    base = ["cloud", "register", "--data", str(data)]
    other = [*base, "--vehicle", "car0", "--driver", "taken"]
    assert cli.main([*other, "--token-file", str(tmp_path / "car0.token")]) == 0
    capsys.readouterr()
    argv = [*base, "--vehicle", "car1", *(a.replace("{d}", str(tmp_path)) for a in first)]
    if "--token-file" not in argv:
        argv += ["--token-file", str(token)]
    assert cli.main(argv) != 0
    err = capsys.readouterr().err
    assert why in err and "Traceback" not in err
    assert _registered(data) == ["car0"] and not token.exists()
    # nothing half-done: the same vehicle registers cleanly now
    assert cli.main([*base, "--vehicle", "car1", "--driver", "d1", "--token-file", str(token)]) == 0
    assert "car1 registered" in capsys.readouterr().out and token.is_file()


def test_register_names_the_key_only_when_it_exists(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "cloud"
    argv = ["cloud", "register", "--data", str(data), "--token-file"]
    assert cli.main([*argv, str(tmp_path / "a"), "--vehicle", "a"]) == 0
    (data / "keys" / "cloud.pub").unlink()  # lost: the next opening writes it again
    assert cli.main([*argv, str(tmp_path / "b"), "--vehicle", "b"]) == 0
    assert f"trusts the key {data / 'keys' / 'cloud.pub'}" in capsys.readouterr().out
    assert (data / "keys" / "cloud.pub").is_file()


def test_orphan_part_files_are_removed_when_the_cloud_opens(tmp_path: Path) -> None:
    CloudService.open(tmp_path).store.close()
    orphans = [
        tmp_path / "blobs" / "ab" / ".ab12.mcap.1234.part",
        tmp_path / "dgpt" / "d1" / ".x.part",
    ]
    for orphan in orphans:
        orphan.parent.mkdir(parents=True, exist_ok=True)
        orphan.write_bytes(b"half a batch")
    kept = tmp_path / "blobs" / "ab" / "ab12.mcap"
    kept.write_bytes(b"a whole one")
    service = CloudService.open(tmp_path)
    service.store.close()
    assert service.store.orphans_removed == 2
    assert not any(o.exists() for o in orphans) and kept.exists()


@pytest.mark.parametrize("source", ["truncated.mcap", "corrupt.asc", "empty.asc", "x.mf4"])
def test_a_failed_export_leaves_no_output(
    source: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trip = _a_trip(tmp_path)
    rec = tmp_path / "bus.mcap"
    assert cli.main(["drive", "--duration", "3", "--can-log", str(rec)]) == 0
    src = tmp_path / source
    if source == "truncated.mcap":
        src.write_bytes(rec.read_bytes()[: rec.stat().st_size // 2])
    elif source == "corrupt.asc":
        assert cli.main(["export", str(rec), str(tmp_path / "ok.asc")]) == 0
        lines = (tmp_path / "ok.asc").read_text().splitlines()
        src.write_text("\n".join([*lines[:40], "   1.0 1 zzz Rx d 8 00"]) + "\n")
    elif source == "empty.asc":
        src.write_text("not a CAN log\n")
    else:
        src = rec
    out = tmp_path / ("out.mf4" if source == "x.mf4" else "out.mcap")
    capsys.readouterr()
    assert cli.main(["export", str(src), str(out)]) == 2
    _one_error_line(capsys.readouterr().err, "pacc export")
    assert not out.exists() and not list(tmp_path.glob("out.*"))
    assert trip.exists()


def test_a_failed_repair_keeps_the_killed_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``pacc export x.mcap.part x.mcap`` on a recording too short to repair fails, and the
    killed recording (the MCAP writer's name for its own temporary file) is still there."""
    part = tmp_path / "y.mcap.part"
    part.write_bytes(b"\x89MCAP0\r\n" + bytes(32))
    before = part.read_bytes()
    assert cli.main(["export", str(part), str(tmp_path / "y.mcap")]) == 2
    _one_error_line(capsys.readouterr().err, "pacc export")
    assert part.read_bytes() == before


def test_a_live_view_that_cannot_start_is_one_error_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``pacc ecu --foxglove`` without --can-log, on a port another socket holds."""
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        argv = ["ecu", "-i", "virtual", "-c", "fox-bad", "--foxglove", f"127.0.0.1:{port}"]
        assert cli.main([*argv, "--duration", "0.2"]) != 0
    _one_error_line(capsys.readouterr().err, "pacc ecu")


def test_manual_drives_refuse_the_options_of_an_ecu(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = str(tmp_path / "m.mcap")
    for extra in (["--bus", "virtual"], ["--gap-controller", "pid"], ["--foxglove"]):
        assert cli.main(["drive", "--manual", "--log", log, *extra]) == 2, extra
        assert "--manual drives the ACC off: drop" in capsys.readouterr().err
