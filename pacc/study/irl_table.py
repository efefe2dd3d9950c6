"""A driver's IRL table for ``pacc drive --controller irl|irl+oa`` and ``pacc study``.

Learned by the cloud trainer from the driver's manual trips on manual1..manual4 and cached
(JSON DGPT) under a key of the driver, the seed and a digest of the code it depends on
(``cloud_sync``, ``sim_bus``, ``ecu``); a cache that cannot be written only costs time.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import json
import os
from pathlib import Path

from dbc.vocab.dgpt import Dgpt, DgptError
from dbc.vocab.dgpt_file import load_dgpt, save_dgpt
from dbc.vocab.triplog import Trip
from sim_bus.drivers import DriverParams
from sim_bus.lead.scenarios import canonical_profiles
from sim_bus.manual import manual_trip

MANUAL_PROFILES = ("manual1", "manual2", "manual3", "manual4")


def code_digest(packages: tuple[str, ...] = ("cloud_sync", "sim_bus", "ecu")) -> str:
    """SHA-256 over the Python sources of ``packages`` (sorted by path): the code version."""
    digest = hashlib.sha256()
    for name in packages:
        spec = importlib.util.find_spec(name)
        if spec is None or not spec.submodule_search_locations:
            continue
        for folder in spec.submodule_search_locations:
            root = Path(folder)
            for path in sorted(root.rglob("*.py")):
                digest.update(str(path.relative_to(root.parent)).encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()


def cache_key(driver: DriverParams, seed: int, trainer_source: str) -> str:
    """A hex key of (driver parameters, seed, code digest): same inputs, same table."""
    payload = json.dumps(
        {
            "driver": dataclasses.asdict(driver),
            "seed": seed,
            "profiles": MANUAL_PROFILES,
            "trainer": trainer_source,
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


def manual_trips(driver: DriverParams, seed: int) -> list[Trip]:
    """The driver's manual (ACC OFF) trips on manual1..manual4: the IRL demonstrations."""
    profiles = canonical_profiles(seed)
    return [manual_trip(driver, profiles[name], seed + i) for i, name in enumerate(MANUAL_PROFILES)]


def irl_table(driver: DriverParams, seed: int, cache_dir: Path | None = None) -> Dgpt:
    """Learn (or read from the cache) the driver's IRL table from its manual trips."""
    key = cache_key(driver, seed, code_digest())
    folder = cache_dir or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pacc"
    path = folder / f"irl-{driver.driver_id}-{key}.json"
    if path.is_file():
        try:
            return load_dgpt(path)
        except DgptError:
            path.unlink(missing_ok=True)  # a damaged cache entry is rebuilt
    # the trainer (scipy) costs about a second of start-up; only a table to learn needs it
    from cloud_sync.engine import single_blas_thread  # noqa: PLC0415
    from cloud_sync.irl.trainer import learn_dgpt  # noqa: PLC0415

    with single_blas_thread():  # the same table whatever the core count (as the cloud's)
        result = learn_dgpt(manual_trips(driver, seed), driver_id=driver.driver_id, seed=seed)
    table: Dgpt = result.table
    try:  # save_dgpt writes atomically; the cache only saves time, so a failure is no error
        folder.mkdir(parents=True, exist_ok=True)
        save_dgpt(table, path)
    except (OSError, DgptError):
        pass  # an unwritable or contended cache folder: learned again next time
    return table
