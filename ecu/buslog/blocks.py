"""The block encoding of a bus recording: named columns as base64 little-endian arrays in JSON.

A block is one JSON object: ``"n"`` (rows), ``"dtypes"`` (column -> numpy dtype string,
``<f8``, ``<i8``, ``<u4``, ``|u1``) and one base64 string per column holding its ``n`` values
as that dtype's little-endian bytes. Formatting floats as JSON text costs about a
microsecond a value, more than everything else the recorder does per frame; the bytes of
a float64 array cost a few nanoseconds and keep every value exactly (NaN included). Any
JSON reader with base64 and a typed-array view (numpy's ``frombuffer``) reads it.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Collection, Mapping
from typing import Any

import numpy as np


class BlockError(ValueError):
    """A block is not the encoding of this module."""


def encode_block(columns: Mapping[str, np.ndarray], ragged: Collection[str] = ()) -> bytes:
    """One JSON block of ``columns`` (equal-length 1-D arrays; their dtypes are kept); the
    columns named in ``ragged`` may have any length (listed under ``"ragged"``)."""
    n = None
    dtypes: dict[str, str] = {}
    parts: list[str] = []
    for name, arr in columns.items():
        a = np.ascontiguousarray(arr)
        if a.dtype.byteorder == ">":
            a = a.astype(a.dtype.newbyteorder("<"))
        if name in ragged:
            pass
        elif n is None:
            n = len(a)
        elif len(a) != n:
            raise BlockError(f"column {name} has {len(a)} rows, not {n}")
        dtypes[name] = a.dtype.str
        # base64 needs no JSON escaping: joined as text, not scanned by json.dumps
        parts.append(f'{json.dumps(name)}:"{base64.b64encode(a.tobytes()).decode("ascii")}"')
    head: dict[str, Any] = {"n": n or 0, "dtypes": dtypes}
    if ragged:
        head["ragged"] = sorted(ragged)
    text = json.dumps(head)
    if parts:
        text = text[:-1] + "," + ",".join(parts) + "}"
    return text.encode("ascii")


def decode_block(data: bytes | str | Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The columns of a block (:func:`encode_block`); BlockError if it is not one."""
    try:
        doc = json.loads(data) if isinstance(data, bytes | str) else data
        n = int(doc["n"])
        ragged = set(doc.get("ragged", ()))
        out: dict[str, np.ndarray] = {}
        for name, dtype in doc["dtypes"].items():
            arr = np.frombuffer(base64.b64decode(doc[name], validate=True), dtype=np.dtype(dtype))
            if len(arr) != n and name not in ragged:
                raise BlockError(f"column {name} holds {len(arr)} values, not {n}")
            out[name] = arr
        return out
    except BlockError:
        raise
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        raise BlockError(f"not a block: {type(exc).__name__}: {exc}") from None


def block_schema(
    title: str,
    description: str,
    columns: Mapping[str, tuple[str, str]],
    ragged: Collection[str] = (),
) -> dict[str, Any]:
    """The JSON schema of a block whose ``columns`` map name -> (dtype, description), the
    columns named in ``ragged`` of any length."""
    props: dict[str, Any] = {
        "n": {"type": "integer", "minimum": 0, "description": "rows in this block"},
        "dtypes": {
            "type": "object",
            "description": "column -> numpy dtype string of its little-endian values",
            "properties": {
                name: {"type": "string", "const": dt} for name, (dt, _) in columns.items()
            },
            "additionalProperties": {"type": "string"},
        },
    }
    if ragged:
        props["ragged"] = {
            "type": "array",
            "items": {"type": "string"},
            "description": "the columns whose length is not n",
        }
    for name, (dtype, desc) in columns.items():
        props[name] = {
            "type": "string",
            "contentEncoding": "base64",
            "description": f"{desc} [{dtype} little-endian array of n values]",
        }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": props,
        "required": ["n", "dtypes", *columns],
    }
