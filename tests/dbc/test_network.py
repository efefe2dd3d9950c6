"""The DBC file itself: strict load, periods, ranges, usability by the standard tool."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import cantools
import pytest

from dbc import BINDING_PATH, DBC_PATH

ROOT = Path(__file__).resolve().parents[2]

# message -> (sender, period ms, {signal: (min, max, unit)})
EXPECTED: dict[str, tuple[str, int, dict[str, tuple[float, float, str]]]] = {
    "ESC_Speed": ("ESC", 10, {"VehicleSpeed": (0, 90, "m/s"), "LongAccel": (-20, 20, "m/s^2")}),
    "PEDAL_Status": (
        "PEDAL",
        10,
        {"AccelPedalPos": (0, 100, "%"), "BrakePressure": (0, 250, "bar")},
    ),
    "RADAR_Lead": (
        "RADAR",
        50,
        {
            "LeadDistance": (0, 250, "m"),
            "LeadRelSpeed": (-50, 50, "m/s"),
            "LeadAccel": (-15, 15, "m/s^2"),
        },
    ),
    "HMI_Buttons": ("HMI", 100, {"GapSetting": (1, 3, ""), "DriverProfileId": (0, 255, "")}),
    "ACC_Command": ("ACC", 20, {"AccelRequest": (-10, 5, "m/s^2"), "AccState": (0, 4, "")}),
    "ACC_Status": (
        "ACC",
        100,
        {
            "DesiredGap": (0, 250, "m"),
            "DgptVersion": (0, 65535, ""),
            "AdaptationCount": (0, 255, ""),
            "SetSpeed": (0, 63.75, "m/s"),
        },
    ),
}


@pytest.fixture(scope="module")
def db() -> cantools.database.can.Database:
    loaded = cantools.database.load_file(str(DBC_PATH), strict=True)
    assert isinstance(loaded, cantools.database.can.Database)
    return loaded


@pytest.mark.slow
def test_installed_package_holds_the_network_files(tmp_path: Path) -> None:
    """What an install holds, not what the checkout holds: setuptools builds the packages
    from the project's configuration (pyproject's package-data) into a fresh folder, and
    there the codec loads the DBC and binding that ship with it."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for package in ("pacc", "dbc", "ecu"):
        shutil.copytree(ROOT / package, src / package, ignore=shutil.ignore_patterns("__pycache__"))
    lib = tmp_path / "lib"
    build = [sys.executable, "-c", "from setuptools import setup; setup()"]
    subprocess.run(
        [*build, "-q", "build_py", "--build-lib", str(lib)],
        cwd=src,
        capture_output=True,
        check=True,
    )
    for name in (
        DBC_PATH.name,
        BINDING_PATH.name,
        "py.typed",
        "bindings/toyota_nodsu.binding.toml",
    ):
        assert (lib / "dbc" / name).is_file(), name
    probe = "import dbc, dbc.codec; print(dbc.DBC_PATH); dbc.codec.load_codec()"
    out = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(lib)},
        capture_output=True,
        text=True,
        check=True,
    )
    assert Path(out.stdout.strip()) == lib / "dbc" / DBC_PATH.name


def test_nodes(db: cantools.database.can.Database) -> None:
    assert {n.name for n in db.nodes} == {"ESC", "PEDAL", "RADAR", "HMI", "ACC", "PT"}
    assert all(n.comment for n in db.nodes)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_message_period_sender_ranges(db: cantools.database.can.Database, name: str) -> None:
    sender, period, signals = EXPECTED[name]
    msg = db.get_message_by_name(name)
    assert msg.senders == [sender]
    assert msg.cycle_time == period
    assert msg.comment and sender in msg.comment.split("->")[0]
    for signal, (lo, hi, unit) in signals.items():
        s = msg.get_signal_by_name(signal)
        assert (s.minimum, s.maximum, s.unit or "") == (lo, hi, unit)
    # every frame carries the E2E pair in the same place
    crc, counter = msg.get_signal_by_name("CRC8"), msg.get_signal_by_name("AliveCounter")
    assert (crc.start, crc.length, counter.start, counter.length) == (0, 8, 8, 4)
    assert all(s.comment for s in msg.signals)


def test_resolutions(db: cantools.database.can.Database) -> None:
    assert db.get_message_by_name("ESC_Speed").get_signal_by_name("VehicleSpeed").scale <= 0.01
    assert db.get_message_by_name("RADAR_Lead").get_signal_by_name("LeadDistance").scale <= 0.05
    assert db.get_message_by_name("ACC_Command").get_signal_by_name("AccelRequest").scale <= 0.01


def test_every_enum_has_a_value_table(db: cantools.database.can.Database) -> None:
    enums = {
        "SpeedValid",
        "AccelPedalPressed",
        "BrakePressed",
        "LeadValid",
        "LeadAccelValid",
        "MainSwitch",
        "SetButton",
        "ResumeButton",
        "CancelButton",
        "GapSetting",
        "RequestActive",
        "TakeoverRequest",
        "AccState",
        "FaultCode",
    }
    found = {s.name for m in db.messages for s in m.signals if s.choices}
    assert enums <= found
    state = db.get_message_by_name("ACC_Command").get_signal_by_name("AccState")
    assert state.choices is not None
    assert {int(k): str(v) for k, v in state.choices.items()} == {
        0: "Off",
        1: "Standby",
        2: "Active",
        3: "Override",
        4: "Fault",
    }


def test_cantools_dump_succeeds() -> None:
    exe = shutil.which("cantools") or shutil.which(
        "cantools", path=str(Path(sys.executable).parent)
    )
    cmd = [exe] if exe else [sys.executable, "-m", "cantools"]
    out = subprocess.run([*cmd, "dump", str(DBC_PATH)], capture_output=True, text=True, check=True)
    assert "ACC_Command" in out.stdout and "RADAR_Lead" in out.stdout
