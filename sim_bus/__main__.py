"""``python -m sim_bus`` is ``pacc sim``: the simulator alone against an ECU on a bus."""

from pacc.commands.sim import main

if __name__ == "__main__":
    raise SystemExit(main())
