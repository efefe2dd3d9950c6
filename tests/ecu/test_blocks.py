"""The block encoding: exact round trips, ragged columns, clear refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ecu.buslog.blocks import BlockError, block_schema, decode_block, encode_block


def test_round_trip_keeps_values_and_dtypes_exactly() -> None:
    cols = {
        "t_s": np.array([0.0, 0.01, 1e-300, np.nan, np.inf, -0.0]),
        "id": np.array([1, 2, 3, 0x1FFFFFFF, 0, 7], dtype="<u4"),
        "big": np.array([1, 2, 3, 4, 5, 6], dtype=">i8"),
        "data": np.arange(17, dtype=np.uint8),
    }
    back = decode_block(encode_block(cols, ragged=("data",)))
    assert back.keys() == cols.keys()
    np.testing.assert_array_equal(back["t_s"], cols["t_s"])
    assert back["t_s"].tobytes() == cols["t_s"].tobytes()  # bit for bit, -0.0 and NaN too
    assert back["id"].dtype == np.dtype("<u4") and back["big"].tolist() == [1, 2, 3, 4, 5, 6]
    assert back["data"].tolist() == list(range(17))


def test_refusals() -> None:
    with pytest.raises(BlockError, match="rows"):
        encode_block({"a": np.zeros(2), "b": np.zeros(3)})
    with pytest.raises(BlockError, match="not a block"):
        decode_block(b"{}")
    good = json.loads(encode_block({"a": np.zeros(2)}))
    good["n"] = 3
    with pytest.raises(BlockError, match="holds 2 values, not 3"):
        decode_block(json.dumps(good))
    good["n"] = 2
    good["a"] = "%%%"
    with pytest.raises(BlockError, match="not a block"):
        decode_block(json.dumps(good))


def test_schema_names_every_column() -> None:
    schema = block_schema("x", "y", {"t_s": ("<f8", "time, s")})
    assert schema["required"] == ["n", "dtypes", "t_s"]
    assert schema["properties"]["t_s"]["contentEncoding"] == "base64"
    assert "<f8" in schema["properties"]["t_s"]["description"]
