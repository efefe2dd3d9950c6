"""Study files: ``pacc study --config study.toml`` — what to run, in one reviewable file.

A study file (TOML; or the JSON manifest a run wrote, whose ``config`` is read) names::

    seed = 0              # the scenarios' and the learners' seed; trial k drives with seed + k
    trials = 1
    duration_s = 60.0     # shortens every drive (omit: the whole profile)
    workers = 2           # local processes; scheduler = "local" or "tcp://HOST:8786": Dask

    [drivers]
    builtin = ["d1", "d2"]                        # d1..d5
    files = ["my_driver.toml"]                    # driver files (docs/drivers.md)
    population = [{ n = 3, seed = 7 }]            # drawn drivers (sim_bus.population)

    [scenarios]
    names = ["A", "B"]                            # A, B, manual1..manual4
    csv = ["lead.csv"]                            # lead profiles t_s,v_lead_mps

    [[methods]]                                   # one table of combinations; lists expand
    table = ["predefined", "irl"]                 # "predefined" or a learner spec
    adaptation = ["none", "paper", "bayes"]       # "none" or an adaptation spec
    controller = "pid"                            # "pid"/"builtin" or a controller spec
    learner_args = {}                             # parameters of the learner, adaptation,
    adaptation_args = {}                          # controller (keyword arguments of their
    controller_args = {}                          # factories)
    name = "..."                                  # optional; default table+adaptation[@ctl]

:func:`resolve` turns it into the **resolved config**: every default filled in, every
combination spelled out, relative paths made absolute. That dict is what runs, what the
manifest stores and what a manifest reproduces. Specs are checked (each one loads) before
anything runs.
"""

from __future__ import annotations

import itertools
import json
import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from cloud_sync.learners import make_learner
from dbc.vocab import FormatError
from ecu.methods import make_adaptation, make_controller
from pacc.study.spec import ECU_ADAPTATION, Method, StudySpec
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.errors import SimError
from sim_bus.lead.scenarios import canonical_profiles

#: the keys of a study file's top level and of a method
TOP_KEYS = {
    "seed",
    "trials",
    "duration_s",
    "workers",
    "scheduler",
    "drivers",
    "scenarios",
    "methods",
    "name",
}
METHOD_KEYS = {
    "name",
    "table",
    "adaptation",
    "controller",
    "learner_args",
    "adaptation_args",
    "controller_args",
}


class StudyFileError(SimError):
    """A study file that cannot run: unreadable, unknown key, bad value, unknown method."""


def _list(value: Any, key: str) -> list[Any]:
    if value is None:
        return []
    items = value if isinstance(value, list) else [value]
    if not all(isinstance(x, str | int | float | dict) for x in items):
        raise StudyFileError(f"{key}: expected a value or a list, got {value!r}")
    return items


def _args(value: Any, key: str) -> tuple[tuple[str, Any], ...]:
    if value is None:
        return ()
    if not isinstance(value, Mapping):
        raise StudyFileError(f"{key} must be a table of parameters, got {value!r}")
    return tuple(sorted((str(k), v) for k, v in value.items()))


