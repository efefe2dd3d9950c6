"""``python -m sim_bus.study`` is ``pacc study``."""

from pacc.commands.study import main

if __name__ == "__main__":
    raise SystemExit(main())
