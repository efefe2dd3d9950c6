"""The ``pacc`` sub-commands, one module each, named after the sub-command.

``pacc X`` is :mod:`pacc.commands.X` and ``pacc cloud Y`` is :mod:`pacc.commands.cloud_Y`:
each has ``main(argv) -> int`` and only parses options and wires the libraries together.

- :mod:`pacc.commands.ecu` — ``pacc ecu``: the ACC ECU node on a CAN bus in real time.
- :mod:`pacc.commands.sim` — ``pacc sim``: the simulator alone against an ECU on a bus.
- :mod:`pacc.commands.drive` — ``pacc drive``: one closed-loop drive, ECU and simulator.
- :mod:`pacc.commands.study` — ``pacc study``: the paper's Table I and the population study.
- :mod:`pacc.commands.cloud` — ``pacc cloud``: dispatch to the cloud's sub-commands.
- :mod:`pacc.commands.cloud_learn` — ``pacc cloud learn``: a driver's DGPT by IRL from files.
- :mod:`pacc.commands.cloud_serve` — ``pacc cloud serve`` and ``pacc cloud register``.
- :mod:`pacc.commands.cloud_sync` — ``pacc cloud sync``: spool and upload trip logs.
- :mod:`pacc.commands.export` — ``pacc export``: convert bus logs.
- :mod:`pacc.commands.replay` — ``pacc replay``: a bus recording through the ECU or onto a bus.
- :mod:`pacc.commands.plot` — ``pacc plot``: a recorded drive over time.
- :mod:`pacc.commands.plugins` — ``pacc plugins``: the methods that can be named.
- :mod:`pacc.commands.bench` — ``pacc bench``: the leaderboard on fresh seeds.
"""
