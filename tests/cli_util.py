"""Running a sub-command's ``main`` in-process the way the shell sees it: its exit status."""

from __future__ import annotations

from collections.abc import Callable


def exit_code(main: Callable[[list[str]], int], argv: list[str]) -> int:
    """``main(argv)``'s return value, or the code of the SystemExit argparse raised (a usage
    error: 2)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 1
