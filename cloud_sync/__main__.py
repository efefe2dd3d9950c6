"""``python -m cloud_sync`` is ``pacc cloud``."""

from __future__ import annotations

from cloud_sync.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
