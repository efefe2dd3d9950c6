"""``pacc plugins``: the methods that can be named — gap controllers, adaptations, learners.

Lists the built-ins and every installed entry point of ``pacc.controllers``,
``pacc.adaptations`` and ``pacc.learners`` with where it comes from and its target; with
``--check`` each one is loaded (an entry point whose module does not import is reported, exit
1). Any of them, or a ``module:attribute``, can be named by ``pacc drive --gap-controller /
--adaptation`` and in a study file (docs/plugins.md).
"""

from __future__ import annotations

import sys

from cloud_sync.learners import BUILTIN_LEARNERS
from dbc.vocab.plugins import GROUPS, PluginError, installed, load_target
from ecu.methods import BUILTIN_ADAPTATIONS, BUILTIN_CONTROLLERS
from pacc.commands._args import CommandParser

BUILTINS = dict(
    zip(GROUPS, (BUILTIN_CONTROLLERS, BUILTIN_ADAPTATIONS, BUILTIN_LEARNERS), strict=True)
)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc plugins``; returns the exit status."""
    p = CommandParser(prog="pacc plugins", description=__doc__.split("\n\n")[0])
    p.add_argument("--check", action="store_true", help="load every method, report failures")
    args = p.parse_args(argv)
    failed = 0
    for group in GROUPS:
        print(f"{group}:")
        for found in installed(group, BUILTINS[group]):
            status = ""
            if args.check:
                try:
                    load_target(found.target)
                    status = "  ok"
                except PluginError as exc:
                    status = f"  FAILED: {exc}"
                    failed += 1
            print(f"  {found.name:<14} {found.origin:<18} {found.target}{status}")
    if failed:
        print(f"pacc plugins: {failed} method(s) failed to load", file=sys.stderr)
        return 1
    return 0
