"""``pacc study``: the paper's human-in-the-loop study (its Table I), end to end on the bus.

For every synthetic driver the IRL table is learned from its manual drives on the four
manual profiles (``cloud_sync.irl.trainer`` via :func:`pacc.study.irl_table.irl_table`, cached);
then every driver × scenario (A seen, B unseen) × controller (Predefined, Predefined + OA,
IRL, IRL + OA) × trial is one lockstep closed-loop drive through the python-can virtual bus
with the DBC codec and the full ECU (:func:`pacc.study.drive.run_drive`). Each cell averages
its trials, as the paper's cells average three.

Every drive is a pure function of (driver, scenario, controller, study seed, trial): the
scenarios and the IRL tables come from the study seed, the drive's noise from
``seed + trial``. Drives run on an engine (:mod:`cloud_sync.engine.base`: this process, a local
process pool, or a Dask cluster with ``--scheduler``) and the results depend on neither the
engine nor its number of workers.

The harness sits on top of the ECU, the simulator and the cloud, and wires them together, one
concept per module:

- :mod:`pacc.study.drive`: one closed-loop drive (:func:`run_drive`), ECU and simulator on
  one bus in lockstep;
- :mod:`pacc.study.drive_recording`: a drive's bus recording and live view (the world
  streamed as it runs, the drive paced to the wall clock);
- :mod:`pacc.study.irl_table`: a driver's IRL table, learned from its manual drives, cached;
- :mod:`pacc.study.tasks`: the study's drives as engine tasks (a worker imports only this
  and what it needs: this package's ``__init__`` imports nothing);
- :mod:`pacc.study.config`: :class:`StudyConfig` and its validation, which resolves the
  drivers (built-in names or driver files) to their ids before anything is learned or run;
- :mod:`pacc.study.run`: the tables, the plan of drives, the engine, the outputs;
- :mod:`pacc.study.collect`: the rows as drives finish, keyed, into ``drives.csv``;
- :mod:`pacc.study.report`: Table I in Markdown, ``drives.csv`` and the plot;
- :mod:`pacc.study.stats`: bootstrap intervals and paired tests;
- :mod:`pacc.study.loop`: the vehicle–cloud loop and the paper's incremental learning;
- :mod:`pacc.study.incremental_report`: the per-trip table and learning curve;
- :mod:`pacc.study.population`: Table I over drawn drivers, resumable;
- :mod:`pacc.study.population_report`: its means, intervals, paired tests and safety.
- :mod:`pacc.study.bench` — ``pacc bench``: the suite (:mod:`~pacc.study.bench.suite`),
  the held-out gap error (:mod:`~pacc.study.bench.heldout`) and the leaderboard
  (:mod:`~pacc.study.bench.leaderboard`).
- :mod:`pacc.study.files` — study files (:mod:`~pacc.study.files.studyfile`), the run's
  manifest (:mod:`~pacc.study.files.manifest`) and running one on the engine
  (:mod:`~pacc.study.files.studyrun`): ``pacc study --config``.

The command line is :mod:`pacc.commands.study` (also ``python -m pacc.study``).

Output folder: ``table1.md`` (the table, averages, reductions, the paper's figures beside
ours), ``drives.csv`` (one row per drive), ``study.png`` (averages, ours vs the paper),
``irl/<driver_id>.json`` (the learned tables) and ``logs/*.mcap`` (every drive as a trip log).
Everything is named by driver id, whatever path a driver file was given by.
"""
