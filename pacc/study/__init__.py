"""``pacc study``: the paper's human-in-the-loop study (its Table I), end to end on the bus.

One pipeline for every study: a spec (:mod:`pacc.study.spec`, the study file's schema) →
plan (one frozen :class:`~pacc.study.pipeline.Drive` per drive) → tables → drives on a
``concurrent.futures.Executor`` (:mod:`cloud_sync.engine`: this process, a local process pool
or a Dask cluster; the rows depend on neither the executor nor its number of workers) → rows
(``rows.jsonl``, resumable) → the report the spec names. Table I over d1..d5, over a drawn
population, a study file's methods, ``pacc bench``'s closed loop and the incremental-learning
experiment are specs and report choices of it.

Every drive is a pure function of (driver, scenario, method, study seed, trial): the
scenarios and the learned tables come from the study seed, the drive's noise from
``seed + trial``. Each cell of Table I averages its trials, as the paper's cells average three.

- :mod:`pacc.study.drive`: one closed-loop drive (:func:`run_drive`), ECU and simulator on
  one bus in lockstep;
- :mod:`pacc.study.drive_recording`: a drive's bus recording and live view (the world
  streamed as it runs, the drive paced to the wall clock);
- :mod:`pacc.study.irl_table`: a driver's IRL table, learned from its manual drives, cached;
- :mod:`pacc.study.spec`: :class:`StudySpec`, its methods, driver sources, validation and
  study files (``pacc study --config``);
- :mod:`pacc.study.manifest`: what a run was (code, seeds, platform), to run it again;
- :mod:`pacc.study.pipeline`: plan, tables, drives on the executor, the resumable journal;
- :mod:`pacc.study.loop`: the one vehicle–cloud wiring (study and ``pacc hil``) and the
  paper's incremental learning;
- :mod:`pacc.study.reports`: which report a spec writes, and a study file's summary;
- :mod:`pacc.study.report`: Table I in Markdown, ``drives.csv`` and the plot;
- :mod:`pacc.study.population_report`: a population's means, intervals, paired tests;
- :mod:`pacc.study.incremental_report`: the per-trip table and learning curve;
- :mod:`pacc.study.stats`: bootstrap intervals and paired tests;
- :mod:`pacc.study.bench` — ``pacc bench``: the suite (:mod:`~pacc.study.bench.suite`),
  the held-out gap error (:mod:`~pacc.study.bench.heldout`) and the leaderboard
  (:mod:`~pacc.study.bench.leaderboard`).

The command line is :mod:`pacc.commands.study`.

Output folder (Table I): ``table1.md`` (the table, averages, reductions, the paper's figures
beside ours), ``drives.csv`` (one row per drive), ``study.png``, ``irl/<driver_id>.json``
(the learned tables), ``logs/*.mcap`` (every drive as a trip log) and ``rows.jsonl`` (the
journal a stopped run resumes from). Everything is named by driver id.
"""
