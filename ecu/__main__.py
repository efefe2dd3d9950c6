"""``python -m ecu`` is ``pacc ecu``."""

from __future__ import annotations

from ecu.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
