"""The ``pacc`` sub-commands, one module each, named after the sub-command.

``pacc X`` is ``pacc.commands.X`` and ``pacc cloud Y`` is ``pacc.commands.cloud.Y``:
each has ``main(argv) -> int`` and only parses options and wires the libraries together.
A sub-command whose code spans several modules is a sub-package of its name, the command
itself in the ``__init__`` (``ecu``, ``drive``, ``plot``; ``cloud`` holds its own sub-commands).

- :mod:`pacc.commands.ecu` — ``pacc ecu``: the ACC ECU node on a CAN bus in real time (a
  sub-package: the command, its link to the cloud ``cloud``, its run on the bus ``run``).
- :mod:`pacc.commands.sim` — ``pacc sim``: the simulator alone against an ECU on a bus.
- :mod:`pacc.commands.drive` — ``pacc drive``: one closed-loop drive, ECU and simulator (a
  sub-package: the command, what it prints ``report``).
- :mod:`pacc.commands.study` — ``pacc study``: the paper's Table I and the population study.
- :mod:`pacc.commands.cloud` — ``pacc cloud``: dispatch to the cloud's sub-commands (a
  sub-package: ``learn``, ``serve``, ``sync``).
- :mod:`pacc.commands.export` — ``pacc export``: convert bus logs.
- :mod:`pacc.commands.replay` — ``pacc replay``: a bus recording through the ECU or onto a bus.
- :mod:`pacc.commands.plot` — ``pacc plot``: a recorded drive over time (a sub-package: the
  command, its PlotJuggler layout ``layout``).
- :mod:`pacc.commands._args` — what several sub-commands share: the bus flags, validated
  numbers, distinct outputs.
- :mod:`pacc.commands.demos` — ``pacc demos extract LOG... -o trips/``: a real car's bus logs as
  IRL demonstrations.
- :mod:`pacc.commands.hil` — the command line of ``pacc hil``: a person drives in a browser
  against the ECU.
- :mod:`pacc.commands.plugins` — ``pacc plugins``: the methods that can be named.
- :mod:`pacc.commands.validate` — ``pacc validate``: the synthetic drivers beside real people.
- :mod:`pacc.commands.bench` — ``pacc bench``: the leaderboard on fresh seeds.
"""
