"""``python -m ecu`` is ``pacc ecu``."""

from __future__ import annotations

from pacc.commands.ecu import main

if __name__ == "__main__":
    raise SystemExit(main())
