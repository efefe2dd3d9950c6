"""The ``--dbc`` / ``--binding`` options every command shares, and the codec they name.

``--binding FILE`` alone brings the DBC its ``dbc`` key names (beside the file); ``--dbc``
needs a binding that names it: a DBC alone is a usage error, never a silent fallback to the
packaged binding (:func:`dbc.codec.network_paths`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from dbc.codec import Codec, load_codec, network_paths


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
    """The (DBC, binding) files of parsed ``args``.

    Raises:
        BindingError: ``--dbc`` without ``--binding``, or a binding naming another DBC.
    """
    return network_paths(args.dbc, args.binding)


def codec_of(args: argparse.Namespace) -> Codec:
    """The codec of parsed ``args`` (:func:`network_of`), loaded once.

    Raises:
        DbcError: as :func:`network_of`, or the DBC or binding cannot be loaded or matched.
    """
    dbc, binding = network_of(args)
    return load_codec(dbc, binding)


__all__ = ["add_network_arguments", "codec_of", "network_of"]
