"""Signed DGPTs: the cloud signs every table it publishes, the vehicle refuses anything else.

Envelope: ``{"format": "pacc.signed-dgpt/1", "key_id": "<16 hex>", "dgpt": "<table JSON
text>", "signature": "<base64 Ed25519 of the UTF-8 dgpt>"}``; the table travels as text, so the
signed bytes are the verified bytes. Keys are Ed25519 PEM (PKCS#8 / SubjectPublicKeyInfo).
:func:`verify_dgpt` checks envelope, key id, signature, then the table against the vehicle's
:class:`~dbc.vocab.dgpt.SafetyBounds`; any defect is a :class:`SignatureError`.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import os
from pathlib import Path

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey

from cloud_sync.errors import CloudSyncError
from dbc.vocab.dgpt import Dgpt, DgptError, SafetyBounds
from dbc.vocab.dgpt_file import dgpt_from_json_dict

SIGNED_FORMAT = "pacc.signed-dgpt/1"


class SignatureError(CloudSyncError):
    """A signed table or a key is unusable: unsigned, tampered, foreign key, bad bounds."""


def key_id(public_key: Ed25519PublicKey) -> str:
    """The first 16 hex digits of SHA-256 over the raw 32-byte public key."""
    raw = public_key.public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
    return hashlib.sha256(raw).hexdigest()[:16]


def new_private_key() -> Ed25519PrivateKey:
    """A fresh Ed25519 key from the operating system's random source."""
    return Ed25519PrivateKey.generate()


def save_private_key(key: Ed25519PrivateKey, path: str | os.PathLike[str]) -> None:
    """Write ``key`` as unencrypted PKCS#8 PEM, readable by the owner only (mode 0600)."""
    pem = key.private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
    )
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as stream:
        stream.write(pem)


def public_pem(key: Ed25519PrivateKey | Ed25519PublicKey) -> bytes:
    """The public half of ``key`` as SubjectPublicKeyInfo PEM."""
    public = key.public_key() if isinstance(key, Ed25519PrivateKey) else key
    return public.public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
    )


def load_private_key(path: str | os.PathLike[str]) -> Ed25519PrivateKey:
    """Read a PKCS#8 PEM Ed25519 private key; :class:`SignatureError` if unusable."""
    data = _read(path, "private key")
    try:
        key = serialization.load_pem_private_key(data, password=None)
    except (ValueError, TypeError) as exc:
        raise SignatureError(f"{path}: not a PEM private key ({exc})") from exc
    if not isinstance(key, Ed25519PrivateKey):
        raise SignatureError(f"{path}: not an Ed25519 key")
    return key


def load_public_key(source: str | os.PathLike[str] | bytes) -> Ed25519PublicKey:
    """Read a SubjectPublicKeyInfo PEM Ed25519 public key (a path or the PEM bytes)."""
    data = source if isinstance(source, bytes) else _read(source, "public key")
    try:
        key = serialization.load_pem_public_key(data)
    except (ValueError, TypeError) as exc:
        raise SignatureError(f"not a PEM public key ({exc})") from exc
    if not isinstance(key, Ed25519PublicKey):
        raise SignatureError("not an Ed25519 public key")
    return key


def _read(path: str | os.PathLike[str], what: str) -> bytes:
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise SignatureError(f"cannot read {what} {path}: {exc.strerror or exc}") from exc


def sign_dgpt(table: Dgpt, key: Ed25519PrivateKey) -> bytes:
    """The signed-table JSON bytes of ``table`` (format in the module docstring)."""
    text = json.dumps(table.to_json_dict(), sort_keys=True, allow_nan=False)
    envelope = {
        "format": SIGNED_FORMAT,
        "key_id": key_id(key.public_key()),
        "dgpt": text,
        "signature": base64.b64encode(key.sign(text.encode("utf-8"))).decode("ascii"),
    }
    return json.dumps(envelope, sort_keys=True).encode("utf-8")


def _verify(data: bytes, public_key: Ed25519PublicKey, bounds: SafetyBounds | None) -> Dgpt:
    try:
        obj = json.loads(data)
    except (ValueError, UnicodeDecodeError) as exc:
        raise SignatureError(f"signed table is not JSON ({exc})") from exc
    if not isinstance(obj, dict) or obj.get("format") != SIGNED_FORMAT:
        raise SignatureError(f"not a signed table: format must be {SIGNED_FORMAT!r} (unsigned?)")
    for key in ("key_id", "dgpt", "signature"):
        if not isinstance(obj.get(key), str):
            raise SignatureError(f"signed table: {key!r} missing or not a string")
    if obj["key_id"] != key_id(public_key):
        raise SignatureError(
            f"signed with key {obj['key_id']}, this vehicle trusts {key_id(public_key)}"
        )
    try:
        signature = base64.b64decode(obj["signature"], validate=True)
        public_key.verify(signature, obj["dgpt"].encode("utf-8"))
    except (InvalidSignature, binascii.Error) as exc:
        raise SignatureError("signature does not match the table (tampered?)") from exc
    try:
        return dgpt_from_json_dict(json.loads(obj["dgpt"]), bounds)
    except (DgptError, ValueError) as exc:
        raise SignatureError(f"signed table refused: {exc}") from exc


def verify_dgpt(
    data: bytes, public_key: Ed25519PublicKey, bounds: SafetyBounds | None = None
) -> Dgpt:
    """The table inside signed-table bytes ``data`` once signature and bounds hold; any
    defect, whatever the bytes, is a SignatureError (nothing else is raised)."""
    try:
        return _verify(data, public_key, bounds)
    except (ValueError, RecursionError) as exc:  # UnicodeError and binascii.Error included
        raise SignatureError(f"signed table is malformed ({type(exc).__name__}: {exc})") from exc
