"""``pacc plugins``: the methods that can be named — gap controllers, adaptations, learners.

Lists the built-ins and every installed entry point of ``pacc.controllers``,
``pacc.adaptations`` and ``pacc.learners`` with where it comes from and its target; with
``--check`` each one is loaded (an entry point whose module does not import is reported, exit
1). Any of them, or a ``module:attribute``, can be named by ``pacc drive --gap-controller /
--adaptation`` and in a study file (docs/plugins.md).
"""

from __future__ import annotations

import sys

from pacc.commands._args import CommandParser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc plugins``; returns the exit status."""
    p = CommandParser(prog="pacc plugins", description=__doc__.split("\n\n")[0])
    p.add_argument("--check", action="store_true", help="load every method, report failures")
    args = p.parse_args(argv)
    from cloud_sync.learners import BUILTIN_LEARNERS  # noqa: PLC0415 - numpy: not for --help
    from dbc.vocab.plugins import GROUPS, PluginError, installed, load_target  # noqa: PLC0415
    from ecu.methods import BUILTIN_ADAPTATIONS, BUILTIN_CONTROLLERS  # noqa: PLC0415

    builtins = (BUILTIN_CONTROLLERS, BUILTIN_ADAPTATIONS, BUILTIN_LEARNERS)
    failed = 0
    for group, builtin in zip(GROUPS, builtins, strict=True):
        print(f"{group}:")
        for found in installed(group, builtin):
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
