"""``pacc study``: the paper's human-in-the-loop study (its Table I), end to end on the bus.

For every synthetic driver the IRL table is learned from its manual drives on the four
manual profiles (``cloud_sync.irl.trainer`` via :func:`sim_bus.study.irl_table.irl_table`, cached);
then every driver × scenario (A seen, B unseen) × controller (Predefined, Predefined + OA,
IRL, IRL + OA) × trial is one lockstep closed-loop drive through the python-can virtual bus
with the DBC codec and the full ECU (:func:`sim_bus.study.drive.run_drive`). Each cell averages
its trials, as the paper's cells average three.

Every drive is a pure function of (driver, scenario, controller, study seed, trial): the
scenarios and the IRL tables come from the study seed, the drive's noise from
``seed + trial``. Drives run on an engine (:mod:`cloud_sync.engine.base`: this process, a local
process pool, or a Dask cluster with ``--scheduler``) and the results depend on neither the
engine nor its number of workers.

The harness sits on top of the ECU, the simulator and the cloud, and wires them together, one
concept per module:

- :mod:`sim_bus.study.drive`: one closed-loop drive (:func:`run_drive`), ECU and simulator on
  one bus in lockstep;
- :mod:`sim_bus.study.drive_recording`: a drive's bus recording and live view (the world
  streamed as it runs, the drive paced to the wall clock);
- :mod:`sim_bus.study.irl_table`: a driver's IRL table, learned from its manual drives, cached;
- :mod:`sim_bus.study.tasks`: the study's drives as engine tasks (a worker imports only this
  and what it needs: this package's ``__init__`` imports nothing);
- :mod:`sim_bus.study.config`: :class:`StudyConfig` and its validation, which resolves the
  drivers (built-in names or driver files) to their ids before anything is learned or run;
- :mod:`sim_bus.study.run`: the tables, the plan of drives, the engine, the outputs;
- :mod:`sim_bus.study.collect`: the rows as drives finish, keyed, into ``drives.csv``;
- :mod:`sim_bus.study.report`: Table I in Markdown, ``drives.csv`` and the plot;
- :mod:`sim_bus.study.stats`: bootstrap intervals and paired tests;
- :mod:`sim_bus.study.loop`: the vehicle–cloud loop and the paper's incremental learning;
- :mod:`sim_bus.study.incremental_report`: the per-trip table and learning curve;
- :mod:`sim_bus.study.population`: Table I over drawn drivers, resumable;
- :mod:`sim_bus.study.population_report`: its means, intervals, paired tests and safety.
- :mod:`sim_bus.study.bench` — ``pacc bench``: the suite (:mod:`~sim_bus.study.bench.suite`),
  the held-out gap error (:mod:`~sim_bus.study.bench.heldout`) and the leaderboard
  (:mod:`~sim_bus.study.bench.leaderboard`).
- :mod:`sim_bus.study.files` — study files (:mod:`~sim_bus.study.files.studyfile`), the run's
  manifest (:mod:`~sim_bus.study.files.manifest`) and running one on the engine
  (:mod:`~sim_bus.study.files.studyrun`): ``pacc study --config``.

The command line is :mod:`pacc.commands.study` (also ``python -m sim_bus.study``).

Output folder: ``table1.md`` (the table, averages, reductions, the paper's figures beside
ours), ``drives.csv`` (one row per drive), ``study.png`` (averages, ours vs the paper),
``irl/<driver_id>.json`` (the learned tables) and ``logs/*.mcap`` (every drive as a trip log).
Everything is named by driver id, whatever path a driver file was given by.
"""
