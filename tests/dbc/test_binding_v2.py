"""Binding v2 on the pacc network: units, inverted flags, constants, optional roles."""

from __future__ import annotations

import itertools
from pathlib import Path

import can
import pytest
from e2e import p01

from dbc import BINDING_PATH, DBC_PATH
from dbc.codec import load_codec, network_paths
from dbc.endpoint import Inbox, Outbox
from dbc.errors import BindingError
from dbc.vocab.dgpt import predefined
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from tests.peers import PeerNodes

_ids = itertools.count()
SPEED = 'SG_ VehicleSpeed : 16|16@1+ (0.01,0) [0|90] "m/s" ACC'
EGO_V1 = (
    'fields = { speed_mps = "VehicleSpeed", accel_mps2 = "LongAccel", speed_valid = "SpeedValid" }'
)


def _network(tmp_path: Path, dbc_text: str, binding_text: str) -> tuple[Path, Path]:
    dbc, binding = tmp_path / "v.dbc", tmp_path / "v.binding.toml"
    dbc.write_text(dbc_text)
    binding.write_text(binding_text.replace('dbc = "pacc.dbc"', 'dbc = "v.dbc"'))
    return dbc, binding


def test_kmh_signal_decodes_to_mps(tmp_path: Path) -> None:
    """A km/h speed signal is converted by its DBC unit: 20 m/s travels as 72.00 km/h."""
    text = DBC_PATH.read_text()
    assert SPEED in text
    kmh = text.replace(SPEED, 'SG_ VehicleSpeed : 16|16@1+ (0.01,0) [0|250] "km/h" ACC')
    codec = load_codec(*_network(tmp_path, kmh, BINDING_PATH.read_text()))
    data = codec.by_role["ego"].encode({"speed_mps": 20.0, "accel_mps2": 0.0, "speed_valid": 1}, 0)
    assert int.from_bytes(data[2:4], "little") == 7200
    assert codec.by_id[0xB0].decode(data).values["speed_mps"] == pytest.approx(20.0)
    assert codec.roles["ego"].bounds("speed_mps")[1] == pytest.approx(250 / 3.6)


@pytest.mark.parametrize(
    ("unit", "message"), [('""', "has no unit, give one"), ('"m"', "unit 'm' is not one of")]
)
def test_missing_or_wrong_unit_is_a_binding_error(tmp_path: Path, unit: str, message: str) -> None:
    text = DBC_PATH.read_text().replace(SPEED, SPEED.replace('"m/s"', unit))
    with pytest.raises(BindingError, match=message):
        load_codec(*_network(tmp_path, text, BINDING_PATH.read_text()))


def test_binding_states_the_unit_the_dbc_lacks(tmp_path: Path) -> None:
    text = DBC_PATH.read_text().replace(SPEED, SPEED.replace('"m/s"', '""'))
    binding = BINDING_PATH.read_text().replace(
        'speed_mps = "VehicleSpeed"', 'speed_mps = { signal = "VehicleSpeed", unit = "mph" }'
    )
    codec = load_codec(*_network(tmp_path, text, binding))
    data = codec.by_role["ego"].encode(
        {"speed_mps": 0.44704 * 50, "accel_mps2": 0.0, "speed_valid": 1}, 0
    )
    assert int.from_bytes(data[2:4], "little") == 5000  # 50.00 mph


def test_inverted_flag_and_constants(tmp_path: Path) -> None:
    """``invert`` flips a 1-bit flag; a ``const`` field is reported without a signal, and a
    constant fixes the signal it names in every frame sent."""
    binding = BINDING_PATH.read_text().replace(
        EGO_V1,
        'fields = { speed_mps = "VehicleSpeed", accel_mps2 = { signal = "LongAccel" }, '
        "speed_valid = { const = 1 } }\nconstants = { SpeedValid = 1 }",
    )
    codec = load_codec(*_network(tmp_path, DBC_PATH.read_text(), binding))
    data = codec.by_role["ego"].encode({"speed_mps": 3.0, "accel_mps2": 0.5, "speed_valid": 0}, 0)
    assert data[1] & 0x10  # SpeedValid (bit 12) fixed at 1 whatever the caller says
    assert codec.roles["ego"].defaults == {"speed_valid": 1.0}
    flipped = BINDING_PATH.read_text().replace(
        '"SpeedValid"', '{ signal = "SpeedValid", invert = true }'
    )
    (tmp_path / "flipped").mkdir()
    codec = load_codec(*_network(tmp_path / "flipped", DBC_PATH.read_text(), flipped))
    data = codec.by_role["ego"].encode({"speed_mps": 3.0, "accel_mps2": 0.5, "speed_valid": 1}, 0)
    assert not data[1] & 0x10
    assert codec.by_id[0xB0].decode(data).values["speed_valid"] == 1


def test_v2_form_of_the_pacc_binding_encodes_the_same_frames(tmp_path: Path) -> None:
    v2 = BINDING_PATH.read_text().replace(
        'crc = "CRC8"', 'checksum = "pacc_crc8"\nchecksum_signal = "CRC8"'
    )
    v2 = v2.replace("[roles.", "[[roles.").replace("]\nmessage", "]]\nmessage")
    ours, theirs = load_codec(*_network(tmp_path, DBC_PATH.read_text(), v2)), load_codec()
    values = {"speed_mps": 12.34, "accel_mps2": -1.5, "speed_valid": 1}
    for counter in range(16):
        mine, packaged = ours.by_role["ego"], theirs.by_role["ego"]
        assert mine.encode(values, counter) == packaged.encode(values, counter)


