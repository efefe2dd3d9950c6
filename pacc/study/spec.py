"""What a study runs: :class:`StudySpec` (the study file's schema) and its validation.

One spec for every study: Table I over d1..d5 (``pacc study``), over a drawn population
(``--population N``), a study file's methods (``--config``), ``pacc bench``'s closed loop and
the incremental-learning experiment (``--incremental N``) differ only in its fields.

Drivers are named by source: a built-in name (``d1``), a driver file (``.toml``/``.json``) or
``NAME:N:SEED``, N drivers drawn from the population ``NAME`` with ``SEED``
(:data:`POPULATIONS`; ``population:3:7``). A method (:class:`Method`) is a table source
(``predefined`` or a learner) × an adaptation × a gap controller; Table I's four controllers
are the methods of :data:`TABLE1_METHODS`.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from ecu.adaptation import AdaptationParams
from pacc.study.drive import BUSES, CONTROLLERS
from sim_bus.drivers import DriverParams, load_driver
from sim_bus.errors import SimError
from sim_bus.lead.events import ROAD_SCENARIOS
from sim_bus.lead.scenarios import canonical_profiles
from sim_bus.population import draw_population

#: driver populations by name: (N, seed, mismatch, trip shift sd s) -> the drawn drivers
POPULATIONS: dict[str, Callable[[int, int, float, float], tuple[DriverParams, ...]]] = {
    "population": lambda n, seed, mismatch, shift: draw_population(
        n, seed, mismatch=mismatch, trip_shift_sd_s=shift
    ),
}
#: the ECU's own adaptation, called directly with the spec's ``adaptation`` parameters
ECU_ADAPTATION = "ecu"
#: what a study learns its tables in: the vehicle-cloud loop, or in-process (cached)
LEARN_IN = ("cloud", "direct")
#: the reports a study writes (pacc.study.reports)
REPORTS = ("table1", "population", "summary", "incremental")


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
        return {
            "name": self.name,
            "table": self.table,
            "adaptation": self.adaptation or "none",
            "controller": self.controller or "builtin",
            "learner_args": dict(self.learner_args),
            "adaptation_args": dict(self.adaptation_args),
            "controller_args": dict(self.controller_args),
        }


def table1_method(controller: str) -> Method:
    """A Table I controller (``irl+oa``) as a method of the same name."""
    table = "irl" if controller.startswith("irl") else "predefined"
    return Method(controller, table, ECU_ADAPTATION if controller.endswith("+oa") else "", "")


TABLE1_METHODS = tuple(table1_method(c) for c in CONTROLLERS)


@dataclass(frozen=True)
class StudySpec:
    """What to run. ``seed`` fixes the scenarios and the learned tables; trial k drives with
    noise seed ``seed + k``. ``duration_s`` shortens every drive (None: the whole profile).
    ``adaptation``: the parameters of the ECU's own adaptation (None: its defaults).
    ``learn_in``: ``cloud``, the tables learned in the vehicle-cloud loop (``cloud`` None: a
    fresh embedded cloud under ``OUT/cloud``; else a URL or folder where the drivers are
    registered to the vehicle of ``token_file``, verified with ``trust``); ``direct``:
    in-process, cached. ``incremental`` N > 0: N trips per driver through the cloud.
    ``dbc``/``binding``/``bus``: the vehicle network and python-can bus of every drive.
    ``workers``/``scheduler``: where the drives run (never what they give)."""

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
    mismatch: float = 0.0  # manual-vs-ACC mismatch scale of drawn drivers (0: none)
    trip_shift_s: float = 0.0  # between-trip shift of drawn drivers' headway, sd in s
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
        for key in ("workers", "scheduler", "name"):
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
                drawn = POPULATIONS[name](int(n), int(seed), spec.mismatch, spec.trip_shift_s)
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


__all__ = [
    "ECU_ADAPTATION",
    "POPULATIONS",
    "TABLE1_METHODS",
    "Method",
    "StudySpec",
    "load_drivers",
    "table1_method",
    "validate",
]
