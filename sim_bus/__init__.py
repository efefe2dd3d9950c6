"""pacc bus simulator: ego physics, real-data lead scenarios, synthetic drivers, faults.

The simulator plays every node but the ACC ECU (ESC, PEDAL, RADAR, HMI) on a python-can bus
and closes the loop through the ACC command frames. Sub-modules, one concept each:
``plant`` (ego dynamics), ``scenarios`` (lead speed profiles from the shipped OpenACC data),
``drivers`` (driver parameters, built-in drivers), ``behaviour`` (what a driver does each
step), ``manual`` (ACC-off demonstrations), ``world`` (lead + plant + driver, the drive log),
``trip`` (a run's log as a trip), ``faults`` (fault injection), ``node`` (the bus node),
``metrics`` (PoI, NIM, safety figures), ``drive`` (``pacc drive``), ``irl_table`` (the
learned table of the irl controllers), ``cli`` (``pacc sim``). On top of them, the sub-package
``study`` (``pacc study``, the paper's Table I). Maintainer tools (building the data file,
calibrating the drivers) live in ``tools/`` at the repository root, outside the wheel.
"""

from sim_bus.errors import SimError

__all__ = ["SimError"]
