"""The emulated vehicle network: the DBC, its binding to pacc's logical quantities, the codec.

``dbc/pacc.dbc`` is installed with the package, so an installed pacc finds it without the
source tree. Import :mod:`dbc.codec` for the frame codec and :mod:`dbc.endpoint` for a
node's inbox (decode + E2E checks) and outbox (counter + CRC on send).
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
