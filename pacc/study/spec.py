"""What a study runs: :class:`StudySpec` (every mode of ``pacc study`` and ``pacc bench``) and
the study file (TOML, or a run's ``manifest.json``) that resolves to one.

Drivers are named by source: a built-in (``d1``), a driver file (``.toml``/``.json``) or
``NAME:N:SEED``, N drivers drawn from population NAME (``people:3:7``, ``headway:5:0``). A
:class:`Method` is a table source × an adaptation × a gap controller. :func:`resolve` fills a
study file's defaults and expands its ``[[methods]]`` lists into the resolved config (what runs,
what the manifest stores); :func:`spec_of` is its spec. docs/plugins.md shows a study file.
"""

from __future__ import annotations

import itertools
import json
import math
import tomllib
import zlib
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from cloud_sync.learners import make_learner
from dbc.vocab import FormatError
from ecu.adaptation import AdaptationParams
from ecu.methods import make_adaptation, make_controller
from pacc.study.drive import BUSES, CONTROLLERS
from pacc.study.manifest import check_plugins
from sim_bus.drivers import BUILTIN_DRIVERS, DriverParams, load_driver
from sim_bus.errors import SimError
from sim_bus.lead.events import ROAD_SCENARIOS
from sim_bus.lead.scenarios import canonical_profiles
from sim_bus.population import DEFAULT_POPULATION, POPULATIONS, draw_population

#: the ECU's own adaptation, called directly with the spec's ``adaptation`` parameters
ECU_ADAPTATION = "ecu"
#: what a study learns its tables in: the vehicle-cloud loop, or in-process (cached)
LEARN_IN = ("cloud", "direct")
#: ``shared``: every driver follows the study seed's lead; ``per-driver``: each driver its own
#: draw of the same scenario (:func:`road_seed`), so that a population's averages do not rest on
#: one road
ROADS = ("shared", "per-driver")
#: the study's modes, each named by the report it writes (pacc.study.report; ``hil``: Table I of
#: pacc hil's session folders, pacc.hil.report)
REPORTS = ("table1", "population", "summary", "incremental", "hil")


@dataclass(frozen=True)
class Method:
    """One combination: table source × adaptation × controller, with arguments."""

    name: str
    table: str  # "predefined" or a learner spec
    adaptation: str  # "" none, "ecu" the ECU's own, else an adaptation spec
    controller: str  # "" the built-in PID directly, else a controller spec
    learner_args: tuple[tuple[str, Any], ...] = ()
    adaptation_args: tuple[tuple[str, Any], ...] = ()
    controller_args: tuple[tuple[str, Any], ...] = ()

    @property
    def table_key(self) -> str:
        """Identifies the table a driver gets (learner and its arguments)."""
        return json.dumps([self.table, self.learner_args], sort_keys=True, default=str)

    @property
    def kind(self) -> str:
        """The drive's controller (:data:`pacc.study.drive.CONTROLLERS`)."""
        base = "predefined" if self.table == "predefined" else "irl"
        return f"{base}+oa" if self.adaptation else base

    def as_dict(self) -> dict[str, Any]:
        """JSON form (arguments as objects), as a study file writes it."""
        doc = {k: dict(v) if k.endswith("_args") else v for k, v in vars(self).items()}
        return doc | {
            "adaptation": self.adaptation or "none",
            "controller": self.controller or "builtin",
        }


def table1_method(controller: str) -> Method:
    """A Table I controller (``irl+oa``) as a method of the same name."""
    table = "irl" if controller.startswith("irl") else "predefined"
    return Method(controller, table, ECU_ADAPTATION if controller.endswith("+oa") else "", "")


TABLE1_METHODS = tuple(table1_method(c) for c in CONTROLLERS)


def road_seed(seed: int, driver_id: str, roads: str = "per-driver") -> int:
    """The seed of the lead profiles ``driver_id`` follows in a study of ``seed``: the study's
    own (``shared``) or one drawn from both (``per-driver``; the same whatever the drivers)."""
    return seed if roads == "shared" else zlib.crc32(f"{seed}/{driver_id}".encode())


@dataclass(frozen=True)
class StudySpec:
    """What to run. Trial k drives with noise seed ``seed + k``; ``duration_s`` shortens every
    drive, s (None: the whole profile). ``learn_in``: ``cloud`` (``cloud`` None: a fresh
    embedded one under OUT/cloud) or ``direct`` (in-process, cached). ``report``: the mode
    (:data:`REPORTS`); ``sessions``/``beside``: the ``hil`` mode's session folder and a
    synthetic drives.csv. ``workers``/``scheduler``: where drives run (never what they give)."""

    drivers: tuple[str, ...] = ("d1", "d2", "d3", "d4", "d5")
    scenarios: tuple[str, ...] = ("A", "B")
    methods: tuple[Method, ...] = TABLE1_METHODS
    trials: int = 3
    seed: int = 0
    duration_s: float | None = None
    report: str = "table1"
    learn_in: str = "cloud"
    name: str = "study"
    logs: bool = True
    can_logs: bool = False  # also record every drive's bus traffic (MCAP) under can/
    adaptation: AdaptationParams | None = None
    cloud: str | None = None
    token_file: str | None = None
    trust: str | None = None
    incremental: int = 0
    dbc: str | None = None  # the vehicle network of every drive (None: pacc's)
    binding: str | None = None
    bus: str = "lockstep"  # the python-can interface of every drive (pacc.study.drive.BUSES)
    roads: str = "shared"  # the lead's road: one per study seed, or one per driver (ROADS)
    sessions: str | None = None
    beside: str | None = None
    workers: int = 2
    scheduler: str | None = None

    @property
    def controllers(self) -> tuple[str, ...]:
        """The methods' names (Table I's controllers)."""
        return tuple(m.name for m in self.methods)

    def fingerprint(self) -> dict[str, Any]:
        """What makes two runs the same run (JSON): not where they run, nor how many drivers
        a population draws (its first N are the same whatever N, so a run can be extended)."""
        doc = json.loads(json.dumps(asdict(self), default=str))
        for key in ("workers", "scheduler", "name", "sessions", "beside"):
            doc.pop(key)
        sources = [(d, _source(d)) for d in self.drivers]
        doc["drivers"] = [d if src is None else f"{src[0]}:{src[2]}" for d, src in sources]
        return dict(doc)


