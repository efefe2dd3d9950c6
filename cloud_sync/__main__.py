"""``python -m cloud_sync`` is ``pacc cloud``."""

from __future__ import annotations

import sys

from pacc.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["cloud", *sys.argv[1:]]))
