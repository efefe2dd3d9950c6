"""The runtime on a SocketCAN vcan0, when the machine has one (skipped otherwise)."""

from __future__ import annotations

import can
import pytest

from dbc.vocab.dgpt import predefined
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from tests.peers import PeerNodes


def _open_vcan() -> can.BusABC:
    try:
        return can.Bus(interface="socketcan", channel="vcan0", receive_own_messages=False)
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        pytest.skip(f"no SocketCAN vcan0 here: {exc}")


def test_lockstep_engage_on_vcan0() -> None:
    ecu_bus = _open_vcan()
    peer_bus = _open_vcan()
    try:
        node = EcuNode(EcuConfig(set_speed_mps=30.0), predefined(1.5))
        rt = EcuRuntime(ecu_bus, node)
        peers = PeerNodes(peer_bus)
        for k in range(1, 200):
            t = k * 0.01
            peers.set("hmi", set=int(1.2 <= t < 1.4))
            peers.send_due(t)
            rt.advance_to(t)
        assert node.state.name == "ACTIVE"
    finally:
        ecu_bus.shutdown()
        peer_bus.shutdown()
