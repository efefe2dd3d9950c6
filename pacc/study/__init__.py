"""``pacc study``: the paper's study (its Table I), end to end on the bus.

One pipeline for every mode: spec → plan → tables → drives on an executor (this process,
local processes or Dask; the rows depend on neither) → ``rows.jsonl`` (resumable) → report.
Every drive is a pure function of (driver, scenario, method, study seed, trial).

- :mod:`pacc.study.drive`: one closed-loop drive, ECU and simulator on one bus in lockstep;
- :mod:`pacc.study.drive_recording`: a drive's bus recording and live view, the pacer;
- :mod:`pacc.study.irl_table`: a driver's IRL table, learned from its manual drives, cached;
- :mod:`pacc.study.spec`: :class:`StudySpec` (every mode), its methods and study files;
- :mod:`pacc.study.manifest`: what a run was (code, seeds, platform), to run it again;
- :mod:`pacc.study.pipeline`: plan, tables, drives on the executor, the resumable journal;
- :mod:`pacc.study.loop`: the one vehicle–cloud wiring and the paper's incremental learning;
- :mod:`pacc.study.report`: every mode's Markdown, CSV and plots (the one report writer);
- :mod:`pacc.study.stats`: means over drivers, bootstrap intervals, paired tests (the one
  statistics module);
- :mod:`pacc.study.bench`: ``pacc bench``, the leaderboard on fresh seeds.
"""
