"""``python -m pacc`` is the ``pacc`` console script."""

from pacc.cli import main

raise SystemExit(main())
