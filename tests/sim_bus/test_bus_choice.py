"""A drive gives the same rows, world and frames on the lockstep bus and on python-can's
virtual bus (``pacc drive --bus virtual``)."""

from __future__ import annotations

import dataclasses
from typing import Any

import can
import numpy as np
import pytest

from pacc.study.drive import BUSES, DriveConfig, DriveResult, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.errors import DriveError
from sim_bus.world import WORLD_COLUMNS

#: the noisiest driver, online adaptation, every kind of fault the simulator injects
CFG = DriveConfig(
    scenario="B",
    driver_id="d5",
    controller="predefined+oa",
    seed=3,
    duration_s=30.0,
    faults="ego:drop=0.05,crc=0.02;pedals:counter=0.03;radar:delay=0.03;hmi:freeze=5-8",
)


def _drive(bus: str) -> tuple[DriveResult, list[tuple[Any, ...]]]:
    driver = BUILTIN_DRIVERS["d5"]
    channel = f"bus-choice-{bus}"
    kw: dict[str, Any] = {"preserve_timestamps": True} if bus == "virtual" else {}
    listener = can.Bus(interface=bus, channel=channel, **kw)
    try:
        result = run_drive(CFG, driver, predefined_table(driver), record_channel=channel, bus=bus)
        frames = []
        while (m := listener.recv(0.0)) is not None:
            frames.append((m.timestamp, m.arbitration_id, m.is_extended_id, m.dlc, bytes(m.data)))
    finally:
        listener.shutdown()
    return result, frames


def test_lockstep_and_virtual_give_identical_drives() -> None:
    (lock, lock_frames), (virt, virt_frames) = _drive("lockstep"), _drive("virtual")
    assert len(lock_frames) > 5000 and lock.frames_faulted > 0
    assert lock_frames == virt_frames
    assert lock.metrics == virt.metrics
    # the summary's counters and state (its max cycle time is wall-clock)
    assert dataclasses.replace(lock.summary, max_cycle_s=0.0) == dataclasses.replace(
        virt.summary, max_cycle_s=0.0
    )
    assert (lock.takeovers, lock.adaptations, lock.frames_sent, lock.frames_faulted) == (
        virt.takeovers,
        virt.adaptations,
        virt.frames_sent,
        virt.frames_faulted,
    )
    for name in WORLD_COLUMNS:
        np.testing.assert_array_equal(getattr(lock.log, name), getattr(virt.log, name))
    assert lock.final_table.to_json_dict() == virt.final_table.to_json_dict()


def test_unknown_bus_is_refused() -> None:
    driver = BUILTIN_DRIVERS["d1"]
    assert BUSES[0] == "lockstep"
    with pytest.raises(DriveError, match="bus must be one of"):
        run_drive(CFG, driver, predefined_table(driver), bus="socketcan")
