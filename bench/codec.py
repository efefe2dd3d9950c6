"""Benchmark: encode + decode round trip of the pacc messages, pacc codec vs cantools.

Both sides do the same work per frame: build the payload from physical values with the
alive counter and the E2E CRC, then decode it, verify the CRC and get physical values back.
The cantools side uses ``Message.encode``/``Message.decode`` (its defaults) for the signals
and the same CRC routine (``dbc.checksums.table_crc``) for the checksum. The last line is the ratio.

    python bench/codec.py [--seconds 2.0]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

from dbc.checksums import table_crc
from dbc.codec import load_codec

SAMPLE: dict[str, dict[str, Any]] = {
    "ego": {"speed_mps": 23.45, "accel_mps2": -0.71, "speed_valid": 1},
    "pedals": {
        "accel_pedal_pct": 12.5,
        "accel_pressed": 1,
        "brake_pressed": 0,
        "brake_pressure_bar": 0.0,
    },
    "radar": {
        "lead_valid": 1,
        "gap_m": 31.25,
        "rel_speed_mps": -1.37,
        "lead_accel_mps2": 0.42,
        "lead_accel_valid": 1,
    },
    "hmi": {
        "main_switch": 1,
        "set": 0,
        "resume": 0,
        "cancel": 0,
        "gap_setting": 2,
        "profile_id": 3,
    },
    "command": {
        "accel_request_mps2": -1.23,
        "request_active": 1,
        "acc_state": 2,
        "takeover_request": 0,
    },
    "status": {
        "desired_gap_m": 35.5,
        "dgpt_version": 7,
        "adaptation_count": 4,
        "fault_code": 0,
        "set_speed_mps": 27.5,
    },
}


def _rate(fn: Callable[[], None], seconds: float) -> float:
    """Round trips per second of ``fn`` (one call = one round trip of every message)."""
    n, start = 0, time.perf_counter()
    while (elapsed := time.perf_counter() - start) < seconds:
        for _ in range(200):
            fn()
        n += 200
    return n * len(SAMPLE) / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="time per side (s)")
    args = parser.parse_args()
    codec = load_codec()
    roles = list(SAMPLE)
    ours = [(codec.by_role[r], SAMPLE[r]) for r in roles]

    def pacc_round_trip() -> None:
        for mc, values in ours:
            mc.decode(mc.encode(values, 5))

    theirs = []
    for role in roles:
        mc = codec.by_role[role]
        part = codec.binding.roles[role].parts[0]
        msg = codec.db.get_message_by_name(mc.name)
        named: dict[str, float] = {part.fields[k].signal: v for k, v in SAMPLE[role].items()}
        crc, counter = part.checksum_signal, part.counter
        assert crc is not None and counter is not None and mc.crc_byte is not None
        named[counter] = 5
        named[crc] = 0
        e2e_crc = table_crc(mc.checksum, mc.frame_id, mc.crc_byte)
        theirs.append((msg, named, e2e_crc, mc.crc_byte, crc, counter))

    def cantools_round_trip() -> None:
        for msg, named, e2e_crc, crc_byte, crc_name, _ in theirs:
            raw = bytearray(msg.encode(named))
            raw[crc_byte] = e2e_crc(bytes(raw))
            data = bytes(raw)
            decoded = msg.decode(data)
            if decoded[crc_name] != e2e_crc(data):
                raise AssertionError("CRC")

    # same bytes on both sides, or the comparison is meaningless
    for (mc, values), (msg, named, e2e_crc, crc_byte, _, _) in zip(ours, theirs, strict=True):
        raw = bytearray(msg.encode(named))
        raw[crc_byte] = e2e_crc(bytes(raw))
        assert bytes(raw) == mc.encode(values, 5), mc.name

    theirs_rate = _rate(cantools_round_trip, args.seconds)
    ours_rate = _rate(pacc_round_trip, args.seconds)
    print(f"cantools Message.encode/decode + CRC: {theirs_rate:12,.0f} frames/s round trip")
    print(f"pacc compiled codec (counter, CRC):   {ours_rate:12,.0f} frames/s round trip")
    print(f"codec: {ours_rate / theirs_rate:.1f}x cantools")


if __name__ == "__main__":
    main()
