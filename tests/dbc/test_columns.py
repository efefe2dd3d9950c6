"""Column-wise decoding equals cantools' decoding frame by frame, on every kind of signal."""

from __future__ import annotations

import math
from typing import Any

import cantools
import numpy as np
import pytest

from dbc import DBC_PATH
from dbc.columns import MessageColumns, message_columns

#: big- and little-endian, signed, integer and fractional scales, offsets, choices, a
#: multiplexed message, an IEEE float signal, a 5-byte message
OTHER_DBC = """VERSION ""

NS_ :

BS_:

BU_: A B

BO_ 100 Mixed: 8 A
 SG_ Motorola12 : 7|12@0- (0.5,-10) [-1034|1013.5] "km/h" B
 SG_ Intel9 : 12|9@1+ (3,7) [7|1540] "" B
 SG_ Flag : 21|1@1+ (1,0) [0|1] "" B
 SG_ Signed16 : 24|16@1- (0.01,0) [-327.68|327.67] "m/s" B
 SG_ BigSigned : 47|8@0- (1,0) [-128|127] "" B
 SG_ Top : 56|8@1+ (1,0) [0|255] "" B

BO_ 200 Short: 5 A
 SG_ Word : 0|20@1+ (0.001,0) [0|1048.575] "" B
 SG_ Rest : 20|20@1- (2,-4) [-1048580|1048570] "" B

BO_ 300 Muxed: 8 A
 SG_ Mux M : 0|2@1+ (1,0) [0|3] "" B
 SG_ Alpha m0 : 8|16@1+ (0.1,0) [0|6553.5] "" B
 SG_ Beta m1 : 8|8@1- (1,0) [-128|127] "" B

BO_ 400 Floaty: 8 A
 SG_ Value : 0|32@1- (1,0) [-1e9|1e9] "" B

VAL_ 100 Flag 0 "off" 1 "on" ;
SIG_VALTYPE_ 400 Value : 1;
"""


def _databases() -> list[Any]:
    return [
        cantools.database.load_file(str(DBC_PATH), database_format="dbc", strict=True),
        cantools.database.load_string(OTHER_DBC, database_format="dbc", strict=False),
    ]


def _payloads(message: Any, n: int, rng: np.random.Generator) -> list[bytes]:
    out = []
    for _ in range(n):
        data = bytes(rng.integers(0, 256, message.length, dtype=np.uint8))
        if message.is_multiplexed():
            data = bytes([data[0] & 0x01]) + data[1:]  # a multiplexer value the DBC knows
        out.append(data)
    return out


@pytest.mark.parametrize("db_index", [0, 1])
def test_decoded_columns_equal_cantools_frame_by_frame(db_index: int) -> None:
    rng = np.random.default_rng(7)
    db = _databases()[db_index]
    for message in db.messages:
        dec = MessageColumns(message)
        payloads = _payloads(message, 300, rng)
        cols = dec.decode(payloads)
        for i, data in enumerate(payloads):
            want = message.decode(data, decode_choices=False, scaling=True)
            for name in dec.signal_names:
                got = cols[name][i].item()
                if name in want:
                    assert got == want[name], (message.name, name, data.hex())
                else:
                    assert math.isnan(got), (message.name, name)  # not carried by this frame


def test_which_messages_are_vectorised() -> None:
    db = _databases()[1]
    kinds = {m.name: MessageColumns(m).vectorised for m in db.messages}
    assert kinds == {"Mixed": True, "Short": True, "Muxed": False, "Floaty": False}
    mixed = MessageColumns(db.get_message_by_name("Mixed"))
    cols = mixed.decode(_payloads(db.get_message_by_name("Mixed"), 5, np.random.default_rng(1)))
    assert cols["Intel9"].dtype == np.int64  # integer scale and offset: integers, as cantools
    assert cols["Motorola12"].dtype == np.float64
    assert mixed.decode([])["Top"].shape == (0,)


def test_message_columns_carry_units_ranges_and_choices() -> None:
    db = _databases()[1]
    cols = message_columns(MessageColumns(db.get_message_by_name("Mixed")))
    assert list(cols)[0] == "t_s"
    assert "unit km/h" in cols["Motorola12"][1] and "range [-1034" in cols["Motorola12"][1]
    assert "choices 0=off, 1=on" in cols["Flag"][1]
    assert cols["Intel9"][0] == "<i8" and cols["Signed16"][0] == "<f8"
