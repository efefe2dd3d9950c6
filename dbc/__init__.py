"""The ground floor: the emulated vehicle network (the DBC, its binding to pacc's logical
quantities, the codec), the vocabulary every room shares, and the project's error root.

``dbc/pacc.dbc`` is installed with the package, so an installed pacc finds it without the
source tree. Import :mod:`dbc.codec` for the frame codec and :mod:`dbc.endpoint` for a
node's inbox (decode + E2E checks) and outbox (counter + CRC on send).

- :mod:`dbc.schema` — pacc's logical roles and fields, and the input roles' resting values.
- :mod:`dbc.binding` — the binding table: roles and fields to a vehicle's messages and signals.
- :mod:`dbc.units` — physical units of DBC signals and their conversion to pacc's units.
- :mod:`dbc.layout` — where a bound signal sits in a payload and how its raw value maps.
- :mod:`dbc.checksums` — per-message checksums, pluggable by name in the binding.
- :mod:`dbc.e2e` — CRC-8 SAE J1850 and the alive-counter receiver check.
- :mod:`dbc.codec` — the frame codec shared by the ECU and the simulator (compiled once).
- :mod:`dbc.message` — one bound message's encoder and decoder, compiled to straight-line
  Python (``MessageCodec``).
- :mod:`dbc.columns` — column-wise decoding of many frames of one message.
- :mod:`dbc.endpoint` — a node's inbox (decode + E2E check) and outbox (counter + CRC).
- :mod:`dbc.frame` — the one frame form inside pacc's nodes, ``(timestamp, key, payload)``,
  and the port that meets a python-can bus at its edge (``port_of``).
- :mod:`dbc.network` — the ``--dbc`` / ``--binding`` options and the codec they name.
- :mod:`dbc.errors` — ``PaccError``, the root of every error the project raises on purpose,
  and the codec's exception tree, named by phase (load, encode, decode).
- :mod:`dbc.vocab` — the vocabulary the ECU, the simulator and the cloud share: the DGPT and
  trip-log formats, ACC state, pedal scaling.
- :mod:`dbc.lockstep` — A python-can bus for in-process simulation where the simulator owns
  time: ``lockstep``.
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
