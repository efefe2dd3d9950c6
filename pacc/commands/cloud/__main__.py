"""``python -m pacc.commands.cloud`` runs ``pacc cloud``'s ``main``."""

from __future__ import annotations

from pacc.commands.cloud import main

if __name__ == "__main__":
    raise SystemExit(main())
