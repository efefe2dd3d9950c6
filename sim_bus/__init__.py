"""pacc bus simulator: ego physics, real-data lead scenarios, synthetic drivers, faults.

The simulator plays every node but the ACC ECU (ESC, PEDAL, RADAR, HMI) on a python-can bus
and closes the loop through the ACC command frames. Sub-modules, one concept each:
``plant`` (ego dynamics), ``scenarios`` (lead speed profiles from the shipped OpenACC data),
``drivers`` (driver parameters, built-in drivers), ``behaviour`` (what a driver does each
step), ``manual`` (ACC-off demonstrations), ``faults`` (fault injection), ``node`` (the bus
node), ``metrics`` (PoI, NIM, safety figures), ``drive`` (``pacc drive``), ``cli`` (``pacc sim``).
"""

from sim_bus.errors import SimError

__all__ = ["SimError"]
