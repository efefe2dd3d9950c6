"""``python -m ecu`` is ``pacc ecu``."""

from __future__ import annotations

import sys

from pacc.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["ecu", *sys.argv[1:]]))
