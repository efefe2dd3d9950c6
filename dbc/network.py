"""The ``--dbc`` / ``--binding`` options every command shares, and the codec they name
(:func:`dbc.codec.network_paths`: a DBC alone is a usage error); the codec is imported when
named, not for ``--help``."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dbc.codec import Codec


def add_network_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--dbc`` and ``--binding`` to ``parser``."""
    group = parser.add_argument_group(
        "vehicle network (default: the packaged pacc network; docs/vehicles.md)"
    )
    group.add_argument("--dbc", metavar="FILE", help="the vehicle's DBC (needs --binding)")
    group.add_argument(
        "--binding",
        metavar="FILE",
        help="binding table of pacc's roles to the DBC (TOML; alone: the DBC it names), or "
        "a packaged binding's name: toyota_nodsu",
    )


def network_of(args: argparse.Namespace) -> tuple[Path, Path]:
    """The (DBC, binding) files of parsed ``args`` (BindingError as network_paths)."""
    from dbc.codec import network_paths  # noqa: PLC0415

    return network_paths(args.dbc, args.binding)


def codec_of(args: argparse.Namespace) -> Codec:
    """The codec of parsed ``args``, loaded once (DbcError: unusable network)."""
    from dbc.codec import load_codec  # noqa: PLC0415

    return load_codec(*network_of(args))
