"""The ground floor: the vehicle network (the packaged ``pacc.dbc``, its binding, the codec),
the vocabulary every room shares, and the project's error root.

- :mod:`dbc.schema` — pacc's logical roles and fields, the input roles' resting values.
- :mod:`dbc.binding` — the binding table: roles and fields to a vehicle's signals.
- :mod:`dbc.units` — signal units and their conversion to pacc's.
- :mod:`dbc.layout` — where a bound signal sits in a payload and how its raw value maps.
- :mod:`dbc.checksums` — per-message checksums, pluggable by name.
- :mod:`dbc.e2e` — CRC-8 SAE J1850 and the alive-counter receiver check.
- :mod:`dbc.codec` — the network's codec, by role and frame id.
- :mod:`dbc.message` — one bound message's generated encoder and decoder.
- :mod:`dbc.columns` — column-wise decoding of many frames of any message.
- :mod:`dbc.endpoint` — a node's inbox (decode + E2E) and outbox (counter + checksum).
- :mod:`dbc.frame` — the one frame form inside the nodes, and the python-can edge.
- :mod:`dbc.network` — the ``--dbc`` / ``--binding`` options.
- :mod:`dbc.errors` — ``PaccError`` and the codec's errors by phase.
- :mod:`dbc.atomic` — files written whole or not at all (temporary file, then a rename).
- :mod:`dbc.vocab` — DGPT and trip-log formats, ACC state, pedal scaling.
- :mod:`dbc.lockstep` — the in-process python-can bus where the simulator owns time.
"""

from __future__ import annotations

from pathlib import Path

#: Folder holding the packaged network description.
DATA_DIR: Path = Path(__file__).resolve().parent
#: The pacc vehicle network (cantools-loadable, strict).
DBC_PATH: Path = DATA_DIR / "pacc.dbc"
#: Binding of pacc's logical roles and fields to the messages and signals of DBC_PATH.
BINDING_PATH: Path = DATA_DIR / "pacc.binding.toml"

__all__ = ["BINDING_PATH", "DATA_DIR", "DBC_PATH"]
