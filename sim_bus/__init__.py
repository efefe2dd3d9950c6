"""pacc bus simulator: every node but the ACC ECU (ESC, PEDAL, RADAR, HMI) on a python-can
bus, the loop closed through the ACC command frames.

- :mod:`sim_bus.plant` — ego longitudinal dynamics;
- :mod:`sim_bus.dataset` — the shipped real-data file;
- :mod:`sim_bus.lead` — the lead vehicle: profiles from real data, CSV files, road scenarios;
- :mod:`sim_bus.drivers` — driver parameters, built-in drivers;
- :mod:`sim_bus.population` — drivers drawn from distributions calibrated on real pairs;
- :mod:`sim_bus.behaviour` — what a driver does each step;
- :mod:`sim_bus.idm` — IDM+ car following, the driver's manual following law;
- :mod:`sim_bus.following` — car-following models fitted to real trajectories;
- :mod:`sim_bus.manual` — ACC-off demonstrations;
- :mod:`sim_bus.world` — lead + plant + driver, the drive log;
- :mod:`sim_bus.trip` — a run's log as a trip;
- :mod:`sim_bus.faults` — fault injection;
- :mod:`sim_bus.readings` — what the simulated sensors read at a tick, per transmitted role;
- :mod:`sim_bus.node` — the bus node;
- :mod:`sim_bus.metrics` — PoI, NIM, safety figures;
- :mod:`sim_bus.errors` — the error tree, rooted at :class:`SimError`.
"""

from sim_bus.errors import SimError

__all__ = ["SimError"]
