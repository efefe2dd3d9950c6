"""The ``pacc`` sub-commands: ``pacc X`` is ``pacc.commands.X``, each with ``main(argv) -> int``
that only parses options and wires the libraries (a sub-package where it spans modules):
:mod:`pacc.commands.ecu`, :mod:`pacc.commands.sim`, :mod:`pacc.commands.drive`,
:mod:`pacc.commands.study`, :mod:`pacc.commands.cloud`, :mod:`pacc.commands.export`,
:mod:`pacc.commands.replay`, :mod:`pacc.commands.plot`, :mod:`pacc.commands.demos`,
:mod:`pacc.commands.hil`, :mod:`pacc.commands.plugins`, :mod:`pacc.commands.validate`,
:mod:`pacc.commands.bench` (``pacc --help`` says what each does); :mod:`pacc.commands._args`
holds what several share: bus flags, numbers, output checks. Each imports numpy, python-can,
MCAP and the harness in the function that runs it: ``pacc X --help`` and a usage error take
~0.05 s of CPU (tests/pacc/test_cli.py checks that none of them is imported).
"""
