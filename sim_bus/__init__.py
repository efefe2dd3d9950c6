"""pacc bus simulator: ego physics, real-data lead scenarios, synthetic drivers, faults.

The simulator plays every node but the ACC ECU (ESC, PEDAL, RADAR, HMI) on a python-can bus
and closes the loop through the ACC command frames. Modules, one concept each:

- :mod:`sim_bus.plant` — ego longitudinal dynamics;
- :mod:`sim_bus.dataset` — the shipped real-data file;
- :mod:`sim_bus.lead` — the lead vehicle: speed profiles from the shipped OpenACC data, as CSV
  files, road scenarios (cut-in, cut-out, lead loss, stop-and-go);
- :mod:`sim_bus.drivers` — driver parameters, built-in drivers;
- :mod:`sim_bus.population` — drivers drawn from distributions calibrated on real pairs;
- :mod:`sim_bus.behaviour` — what a driver does each step;
- :mod:`sim_bus.idm` — IDM+ car following, the driver's manual following law;
- :mod:`sim_bus.following` — car-following models (IDM, constant time gap, Gipps, the
  drivers' own) fitted to real trajectories and scored on held-out replay;
- :mod:`sim_bus.manual` — ACC-off demonstrations;
- :mod:`sim_bus.world` — lead + plant + driver, the drive log;
- :mod:`sim_bus.trip` — a run's log as a trip;
- :mod:`sim_bus.faults` — fault injection;
- :mod:`sim_bus.readings` — what the simulated sensors read at a tick, per transmitted role;
- :mod:`sim_bus.node` — the bus node;
- :mod:`sim_bus.metrics` — PoI, NIM, safety figures;
- :mod:`sim_bus.errors` — the error tree, rooted at :class:`SimError`.

On top of them, and of the ECU and the cloud, two harness sub-packages wire everything
together: :mod:`pacc.study` (one drive, ``pacc drive``; the paper's Table I, ``pacc study``)
and :mod:`pacc.hil` (a person drives in a browser page, ``pacc hil``). Maintainer tools
(building the data file, calibrating the drivers) live in ``tools/`` outside the wheel.
"""

from sim_bus.errors import SimError

__all__ = ["SimError"]
