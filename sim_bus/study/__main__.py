"""``python -m sim_bus.study`` is ``pacc study``."""

import sys

from pacc.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["study", *sys.argv[1:]]))