def _source(entry: str) -> tuple[str, str, str] | None:
    """(population, N, seed) of a ``NAME:N:SEED`` driver entry; None for a name or file."""
    parts = entry.split(":")
    return (parts[0], parts[1], parts[2]) if len(parts) == 3 and parts[0] in POPULATIONS else None


def load_drivers(spec: StudySpec) -> dict[str, DriverParams]:
    """The spec's drivers by id, in order; SimError for a bad entry or two with one id."""
    drivers: dict[str, DriverParams] = {}
    for entry in spec.drivers:
        source = _source(entry)
        if source is not None:
            name, n, seed = source
            try:
                drawn = draw_population(int(n), int(seed), population=name)
            except ValueError as exc:
                raise SimError(f"{entry!r}: {name}:N:SEED with whole numbers ({exc})") from exc
        else:
            drawn = (load_driver(entry),)
        for driver in drawn:
            if driver.driver_id in drivers:
                raise SimError(
                    f"two drivers have the id {driver.driver_id!r} ({entry!r} and an earlier "
                    "one): the study names its tables, rows and logs by driver id"
                )
            drivers[driver.driver_id] = driver
    return drivers


def validate(spec: StudySpec) -> dict[str, DriverParams]:
    """The drivers of ``spec`` by id once it is known to be runnable; SimError naming the
    first defect otherwise (no driver, no method, an unknown scenario, no trial, ...)."""
    known = set(canonical_profiles(spec.seed)) | set(ROAD_SCENARIOS)
    unknown = [s for s in spec.scenarios if s not in known and not s.lower().endswith(".csv")]
    direct, sched = spec.learn_in != "cloud", spec.scheduler
    checks = (
        (not spec.drivers, "give at least one driver"),
        (not spec.methods, f"give at least one method or controller ({', '.join(CONTROLLERS)})"),
        (not spec.scenarios, "give at least one scenario"),
        (spec.bus not in BUSES, f"--bus must be one of {', '.join(BUSES)}, got {spec.bus!r}"),
        (spec.roads not in ROADS, f"--roads must be one of {', '.join(ROADS)}, got {spec.roads!r}"),
        (spec.trials < 1, "--trials must be >= 1"),
        (spec.duration_s is not None and not spec.duration_s > 0, "--duration must be > 0"),
        (spec.seed < 0, f"--seed must be >= 0, got {spec.seed}"),
        (spec.report not in REPORTS, f"report must be one of {', '.join(REPORTS)}"),
        (spec.learn_in not in LEARN_IN, f"learn_in must be one of {', '.join(LEARN_IN)}"),
        (bool(unknown), f"unknown scenarios {unknown}: A, B, manual1..manual4, a road "
         f"scenario ({', '.join(ROAD_SCENARIOS)}) or a .csv file"),
        (spec.incremental < 0, "--incremental must be >= 0"),
        (direct and (spec.cloud is not None or spec.incremental > 0),
         "--direct learns without a cloud: not with --cloud or --incremental"),
        (sched is not None and spec.incremental > 0,
         "--incremental drives one trip after another: not with --scheduler"),
        (sched is not None and not sched.strip(),
         "--scheduler needs 'local' or a Dask scheduler address (tcp://HOST:8786)"),
        (spec.cloud is not None and not (spec.token_file and spec.trust),
         "--cloud needs --token-file F and --trust KEY.pub"),
    )  # fmt: skip
    for bad, message in checks:
        if bad:
            raise SimError(message)
    return load_drivers(spec)


#: the keys of a study file's top level and of a method
TOP_KEYS = {"seed", "trials", "duration_s", "workers", "scheduler", "drivers", "scenarios",
            "methods", "name"}  # fmt: skip
METHOD_KEYS = {"name", "table", "adaptation", "controller", "learner_args", "adaptation_args",
               "controller_args"}  # fmt: skip


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
        check_plugins(raw.get("plugins") or {})
        raw = dict(raw["config"])
        raw["methods"] = [_plain_method(m) for m in raw.get("methods", [])]
    if not isinstance(raw, Mapping):
        raise StudyFileError(f"{path}: not a study file")
    return resolve(raw, path.resolve().parent)


def _plain_method(m: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in m.items() if k in METHOD_KEYS}


def spec_of(config: Mapping[str, Any]) -> StudySpec:
    """The study spec of a resolved config: its drivers (built-ins, files, then each
    population as ``people:N:SEED``), scenarios and methods, learned in-process."""
    d = config["drivers"]
    pops = [f"{DEFAULT_POPULATION}:{p['n']}:{p['seed']}" for p in d["population"]]
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