def expand_methods(entries: Any) -> list[Method]:
    """Every combination of every ``[[methods]]`` entry, names unique."""
    if not isinstance(entries, list) or not entries:
        raise StudyFileError("give at least one [[methods]] entry")
    out: list[Method] = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, Mapping):
            raise StudyFileError(f"methods[{i}] must be a table")
        unknown = set(entry) - METHOD_KEYS
        if unknown:
            raise StudyFileError(f"methods[{i}]: unknown keys {sorted(unknown)}")
        tables = _list(entry.get("table", "predefined"), "table")
        adaptations = _list(entry.get("adaptation", "none"), "adaptation")
        controllers = _list(entry.get("controller", "builtin"), "controller")
        combos = list(itertools.product(tables, adaptations, controllers))
        if "name" in entry and len(combos) > 1:
            raise StudyFileError(f"methods[{i}]: a name names one combination, not {len(combos)}")
        for table, adaptation, controller in combos:
            ada = "" if adaptation == "none" else str(adaptation)
            ctl = "" if controller == "builtin" else str(controller)
            name = entry.get("name") or str(table) + (f"+{ada}" if ada else "") + (
                f"@{ctl}" if ctl else ""
            )
            out.append(
                Method(
                    str(name),
                    str(table),
                    ada,
                    ctl,
                    _args(entry.get("learner_args"), "learner_args"),
                    _args(entry.get("adaptation_args"), "adaptation_args"),
                    _args(entry.get("controller_args"), "controller_args"),
                )
            )
    names = [m.name for m in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise StudyFileError(f"two methods named {dup}: give each combination a name")
    return out


def check_methods(methods: list[Method]) -> None:
    """Every spec loads and accepts its arguments (StudyFileError naming the one that fails)."""
    try:
        for m in methods:
            if m.table != "predefined":
                make_learner(m.table, dict(m.learner_args))
            if m.adaptation and m.adaptation != ECU_ADAPTATION:
                make_adaptation(m.adaptation, dict(m.adaptation_args))
            if m.controller:
                make_controller(m.controller, dict(m.controller_args))
    except FormatError as exc:
        raise StudyFileError(f"method {m.name!r}: {exc}") from exc


def _drivers(raw: Any, base: Path) -> dict[str, Any]:
    raw = raw if raw is not None else {"builtin": ["d1"]}
    if not isinstance(raw, Mapping) or set(raw) - {"builtin", "files", "population"}:
        raise StudyFileError("[drivers] takes builtin, files and population")
    builtin = [str(x) for x in _list(raw.get("builtin"), "drivers.builtin")]
    bad = [b for b in builtin if b not in BUILTIN_DRIVERS]
    if bad:
        raise StudyFileError(f"unknown built-in drivers {bad}: one of {sorted(BUILTIN_DRIVERS)}")
    files = [str((base / str(f)).resolve()) for f in _list(raw.get("files"), "drivers.files")]
    pops = []
    for p in _list(raw.get("population"), "drivers.population"):
        if not isinstance(p, Mapping) or not {"n", "seed"} <= set(p):
            raise StudyFileError("drivers.population entries are { n = N, seed = S }")
        n, seed = int(p["n"]), int(p["seed"])
        if n < 1 or seed < 0:
            raise StudyFileError(f"a population needs n >= 1 and seed >= 0, got {n}, {seed}")
        pops.append({"n": n, "seed": seed})
    if not (builtin or files or pops):
        raise StudyFileError("[drivers] names no driver")
    return {"builtin": builtin, "files": files, "population": pops}


def _scenarios(raw: Any, base: Path, seed: int) -> list[str]:
    raw = raw if raw is not None else {"names": ["B"]}
    if isinstance(raw, list):  # the resolved form (a manifest): names and CSV paths in one list
        raw = {
            "names": [s for s in raw if not str(s).lower().endswith(".csv")],
            "csv": [s for s in raw if str(s).lower().endswith(".csv")],
        }
    if not isinstance(raw, Mapping) or set(raw) - {"names", "csv"}:
        raise StudyFileError("[scenarios] takes names and csv")
    names = [str(x) for x in _list(raw.get("names"), "scenarios.names")]
    unknown = [s for s in names if s not in canonical_profiles(seed)]
    if unknown:
        raise StudyFileError(f"unknown scenarios {unknown}: A, B or manual1..manual4")
    csvs = [str((base / str(f)).resolve()) for f in _list(raw.get("csv"), "scenarios.csv")]
    missing = [c for c in csvs if not Path(c).is_file()]
    if missing:
        raise StudyFileError(f"scenario CSV files not found: {missing}")
    if not names + csvs:
        raise StudyFileError("[scenarios] names no scenario")
    return names + csvs


def resolve(raw: Mapping[str, Any], base: Path) -> dict[str, Any]:
    """The resolved config of a parsed study file (``base``: its folder, for relative paths)."""
    unknown = set(raw) - TOP_KEYS
    if unknown:
        raise StudyFileError(f"unknown keys {sorted(unknown)}: one of {sorted(TOP_KEYS)}")
    seed, trials = int(raw.get("seed", 0)), int(raw.get("trials", 1))
    duration = raw.get("duration_s")
    if seed < 0 or trials < 1:
        raise StudyFileError("need seed >= 0 and trials >= 1")
    if duration is not None and not (math.isfinite(float(duration)) and float(duration) > 0):
        raise StudyFileError("duration_s must be > 0")
    methods = expand_methods(raw.get("methods"))
    check_methods(methods)
    return {
        "name": str(raw.get("name", "study")),
        "seed": seed,
        "trials": trials,
        "duration_s": None if duration is None else float(duration),
        "workers": max(1, int(raw.get("workers", 2))),
        "scheduler": str(raw.get("scheduler", "")),
        "drivers": _drivers(raw.get("drivers"), base),
        "scenarios": _scenarios(raw.get("scenarios"), base, seed),
        "methods": [m.as_dict() for m in methods],
    }


def load_study_file(path: Path) -> dict[str, Any]:
    """The resolved config of a study file (.toml) or of a run's manifest (.json)."""
    try:
        text = path.read_text(encoding="utf-8")
        raw: Any = json.loads(text) if path.suffix == ".json" else tomllib.loads(text)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise StudyFileError(f"cannot read the study file {path}: {exc}") from exc
    if isinstance(raw, Mapping) and "config" in raw and "pacc_version" in raw:  # a manifest
        raw = dict(raw["config"])
        raw["methods"] = [_plain_method(m) for m in raw.get("methods", [])]
    if not isinstance(raw, Mapping):
        raise StudyFileError(f"{path}: not a study file")
    return resolve(raw, path.resolve().parent)


def _plain_method(m: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in m.items() if k in METHOD_KEYS}


def spec_of(config: Mapping[str, Any]) -> StudySpec:
    """The study spec of a resolved config: its drivers (built-ins, files, then each
    population as ``population:N:SEED``), scenarios and methods, learned in-process."""
    d = config["drivers"]
    pops = [f"population:{p['n']}:{p['seed']}" for p in d["population"]]
    return StudySpec(
        drivers=(*d["builtin"], *d["files"], *pops),
        scenarios=tuple(config["scenarios"]),
        methods=tuple(expand_methods([_plain_method(m) for m in config["methods"]])),
        trials=int(config["trials"]),
        seed=int(config["seed"]),
        duration_s=config["duration_s"],
        report="summary",
        learn_in="direct",
        name=str(config["name"]),
        logs=False,
        workers=int(config["workers"]),
        scheduler=config["scheduler"] or None,
    )


__all__ = ["StudyFileError", "expand_methods", "load_study_file", "resolve", "spec_of"]
