"""Signed DGPTs: a round trip, and every way a table can be refused by the vehicle."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import pytest

from cloud_sync.signing import (
    SignatureError,
    key_id,
    load_private_key,
    load_public_key,
    new_private_key,
    public_pem,
    save_private_key,
    sign_dgpt,
    verify_dgpt,
)
from dbc.vocab.dgpt import SafetyBounds, predefined


def test_a_signed_table_verifies_to_the_same_table() -> None:
    key = new_private_key()
    original = predefined(2.0, driver_id="d1", created_utc="2026-01-01T00:00:00Z")
    back = verify_dgpt(sign_dgpt(original, key), key.public_key())
    assert back.to_json_dict() == original.to_json_dict()


def test_a_tampered_table_is_refused() -> None:
    key = new_private_key()
    envelope = json.loads(sign_dgpt(predefined(2.0, created_utc="x"), key))
    inner = json.loads(envelope["dgpt"])
    inner["gap_m"][40] += 5.0  # the cloud never said this
    envelope["dgpt"] = json.dumps(inner, sort_keys=True)
    with pytest.raises(SignatureError, match="tampered"):
        verify_dgpt(json.dumps(envelope).encode(), key.public_key())


def test_an_unsigned_table_is_refused() -> None:
    key = new_private_key()
    plain = json.dumps(predefined(2.0, created_utc="x").to_json_dict()).encode()
    with pytest.raises(SignatureError, match="unsigned"):
        verify_dgpt(plain, key.public_key())
    with pytest.raises(SignatureError, match="not JSON"):
        verify_dgpt(b"\xff\x00", key.public_key())


def test_a_table_signed_by_another_key_is_refused() -> None:
    cloud, stranger = new_private_key(), new_private_key()
    data = sign_dgpt(predefined(2.0, created_utc="x"), stranger)
    with pytest.raises(SignatureError, match=f"this vehicle trusts {key_id(cloud.public_key())}"):
        verify_dgpt(data, cloud.public_key())
    # same key id forged onto a stranger's signature: the signature check still refuses it
    forged = json.loads(data)
    forged["key_id"] = key_id(cloud.public_key())
    with pytest.raises(SignatureError, match="tampered"):
        verify_dgpt(json.dumps(forged).encode(), cloud.public_key())


def test_a_signature_that_is_not_base64_is_refused() -> None:
    key = new_private_key()
    envelope = json.loads(sign_dgpt(predefined(2.0, created_utc="x"), key))
    envelope["signature"] = "not base64 !"
    with pytest.raises(SignatureError, match="tampered"):
        verify_dgpt(json.dumps(envelope).encode(), key.public_key())
    envelope["signature"] = base64.b64encode(b"\x00" * 64).decode()
    with pytest.raises(SignatureError, match="tampered"):
        verify_dgpt(json.dumps(envelope).encode(), key.public_key())


def test_a_validly_signed_table_outside_the_vehicles_bounds_is_refused() -> None:
    key = new_private_key()
    wide = SafetyBounds(headway_max_s=8.0)
    data = sign_dgpt(predefined(6.0, bounds=wide, created_utc="x"), key)
    assert verify_dgpt(data, key.public_key(), wide).gap_m[-1] == pytest.approx(4.0 + 6.0 * 40)
    with pytest.raises(SignatureError, match="refused"):
        verify_dgpt(data, key.public_key(), SafetyBounds())


def test_keys_round_trip_through_pem_files(tmp_path: Path) -> None:
    key = new_private_key()
    save_private_key(key, tmp_path / "cloud.key")
    (tmp_path / "cloud.pub").write_bytes(public_pem(key))
    assert (tmp_path / "cloud.key").stat().st_mode & 0o777 == 0o600
    again = load_private_key(tmp_path / "cloud.key")
    public = load_public_key(tmp_path / "cloud.pub")
    assert key_id(again.public_key()) == key_id(public) == key_id(key.public_key())
    data = sign_dgpt(predefined(2.0, created_utc="x"), again)
    assert verify_dgpt(data, public).driver_id == "guest"


def test_bad_key_files_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(SignatureError, match="cannot read public key"):
        load_public_key(tmp_path / "missing.pub")
    (tmp_path / "junk.pem").write_bytes(
        b"-----BEGIN PUBLIC KEY-----\nAAAA\n-----END PUBLIC KEY-----\n"
    )
    with pytest.raises(SignatureError, match="not a PEM public key"):
        load_public_key(tmp_path / "junk.pem")
    (tmp_path / "pub-as-private.pem").write_bytes(public_pem(new_private_key()))
    with pytest.raises(SignatureError, match="not a PEM private key"):
        load_private_key(tmp_path / "pub-as-private.pem")


@pytest.mark.parametrize(
    "envelope",
    [
        {"signature": "é", "dgpt": "{}"},  # not ASCII: base64 raises ValueError
        {"signature": "AAAA", "dgpt": "\ud800"},  # a lone surrogate cannot be encoded
    ],
)
def test_malformed_envelopes_are_signature_errors(envelope: dict[str, str]) -> None:
    key = new_private_key()
    data = json.dumps(
        {"format": "pacc.signed-dgpt/1", "key_id": key_id(key.public_key()), **envelope}
    ).encode()
    with pytest.raises(SignatureError):
        verify_dgpt(data, key.public_key())


def test_absurd_nesting_is_a_signature_error() -> None:
    with pytest.raises(SignatureError):
        verify_dgpt(b"[" * 100_000 + b"]" * 100_000, new_private_key().public_key())
