"""``python -m pacc.commands.ecu`` runs ``pacc ecu``'s ``main``."""

from __future__ import annotations

from pacc.commands.ecu import main

if __name__ == "__main__":
    raise SystemExit(main())
