"""``python -m cloud_sync`` is ``pacc cloud``."""

from __future__ import annotations

from pacc.commands.cloud import main

if __name__ == "__main__":
    raise SystemExit(main())
