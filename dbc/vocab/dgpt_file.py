"""The DGPT file format: a table (:class:`dbc.vocab.dgpt.Dgpt`) as one JSON object.

``{"format": "pacc.dgpt/1", "driver_id", "condition", "source", "version", "created_utc",
"speed_mps": [...], "gap_m": [...], "meta": {...}}`` (speeds m/s, gaps m). Reading checks the
tag, keys, shapes, axis, plain names, finite values and the safety bounds, else
:class:`DgptError` naming the defect (and the file). :func:`load_dgpt` reads only a regular
file of at most :data:`MAX_DGPT_BYTES`; :func:`save_dgpt` is atomic.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Any

import numpy as np

from dbc.atomic import write_bytes_atomic
from dbc.vocab.dgpt import FORMAT_TAG, PLAIN_NAME, Dgpt, DgptError, SafetyBounds

#: the largest DGPT file read, bytes (a 0.5 m/s table is about 4 KB)
MAX_DGPT_BYTES = 1 << 20


def dgpt_from_json_dict(obj: Any, bounds: SafetyBounds | None = None) -> Dgpt:
    """Build and validate a table from its parsed JSON object."""
    if not isinstance(obj, dict):
        raise DgptError("top level is not a JSON object")
    tag = obj.get("format")
    if tag != FORMAT_TAG:
        raise DgptError(f"format tag is {tag!r}, expected {FORMAT_TAG!r}")
    missing = [k for k in ("speed_mps", "gap_m", "version", "source") if k not in obj]
    if missing:
        raise DgptError(f"missing key(s): {', '.join(missing)}")
    for key in ("speed_mps", "gap_m"):
        seq = obj[key]
        if not isinstance(seq, list) or not all(
            isinstance(x, int | float) and not isinstance(x, bool) for x in seq
        ):
            raise DgptError(f"{key} must be a list of numbers")
    try:
        speed = np.asarray(obj["speed_mps"], dtype=np.float64)
        gap = np.asarray(obj["gap_m"], dtype=np.float64)
    except OverflowError:
        raise DgptError("speed_mps or gap_m holds a number too large for a float") from None
    table = Dgpt(
        speed_mps=speed,
        gap_m=gap,
        version=obj["version"],
        driver_id=obj.get("driver_id", "guest"),
        condition=obj.get("condition", "default"),
        source=obj["source"],
        created_utc=obj.get("created_utc", ""),
        meta=obj.get("meta", {}),
    )
    for name in ("driver_id", "condition"):  # they name folders and are printed
        if PLAIN_NAME.fullmatch(getattr(table, name)) is None:
            raise DgptError(
                f"{name} {getattr(table, name)!a} is not a plain name (1-64 letters, digits, "
                "_.-, starting with a letter or digit)"
            )
    table.check_bounds(bounds)
    return table


def dgpt_from_bytes(data: bytes, bounds: SafetyBounds | None = None) -> Dgpt:
    """Parse and validate the bytes of a DGPT file ("not valid JSON: ..." or
    "invalid DGPT: ...")."""
    try:
        obj = json.loads(data.decode("utf-8"), parse_constant=float)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, int digit limit, nesting
        raise DgptError(f"not valid JSON: {exc}") from None
    try:
        return dgpt_from_json_dict(obj, bounds)
    except DgptError as exc:
        raise DgptError(f"invalid DGPT: {exc}") from None


def dgpt_to_bytes(table: Dgpt) -> bytes:
    """The bytes of ``table``'s DGPT file (UTF-8 JSON, indented, a final newline)."""
    return (json.dumps(table.to_json_dict(), indent=1) + "\n").encode("utf-8")


def load_dgpt(path: str | os.PathLike[str], bounds: SafetyBounds | None = None) -> Dgpt:
    """Read and validate a DGPT file; :class:`DgptError` names the file and the defect."""
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO must not block the open
        with os.fdopen(fd, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise DgptError(f"{p}: not a regular file")
            raw = fh.read(MAX_DGPT_BYTES + 1)
    except OSError as exc:
        raise DgptError(f"{p}: cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_DGPT_BYTES:
        raise DgptError(f"{p}: larger than {MAX_DGPT_BYTES} bytes")
    try:
        return dgpt_from_bytes(raw, bounds)
    except DgptError as exc:
        raise DgptError(f"{p}: {exc}") from None


def save_dgpt(table: Dgpt, path: str | os.PathLike[str]) -> None:
    """Write ``table`` to ``path`` atomically (:mod:`dbc.atomic`; DgptError if it cannot)."""
    try:
        write_bytes_atomic(path, dgpt_to_bytes(table))
    except OSError as exc:
        raise DgptError(f"{Path(path)}: cannot write: {exc.strerror or exc}") from None
