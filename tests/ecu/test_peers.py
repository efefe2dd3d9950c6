"""The scripted peers (tests/peers.py) corrupt the CRC where the DBC puts it, not at byte 0."""

from __future__ import annotations

import itertools
from pathlib import Path

import can
import pytest

from dbc import DBC_PATH
from dbc.codec import load_codec
from dbc.endpoint import Inbox, Outbox
from dbc.errors import CrcError
from tests.peers import PeerNodes

_ids = itertools.count()
ESC_CRC = 'BO_ 176 ESC_Speed: 8 ESC\n SG_ CRC8 : 0|8@1+ (1,0) [0|255] "" ACC'


@pytest.mark.parametrize("crc_start", [0, 56])
def test_corrupt_flips_the_crc_byte_of_the_binding(tmp_path: Path, crc_start: int) -> None:
    """With ESC_Speed's CRC moved to byte 7, a corrupted frame differs from the genuine one
    in byte 7 only: the payload stays intact and the inbox sees a CRC error."""
    text = DBC_PATH.read_text()
    assert ESC_CRC in text
    path = tmp_path / "crc.dbc"
    path.write_text(text.replace(ESC_CRC, ESC_CRC.replace("0|8@1+", f"{crc_start}|8@1+")))
    codec = load_codec(path)
    crc_byte = codec.by_role["ego"].crc_byte
    assert crc_byte == crc_start // 8
    channel = f"peers-test-{next(_ids)}"
    with (
        can.Bus(interface="virtual", channel=channel) as peer_bus,
        can.Bus(interface="virtual", channel=channel) as listener,
    ):
        peers = PeerNodes(peer_bus, codec)
        peers.corrupt("ego")
        peers.send("ego")
        msg = listener.recv(1.0)
    assert msg is not None
    genuine = Outbox(codec).encode("ego", peers.values["ego"])  # the same counter, 0
    differ = [i for i, (a, b) in enumerate(zip(msg.data, genuine, strict=True)) if a != b]
    assert differ == [crc_byte]
    with pytest.raises(CrcError):
        codec.by_id[msg.arbitration_id].decode(msg.data)
    inbox = Inbox(codec, ["ego"])
    assert inbox.accept(msg.arbitration_id, msg.data, 0.0) is None
