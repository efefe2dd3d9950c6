"""A table offered from another thread is swapped in by the cycle, never while ACTIVE."""

from __future__ import annotations

import threading
from pathlib import Path

import can

from dbc.codec import load_codec
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import predefined
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.profiles import TableOffer, may_swap
from ecu.runtime import EcuRuntime
from tests.peers import PeerNodes


def test_no_swap_while_active() -> None:
    assert not may_swap(AccState.ACTIVE)
    assert all(may_swap(s) for s in AccState if s is not AccState.ACTIVE)


def test_the_newest_offer_waits_for_a_state_that_is_not_active() -> None:
    node = EcuNode(EcuConfig(), predefined(2.0, created_utc="x"))
    offer = TableOffer()
    offer.offer(predefined(1.5, created_utc="x"), "first")
    offer.offer(predefined(1.2, driver_id="d9", created_utc="x"), "newest")
    node.state = AccState.ACTIVE
    assert not offer.apply(node) and offer.pending
    node.state = AccState.OVERRIDE
    assert offer.apply(node) and not offer.pending
    assert node.table.driver_id == "d9" and offer.applied == 1
    assert not offer.apply(node)  # nothing pending


def test_a_table_offered_from_another_thread_reaches_the_running_node() -> None:
    codec = load_codec()
    node = EcuNode(EcuConfig(), predefined(2.0, created_utc="x"))
    with (
        can.Bus(interface="virtual", channel="offer", preserve_timestamps=True) as peers_bus,
        can.Bus(interface="virtual", channel="offer", preserve_timestamps=True) as ecu_bus,
    ):
        peers = PeerNodes(peers_bus, codec)
        rt = EcuRuntime(ecu_bus, node, codec)
        new = predefined(1.0, driver_id="cloud", created_utc="x")
        thread = threading.Thread(target=rt.offer_table, args=(new, "downloaded"))
        thread.start()
        thread.join()
        for k in range(10):
            peers.send_due(k * 0.02)
            rt.advance_to(k * 0.02)
    assert node.table is new  # ACC was never ACTIVE (no SET): swapped at the first cycle
    assert rt.table_offer.applied == 1


def test_no_offer_is_applied_under_another_drivers_hmi_profile(tmp_path: Path) -> None:
    codec = load_codec()
    node = EcuNode(EcuConfig(), predefined(2.0, created_utc="x"))
    with (
        can.Bus(interface="virtual", channel="offer-hmi", preserve_timestamps=True) as peers_bus,
        can.Bus(interface="virtual", channel="offer-hmi", preserve_timestamps=True) as ecu_bus,
    ):
        peers = PeerNodes(peers_bus, codec)
        peers.set("hmi", profile_id=2)  # another driver sits in the car
        rt = EcuRuntime(ecu_bus, node, codec, profile_dir=tmp_path)
        rt.offer_table(predefined(1.0, driver_id="cloud", created_utc="x"), "downloaded")
        for k in range(20):
            peers.send_due(k * 0.02)
            rt.advance_to(k * 0.02)
        assert rt.table_offer.pending and node.table.driver_id != "cloud"
        peers.set("hmi", profile_id=0)  # back to the guest/owner profile: now it may swap
        for k in range(20, 40):
            peers.send_due(k * 0.02)
            rt.advance_to(k * 0.02)
    assert node.table.driver_id == "cloud"
