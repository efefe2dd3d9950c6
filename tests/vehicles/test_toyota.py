"""opendbc's Toyota network through pacc's Toyota binding, checked against opendbc itself.

The DBC is assembled from the opendbc wheel's parts by tools/opendbc_toyota.py; frames of the
car's side are packed by opendbc's own CANPacker (its Toyota checksum), the ECU's frames are
checked with opendbc's checksum function and decoded by cantools. Skipped where the opendbc
wheel is not installed (it is a dev dependency on Python < 3.13).
"""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import can
import cantools
import numpy as np
import pytest

from dbc import DATA_DIR
from dbc.codec import Codec, load_codec, network_paths
from dbc.e2e import E2EStatus
from dbc.endpoint import Inbox, Outbox
from dbc.errors import BindingError, CrcError, DbcError
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import predefined
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from tools.opendbc_toyota import assemble

pytest.importorskip("opendbc.can.packer")
from opendbc import get_generated_dbcs  # noqa: E402
from opendbc.can.dbc import DBC as OpendbcDbc  # noqa: E402
from opendbc.can.packer import CANPacker  # noqa: E402

BINDING = DATA_DIR / "bindings" / "toyota_nodsu.binding.toml"
_ids = itertools.count()


@pytest.fixture(scope="module")
def toyota_dbc(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("toyota") / "toyota_nodsu_pt_generated.dbc"
    path.write_text(assemble())
    return path


@pytest.fixture(scope="module")
def codec(toyota_dbc: Path) -> Codec:
    return load_codec(toyota_dbc, BINDING)


def _layout(db: Any) -> dict[str, tuple[int, int, list[tuple[str, int, int]]]]:
    return {
        m.name: (m.frame_id, m.length, sorted((s.name, s.start, s.length) for s in m.signals))
        for m in db.messages
    }


def test_assembly_is_opendbcs_network(toyota_dbc: Path, tmp_path: Path) -> None:
    """The script's DBC holds the messages and signals of opendbc's own generated one."""
    theirs = tmp_path / "theirs.dbc"
    theirs.write_text(get_generated_dbcs()["toyota_nodsu_pt_generated"])
    ours_db: Any = cantools.database.load_file(str(toyota_dbc), strict=False)
    theirs_db: Any = cantools.database.load_file(str(theirs), strict=False)
    assert len(ours_db.messages) > 50
    assert _layout(ours_db) == _layout(theirs_db)


def test_checksums_match_opendbcs(codec: Codec, toyota_dbc: Path) -> None:
    """Every checksummed message we send carries the checksum opendbc computes, and every
    frame opendbc's packer makes passes our check and decodes to the same values."""
    odb = OpendbcDbc(str(toyota_dbc))
    packer = CANPacker(str(toyota_dbc))
    db: Any = cantools.database.load_file(str(toyota_dbc), strict=False)
    rng = np.random.default_rng(7)
    outbox = Outbox(codec)
    checked = 0
    for mc in codec.by_id.values():
        for _ in range(50):
            values = {}
            for key in mc.fields:
                lo, hi = mc.bounds(key)
                values[key] = (
                    round(float(rng.uniform(lo, hi)), 1)
                    if hi - lo > 1
                    else int(rng.integers(int(lo), int(hi) + 1))
                )
            data = outbox.encode_part(mc, values)
            if mc.protected:
                sig = odb.addr_to_msg[mc.frame_id].sigs["CHECKSUM"]
                assert sig.calc_checksum is not None
                assert sig.calc_checksum(mc.frame_id, sig, bytearray(data)) == data[-1]
                checked += 1
            # opendbc packs the same signal values: our decoder accepts its frame
            named = db.decode_message(mc.frame_id, data, decode_choices=False)
            theirs = bytes(packer.pack(mc.frame_id, dict(named)))
            assert theirs == data, mc.name
            decoded = mc.decode(theirs).values
            step = {f.key: f.scale for f in mc.layouts}  # one raw step, logical units
            for key, value in values.items():
                assert decoded[key] == pytest.approx(value, abs=step[key] / 2 + 1e-9), key
    assert checked >= 6 * 50


def test_speed_is_converted_from_kmh(codec: Codec, toyota_dbc: Path) -> None:
    packer = CANPacker(str(toyota_dbc))
    data = bytes(packer.pack(0xB4, {"SPEED": 72.0}))
    assert codec.by_id[0xB4].decode(data).values["speed_mps"] == pytest.approx(20.0)


def test_a_wrong_checksum_is_dropped(codec: Codec, toyota_dbc: Path) -> None:
    packer = CANPacker(str(toyota_dbc))
    data = bytearray(packer.pack(0x2E6, {"LEAD_LONG_DIST": 30.0, "LEAD_REL_SPEED": -1.0}))
    with pytest.raises(CrcError, match="toyota checksum"):
        codec.by_id[0x2E6].decode(bytes(data[:-1]) + bytes([data[-1] ^ 1]))
    inbox = Inbox(codec, ["radar"])
    assert inbox.accept(0x2E6, bytes(data), 0.0) is not None
    data[2] ^= 0x10
    assert inbox.accept(0x2E6, bytes(data), 0.05) is None
    assert inbox.counts[("radar", E2EStatus.WRONG_CRC)] == 1
    assert inbox.latest("radar") == {
        "gap_m": pytest.approx(30.0),
        "rel_speed_mps": pytest.approx(-1.0),
        "lead_valid": 1.0,
        "lead_accel_mps2": 0.0,
        "lead_accel_valid": 0.0,
    }


class ToyotaCar:
    """The car around the ECU, played with opendbc's CANPacker at the binding's periods."""

    def __init__(self, bus: can.BusABC, codec: Codec, dbc: Path) -> None:
        self.bus = bus
        self.packer = CANPacker(str(dbc))
        self.periods = {
            mc.name: mc.cycle_s
            for r in ("ego", "pedals", "radar", "hmi")
            for mc in codec.roles[r].parts
        }
        self.values: dict[str, dict[str, float]] = {
            "SPEED": {"SPEED": 72.0},  # km/h
            "KINEMATICS": {"ACCEL_X": 0.0},
            "GAS_PEDAL": {"GAS_PEDAL": 0.0, "GAS_RELEASED": 1},
            "BRAKE_MODULE": {"BRAKE_PRESSED": 0},
            "LEAD_INFO": {"LEAD_LONG_DIST": 26.0, "LEAD_REL_SPEED": -2.0},
            "PCM_CRUISE_2": {"MAIN_ON": 1, "PCM_FOLLOW_DISTANCE": 2, "LOW_SPEED_LOCKOUT": 1},
            "DSU_CRUISE": {"SET_BTN": 0, "RES_BTN": 0, "CANCEL_BTN": 0},
        }
        self.sent = 0

    def send_due(self, k: int, t: float) -> None:
        for name, period in self.periods.items():
            if k % round(period / 0.01) == 0:
                addr, data, _ = self.packer.make_can_msg(name, 0, self.values[name])
                self.bus.send(
                    can.Message(arbitration_id=addr, data=data, is_extended_id=False, timestamp=t)
                )
                self.sent += 1


def test_ecu_drives_a_toyota_through_opendbc_frames(codec: Codec, toyota_dbc: Path) -> None:
    """Frames packed by opendbc in, ACC_CONTROL and PCM_CRUISE out: the ECU reads 72 km/h as
    20 m/s, engages on SET, brakes for a close, closing lead, and every frame it sends
    carries the checksum opendbc expects."""
    channel = f"toyota-{next(_ids)}"
    odb = OpendbcDbc(str(toyota_dbc))
    db: Any = cantools.database.load_file(str(toyota_dbc), strict=False)
    with (
        can.Bus(interface="virtual", channel=channel) as ecu_bus,
        can.Bus(interface="virtual", channel=channel) as car_bus,
        can.Bus(interface="virtual", channel=channel) as listener,
    ):
        node = EcuNode(EcuConfig(set_speed_mps=25.0, adaptation=False), predefined(1.5))
        rt = EcuRuntime(ecu_bus, node, codec)
        car = ToyotaCar(car_bus, codec, toyota_dbc)
        out: list[tuple[float, str, dict[str, Any]]] = []
        for k in range(1, 501):
            t = k * 0.01
            car.values["DSU_CRUISE"]["SET_BTN"] = 1 if 1.5 <= t < 1.8 else 0
            car.send_due(k, t)
            rt.advance_to(t)
            while (msg := listener.recv(0)) is not None:
                if msg.arbitration_id not in (0x343, 0x1D2):
                    continue
                sig = odb.addr_to_msg[msg.arbitration_id].sigs["CHECKSUM"]
                assert sig.calc_checksum is not None
                assert (
                    sig.calc_checksum(msg.arbitration_id, sig, bytearray(msg.data))
                    == (msg.data[-1])
                )
                m = db.get_message_by_frame_id(msg.arbitration_id)
                out.append((t, m.name, m.decode(bytes(msg.data), decode_choices=False)))
        inputs = rt.io.read_inputs(5.0)
        summary = rt.summary()
    assert inputs.v_mps == pytest.approx(20.0) and inputs.gap_m == pytest.approx(26.0)
    assert summary.e2e_errors == {}
    assert car.sent > 1000
    pcm = [v for t, name, v in out if name == "PCM_CRUISE"]
    acc = [v for t, name, v in out if name == "ACC_CONTROL"]
    assert len(pcm) == len(acc) >= 240  # both messages of the command role, every 20 ms
    assert pcm[0]["CRUISE_ACTIVE"] == 0 and pcm[0]["CRUISE_STATE"] in (
        AccState.OFF,
        AccState.STANDBY,
    )
    assert pcm[-1]["CRUISE_ACTIVE"] == 1 and pcm[-1]["CRUISE_STATE"] == AccState.ACTIVE
    assert acc[-1]["ACCEL_CMD"] < -0.3  # 26 m at 20 m/s, closing: brake
    assert all(v["PERMIT_BRAKING"] == 1 and v["ACC_TYPE"] == 1 for v in acc)  # constants


def test_missing_required_field_is_a_binding_error(tmp_path: Path, toyota_dbc: Path) -> None:
    binding = tmp_path / "b.toml"
    binding.write_text(BINDING.read_text().replace('accel_request_mps2 = "ACCEL_CMD"\n', ""))
    with pytest.raises(BindingError, match=r"command: required fields \['accel_request_mps2'\]"):
        load_codec(toyota_dbc, binding)


def test_cycle_time_is_required_where_the_dbc_has_none(tmp_path: Path, toyota_dbc: Path) -> None:
    binding = tmp_path / "b.toml"
    binding.write_text(BINDING.read_text().replace("cycle_ms = 50\n", "", 1))
    with pytest.raises(DbcError, match="LEAD_INFO has no GenMsgCycleTime"):
        load_codec(toyota_dbc, binding)


def test_pacc_drive_on_the_toyota_network(
    toyota_dbc: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The closed loop runs from the command line on the Toyota network, and its bus
    recording (which carries the Toyota DBC and binding) replays through the ECU exactly."""
    from pacc.commands.drive import main  # noqa: PLC0415
    from pacc.commands.replay import main as replay  # noqa: PLC0415 - entry points, on top

    argv = ["--driver", "d2", "--duration", "20", "--can-log", str(tmp_path / "t.mcap")]
    assert main([*argv, "--dbc", str(toyota_dbc), "--binding", str(BINDING)]) == 0
    toyota = capsys.readouterr().out
    assert "ECU E2E errors none" in toyota and "collisions     0" in toyota
    acc_on_s = float(toyota.split("ACC-ON")[1].split("s)")[0])
    assert acc_on_s > 15.0  # engaged through DSU_CRUISE.SET_BTN, held through PCM_CRUISE
    assert replay([str(tmp_path / "t.mcap"), "--ecu"]) == 0
    out = capsys.readouterr().out
    assert "identical to the recording (2000 of 2000)" in out and "E2E errors:     none" in out


def test_the_recipe_works_from_any_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The assembly script by its path and ``--binding toyota_nodsu`` (the packaged
    binding's name), run from a folder that is not the repository's."""
    script = Path(__file__).resolve().parents[2] / "tools" / "opendbc_toyota.py"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run(
        [sys.executable, str(script), "-o", "toyota_nodsu_pt_generated.dbc"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    monkeypatch.chdir(tmp_path)
    dbc, binding = network_paths("toyota_nodsu_pt_generated.dbc", "toyota_nodsu")
    assert binding == BINDING.resolve()
    assert load_codec(dbc, binding).roles["ego"].parts[0].name == "SPEED"
