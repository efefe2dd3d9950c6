"""The ``pacc`` sub-commands: ``pacc X`` is ``pacc.commands.X``, each with ``main(argv) -> int``
that only parses options and wires the libraries (a sub-package where it spans modules).

- :mod:`pacc.commands.ecu` — ``pacc ecu``: the ACC ECU node on a CAN bus in real time;
- :mod:`pacc.commands.sim` — ``pacc sim``: the simulator alone against an ECU on a bus;
- :mod:`pacc.commands.drive` — ``pacc drive``: one closed-loop drive, ECU and simulator;
- :mod:`pacc.commands.study` — ``pacc study``: Table I, a population, a study file, HIL sessions;
- :mod:`pacc.commands.cloud` — ``pacc cloud``: the cloud's sub-commands;
- :mod:`pacc.commands.export` — ``pacc export``: convert bus logs;
- :mod:`pacc.commands.replay` — ``pacc replay``: a bus recording through the ECU or onto a bus;
- :mod:`pacc.commands.plot` — ``pacc plot``: a recorded drive over time;
- :mod:`pacc.commands.demos` — ``pacc demos extract``: a real car's bus logs as demonstrations;
- :mod:`pacc.commands.hil` — ``pacc hil``: a person drives in a browser against the ECU;
- :mod:`pacc.commands.plugins` — ``pacc plugins``: the methods that can be named;
- :mod:`pacc.commands.validate` — ``pacc validate``: the synthetic drivers beside real people;
- :mod:`pacc.commands.bench` — ``pacc bench``: the leaderboard on fresh seeds;
- :mod:`pacc.commands._args` — what several sub-commands share: bus flags, numbers, outputs.
"""