def test_network_without_status_runs_the_ecu(tmp_path: Path) -> None:
    """The status role is optional: a network without it runs the ECU, which sends only its
    command (no KeyError for desired_gap_m)."""
    text = BINDING_PATH.read_text()
    binding = text[: text.index("[roles.status]")]
    codec = load_codec(*_network(tmp_path, DBC_PATH.read_text(), binding))
    assert "status" not in codec.roles
    channel = f"v2-{next(_ids)}"
    with (
        can.Bus(interface="virtual", channel=channel) as ecu_bus,
        can.Bus(interface="virtual", channel=channel) as peer_bus,
        can.Bus(interface="virtual", channel=channel) as listener,
    ):
        rt = EcuRuntime(ecu_bus, EcuNode(EcuConfig(set_speed_mps=25.0), predefined(1.5)), codec)
        peers = PeerNodes(peer_bus, codec)
        for k in range(1, 101):
            peers.send_due(k * 0.01)
            rt.advance_to(k * 0.01)
        ids = set()
        while (msg := listener.recv(0)) is not None:
            ids.add(msg.arbitration_id)
    assert 0x2E0 in ids and 0x3E0 not in ids
    assert rt.summary().e2e_errors == {}


def test_network_paths_rules(tmp_path: Path) -> None:
    assert network_paths() == (DBC_PATH, BINDING_PATH)
    assert network_paths(None, BINDING_PATH) == (DBC_PATH, BINDING_PATH)
    with pytest.raises(BindingError, match="needs --binding"):
        network_paths(DBC_PATH, None)
    other = tmp_path / "other.dbc"
    with pytest.raises(BindingError, match="binds pacc.dbc, not other.dbc"):
        network_paths(other, BINDING_PATH)


def test_autosar_p01_frames_interoperate_with_autosar_e2e(tmp_path: Path) -> None:
    """A message bound with ``checksum = "autosar_p01"`` (pacc.dbc's CRC in byte 0 and
    counter in byte 1's low nibble are profile 1's default layout) is protected exactly as
    the autosar-e2e package protects it: its check accepts our frames, counters run
    0..14, and our inbox accepts its frames in sequence; counter 15 is refused."""
    binding = BINDING_PATH.read_text().replace(
        '[roles.ego]\nmessage = "ESC_Speed"\ncrc = "CRC8"',
        '[roles.ego]\nmessage = "ESC_Speed"\nchecksum = "autosar_p01"\nchecksum_signal = "CRC8"',
    )
    assert 'checksum = "autosar_p01"' in binding
    codec = load_codec(*_network(tmp_path, DBC_PATH.read_text(), binding))
    outbox = Outbox(codec)
    values = {"speed_mps": 12.34, "accel_mps2": -1.5, "speed_valid": 1}
    counters = []
    for _ in range(20):
        data = outbox.encode("ego", values)
        assert p01.e2e_p01_check(bytearray(data), 0xB0)
        counters.append(data[1] & 0xF)
    assert counters == [*range(15), *range(5)]
    theirs = bytearray(codec.by_role["ego"].encode(values, 14))
    inbox = Inbox(codec, ["ego"])
    for k in range(30):
        p01.e2e_p01_protect(theirs, 0xB0, increment_counter=True)  # 0, 1, ... 14, 0, ...
        assert inbox.accept(0xB0, bytes(theirs), 0.01 * k) is not None, k
    assert inbox.errors() == {}
    bad = bytearray(theirs)
    bad[1] |= 0x0F  # counter 15: not a profile-1 counter
    p01.e2e_p01_protect(bad, 0xB0, increment_counter=False)
    assert inbox.accept(0xB0, bytes(bad), 0.5) is None
    assert inbox.errors() == {"out_of_range": 1}


def test_scale_is_a_further_factor(tmp_path: Path) -> None:
    """``scale = 2``: the field is twice the signal's value (after its unit)."""
    binding = BINDING_PATH.read_text().replace(
        'gap_m = "LeadDistance"', 'gap_m = { signal = "LeadDistance", scale = 2 }'
    )
    codec = load_codec(*_network(tmp_path, DBC_PATH.read_text(), binding))
    radar = {
        "lead_valid": 1,
        "gap_m": 30.0,
        "rel_speed_mps": 0.0,
        "lead_accel_mps2": 0.0,
        "lead_accel_valid": 1,
    }
    data = codec.by_role["radar"].encode(radar, 0)
    assert int.from_bytes(data[2:4], "little") == 300  # 15 m at 0.05 m per bit
    assert codec.by_id[0x120].decode(data).values["gap_m"] == pytest.approx(30.0)
    assert codec.roles["radar"].bounds("gap_m") == (0.0, 500.0)
    bad = binding.replace("scale = 2", "scale = 0")
    (tmp_path / "bad").mkdir()  # load_codec caches by path: a new folder for a new table
    with pytest.raises(BindingError, match="scale must be > 0"):
        load_codec(*_network(tmp_path / "bad", DBC_PATH.read_text(), bad))
