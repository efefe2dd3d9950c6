"""``pacc ecu --cloud DIR``: the start table comes verified from the cloud, a newer one is
swapped in while not ACTIVE, and the takeover goes up through the spool."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from cloud_sync.service.rules import CloudService
from cloud_sync.service.trips import trip_rows
from cloud_sync.vehicle.connect import write_token
from dbc.vocab.dgpt import Dgpt, predefined
from pacc.commands.ecu import main
from tests.ecu.test_cli import Peers


def cloud_table(headway_s: float, version: int) -> Dgpt:
    table = predefined(headway_s, driver_id="syn", created_utc="2026-01-01T00:00:00Z")
    for _ in range(version):
        table = table.with_gaps(table.gap_m, source="irl", created_utc="2026-01-01T00:00:00Z")
    return table


@pytest.mark.slow
def test_ecu_with_an_embedded_cloud(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "cloud"
    service = CloudService.open(data)
    write_token(tmp_path / "car.token", service.register_vehicle("car"))
    service.register_driver("car", "syn")
    service.publish(cloud_table(2.5, version=1), [])
    later = threading.Timer(0.5, service.publish, args=(cloud_table(2.0, version=2), []))
    later.start()  # a newer version appears while the ECU runs
    peers = Peers("ecu-cloud", 4.2)
    peers.start()
    args = ["-i", "virtual", "-c", "ecu-cloud", "--duration", "4.0", "--cloud", str(data)]
    args += ["--vehicle", "car", "--token-file", str(tmp_path / "car.token"), "--driver", "syn"]
    args += ["--spool", str(tmp_path / "spool"), "--sync-every", "0.3"]
    rc = main(args)
    peers.join()
    later.join()
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "profile: cloud syn irl v1" in out
    swap = [line for line in out.splitlines() if "cloud: syn irl v2" in line]
    assert swap, out  # offered and swapped in by the cycle
    assert "takeover 1 (accel)" in out
    assert "1 batch(es) uploaded" in out and "0 spooled" in out
    batches = service.store.batches("syn", "default")
    assert [b.kind for b in batches] == ["takeover"]
    # the trip is reported with the version it started with (the embedded cloud too)
    assert "trip reports sent 1, queued 0, refused 0" in out, out
    (point,) = trip_rows(service, "syn")
    assert point["dgpt_version"] == 1 and point["segments"] == [batches[0].digest]
    assert 1.5 <= point["acc_on_s"] <= 3.2  # engaged at ~1.3 s until 4.0 s


def test_cloud_flags_are_checked_before_the_bus_opens(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["--cloud", str(tmp_path / "c"), "--duration", "0"]) == 2
    assert "--vehicle ID and --token-file F" in capsys.readouterr().err
    (tmp_path / "t").write_text("tok\n")
    base = ["--cloud", "http://127.0.0.1:9", "--vehicle", "v", "--token-file", str(tmp_path / "t")]
    assert main([*base, "--driver", "d1", "--duration", "0"]) == 2
    assert "needs --trust" in capsys.readouterr().err
    assert main([*base, "--takeovers", str(tmp_path), "--duration", "0"]) == 2
    assert "drop --takeovers" in capsys.readouterr().err
    profile = ["--profile", str(tmp_path / "p.json"), "--trust", str(tmp_path / "k.pub")]
    assert main([*base, "--driver", "d1", *profile, "--duration", "0"]) == 2
    assert "not both" in capsys.readouterr().err
