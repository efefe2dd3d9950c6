"""One trip-mode vocabulary: the spool, the cloud's ingest and the learner classify alike."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cloud_sync.api import BadBatchError
from cloud_sync.irl.demos import is_acc_trip
from cloud_sync.service.rules import CloudService, DeferredExecutor
from cloud_sync.vehicle.spool import Spool, SpoolError
from dbc.vocab.acc_state import AccState
from dbc.vocab.triplog import Trip, trip_mode
from dbc.vocab.triplog_file import write_trip
from dbc.vocab.tripmode import TripMode, TripModeError


def trip(mode: str | None, states: list[int] | None = None) -> Trip:
    """A 4-sample trip of driver d1 with ``meta["mode"] = mode`` (no mode when None)."""
    n = 4
    meta: dict[str, object] = {"driver_id": "d1"}
    if mode is not None:
        meta["mode"] = mode
    return Trip(
        t_s=np.arange(n) * 0.1,
        v_mps=np.full(n, 20.0),
        gap_m=np.full(n, 40.0),
        v_lead_mps=np.full(n, 20.0),
        a_mps2=np.zeros(n),
        accel_pedal=np.zeros(n),
        brake_pedal=np.zeros(n),
        acc_state=np.asarray(states if states is not None else [0] * n, dtype=np.int64),
        meta=meta,
    )


ACTIVE, OVERRIDE = int(AccState.ACTIVE), int(AccState.OVERRIDE)
CASES = [
    (trip("manual"), TripMode.MANUAL),
    (trip("acc", [ACTIVE] * 4), TripMode.ACC),
    (trip("takeover", [ACTIVE, OVERRIDE, OVERRIDE, OVERRIDE]), TripMode.TAKEOVER),
    (trip(None), TripMode.MANUAL),  # no mode, the ACC never Active: manual driving
    (trip(None, [1, ACTIVE, OVERRIDE, 1]), TripMode.ACC),  # no mode, the ACC drove a part
]


@pytest.mark.parametrize(("t", "mode"), CASES)
def test_the_spool_and_the_learner_classify_every_trip_alike(
    t: Trip, mode: TripMode, tmp_path: Path
) -> None:
    assert trip_mode(t) is mode
    assert Spool(tmp_path).put_trip(t).kind == mode.value
    assert is_acc_trip(t) is mode.acc_on


def test_a_trip_without_a_mode_is_spooled_as_manual_driving(tmp_path: Path) -> None:
    """The defect: the spool filed a mode-less manual trip as an ACC trip (a correction)."""
    batch = Spool(tmp_path).put_trip(trip(None))
    assert batch.kind == "manual" and not is_acc_trip(trip(None))


def test_an_unknown_mode_is_an_error_never_a_guess(tmp_path: Path) -> None:
    bad = trip("cruise")
    for classify in (trip_mode, is_acc_trip):
        with pytest.raises(TripModeError, match="unknown trip mode 'cruise'"):
            classify(bad)
    with pytest.raises(SpoolError, match="not spooled: unknown trip mode 'cruise'"):
        Spool(tmp_path).put_trip(bad)
    z = np.zeros(1)
    with pytest.raises(TripModeError):
        trip_mode(Trip.manual(z, z, z, z, z, {"mode": 3}))


def test_the_cloud_files_a_mode_less_trip_as_manual_and_refuses_an_unknown_mode(
    tmp_path: Path,
) -> None:
    cloud = CloudService.open(tmp_path / "cloud", executor=DeferredExecutor())
    cloud.register_vehicle("car")
    cloud.register_driver("car", "d1")
    path = tmp_path / "t.mcap"
    write_trip(path, trip(None))
    assert cloud.upload("car", path.read_bytes()).kind == "manual"
    write_trip(path, trip("cruise"))
    with pytest.raises(BadBatchError, match="unknown trip mode"):
        cloud.upload("car", path.read_bytes())
