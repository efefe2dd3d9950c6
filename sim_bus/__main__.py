"""``python -m sim_bus`` is ``pacc sim``: the simulator alone against an ECU on a bus."""

import sys

from pacc.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["sim", *sys.argv[1:]]))
