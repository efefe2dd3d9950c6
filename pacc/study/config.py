"""What a study runs (:class:`StudyConfig`) and its validation before anything runs."""

from __future__ import annotations

from dataclasses import dataclass

from ecu.adaptation import AdaptationParams
from pacc.study.drive import BUSES, CONTROLLERS
from sim_bus.drivers import DriverParams, load_driver
from sim_bus.errors import SimError
from sim_bus.lead.events import ROAD_SCENARIOS
from sim_bus.lead.scenarios import canonical_profiles


@dataclass(frozen=True)
class StudyConfig:
    """What to run. ``drivers``: built-in names (d1..d5) or driver files (.toml/.json).
    ``seed`` fixes the scenarios and the IRL tables; trial k drives with noise seed
    ``seed + k``. ``duration_s`` shortens every drive (None: the full 300 s).
    ``adaptation``: the online adaptation of the +oa controllers (None: the ECU's default).
    ``cloud``: where the IRL tables are learned: None, a fresh embedded cloud under
    ``OUT/cloud``; a URL or folder of a cloud where the drivers are registered to the vehicle
    of ``token_file``, whose tables are verified with ``trust``. ``direct``: no cloud, learn
    in-process (cached). ``incremental``: N > 0 runs the incremental-learning experiment
    (N trips per driver through the cloud) instead of Table I. ``dbc``/``binding``: the
    vehicle network every drive runs on (docs/vehicles.md; None: the packaged pacc network).
    ``scheduler``: where the drives run: None, ``workers`` local processes; ``"local"``, a
    Dask ``LocalCluster`` of ``workers`` processes; a Dask scheduler's address
    (``tcp://HOST:8786``), that cluster (docs/scale.md).
    ``population``: N > 0 runs Table I over N drivers drawn with ``seed``
    (:mod:`pacc.study.population`) instead of ``drivers``."""

    drivers: tuple[str, ...] = ("d1", "d2", "d3", "d4", "d5")
    scenarios: tuple[str, ...] = ("A", "B")
    controllers: tuple[str, ...] = CONTROLLERS
    trials: int = 3
    seed: int = 0
    duration_s: float | None = None
    workers: int = 2
    logs: bool = True
    can_logs: bool = False  # also record every drive's bus traffic (MCAP) under can/
    adaptation: AdaptationParams | None = None
    cloud: str | None = None
    token_file: str | None = None
    trust: str | None = None
    direct: bool = False
    incremental: int = 0
    dbc: str | None = None  # the vehicle network of every drive (None: pacc's)
    binding: str | None = None
    scheduler: str | None = None
    population: int = 0
    bus: str = "lockstep"  # the python-can interface of every drive (pacc.study.drive.BUSES)
    mismatch: float = 0.0  # manual-vs-ACC mismatch scale of drawn drivers (0: none)
    trip_shift_s: float = 0.0  # between-trip shift of drawn drivers' headway, sd in s


def _validate_cloud(cfg: StudyConfig) -> None:
    if cfg.incremental < 0:
        raise SimError("--incremental must be >= 0")
    if cfg.direct and (cfg.cloud is not None or cfg.incremental):
        raise SimError("--direct learns without a cloud: not with --cloud or --incremental")
    if cfg.scheduler is not None and cfg.incremental:
        raise SimError("--incremental drives one trip after another: not with --scheduler")
    if cfg.scheduler is not None and not cfg.scheduler.strip():
        raise SimError("--scheduler needs 'local' or a Dask scheduler address (tcp://HOST:8786)")
    if cfg.cloud is not None and not (cfg.token_file and cfg.trust):
        raise SimError("--cloud needs --token-file F and --trust KEY.pub")


def validate_drives(cfg: StudyConfig) -> None:
    """SimError naming the defect of the drives ``cfg`` asks for (an unknown controller or
    scenario, no scenario, no trial, a duration <= 0, a negative seed); shared by Table I
    over named drivers and over a drawn population."""
    bad = [c for c in cfg.controllers if c not in CONTROLLERS]
    if bad or not cfg.controllers:
        raise SimError(f"unknown controllers {bad}: choose from {', '.join(CONTROLLERS)}")
    if not cfg.scenarios:
        raise SimError("give at least one scenario")
    if cfg.bus not in BUSES:
        raise SimError(f"--bus must be one of {', '.join(BUSES)}, got {cfg.bus!r}")
    if cfg.trials < 1:
        raise SimError("--trials must be >= 1")
    if cfg.duration_s is not None and not cfg.duration_s > 0:
        raise SimError("--duration must be > 0")
    if cfg.seed < 0:
        raise SimError(f"--seed must be >= 0, got {cfg.seed}")
    known = set(canonical_profiles(cfg.seed)) | set(ROAD_SCENARIOS)
    unknown = [s for s in cfg.scenarios if s not in known]
    if unknown:
        raise SimError(
            f"unknown scenarios {unknown}: A, B, manual1..manual4 or a road scenario "
            f"({', '.join(ROAD_SCENARIOS)})"
        )


def validate(cfg: StudyConfig) -> dict[str, DriverParams]:
    """The study's drivers by driver id, in ``cfg.drivers`` order, once ``cfg`` is known to
    be runnable; SimError naming the defect otherwise (an unknown controller or scenario, a
    bad driver file, two drivers with one id, no trial, a duration <= 0)."""
    if not cfg.drivers:
        raise SimError("give at least one driver")
    validate_drives(cfg)
    _validate_cloud(cfg)
    drivers: dict[str, DriverParams] = {}
    for spec in cfg.drivers:
        driver = load_driver(spec)
        if driver.driver_id in drivers:
            raise SimError(
                f"two drivers have the id {driver.driver_id!r} ({spec!r} and an earlier one): "
                "the study names its tables, rows and logs by driver id"
            )
        drivers[driver.driver_id] = driver
    return drivers
