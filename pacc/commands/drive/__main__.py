"""``python -m pacc.commands.drive`` runs ``pacc drive``'s ``main``."""

from __future__ import annotations

from pacc.commands.drive import main

if __name__ == "__main__":
    raise SystemExit(main())
