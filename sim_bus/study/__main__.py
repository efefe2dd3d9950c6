"""``python -m sim_bus.study`` is ``pacc study``."""

from sim_bus.study.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
