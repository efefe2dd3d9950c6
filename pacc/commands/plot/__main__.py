"""``python -m pacc.commands.plot`` runs ``pacc plot``'s ``main``."""

from __future__ import annotations

from pacc.commands.plot import main

if __name__ == "__main__":
    raise SystemExit(main())
