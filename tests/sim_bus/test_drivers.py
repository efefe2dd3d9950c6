"""Driver parameters: the hidden preference, built-ins, loading from TOML/JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sim_bus.drivers import BUILTIN_DRIVERS, DriverParams, load_driver
from sim_bus.errors import DriverError


def test_preferred_gap_formula() -> None:
    d = DriverParams("x", standstill_m=4.0, headway_speeds_mps=(10.0, 30.0), headway_s=(1.0, 2.0))
    v = np.array([0.0, 10.0, 20.0, 30.0, 40.0])
    assert np.allclose(d.preferred_gap_m(v), [4.0, 14.0, 34.0, 64.0, 84.0])
    assert np.allclose(
        d.preferred_gap_m(v, condition_factor=1.5), 4.0 + 1.5 * (v * [1, 1, 1.5, 2, 2])
    )
    assert d.preferred_gap_m(-5.0) == pytest.approx(4.0)


def test_builtins_span_the_diversity() -> None:
    assert set(BUILTIN_DRIVERS) == {"d1", "d2", "d3", "d4", "d5"}
    g20 = {k: float(d.preferred_gap_m(20.0)) for k, d in BUILTIN_DRIVERS.items()}
    assert g20["d1"] == min(g20.values()) and g20["d3"] == max(g20.values())
    d4 = BUILTIN_DRIVERS["d4"]
    assert d4.headway_at(30.0) - d4.headway_at(5.0) > 1.0  # speed-dependent
    assert BUILTIN_DRIVERS["d5"].condition_drift_per_min > 0  # inconsistent


def test_load_builtin_by_name() -> None:
    assert load_driver("d3") is BUILTIN_DRIVERS["d3"]


def test_load_toml_with_base(tmp_path: Path) -> None:
    path = tmp_path / "rainy.toml"
    path.write_text(
        '[driver]\nbase = "d2"\ndriver_id = "rainy"\ncondition_factor = 1.2\n'
        "headway_s = [1.5, 1.6, 1.7, 1.8]\n"
    )
    d = load_driver(path)
    assert d.driver_id == "rainy" and d.condition_factor == 1.2
    assert d.headway_s == (1.5, 1.6, 1.7, 1.8)
    assert d.patience_s == BUILTIN_DRIVERS["d2"].patience_s


def test_load_json(tmp_path: Path) -> None:
    path = tmp_path / "j.json"
    path.write_text(
        json.dumps(
            {
                "driver_id": "j",
                "headway_speeds_mps": [10, 20],
                "headway_s": [1.2, 2.2],
                "standstill_m": 3.0,
            }
        )
    )
    d = load_driver(path)
    assert d.preferred_gap_m(20.0) == pytest.approx(3.0 + 44.0)


@pytest.mark.parametrize(
    "body,match",
    [
        ('driver_id = "x"\nheadway_s = [1.0, 2.0]\n', "differ in length"),
        ('driver_id = "x"\nfoo = 1\n', "unknown driver fields"),
        ('base = "d9"\n', "unknown base"),
        ('driver_id = "x"\nheadway_s = [0.1, 0.1, 0.1, 0.1]\n', "headway_s"),
        ('driver_id = "x"\npatience_s = -1\n', "patience_s"),
        ("headway_s = [1.0, 1.0, 1.0, 1.0]\n", "driver_id is required"),
        ('driver_id = "x"\npredefined_setting = "huge"\n', "predefined_setting"),
        ("driver_id = \n", "Invalid"),
        ('driver_id = "x"\nheadway_s = [1.0, "a", 1.0, 1.0]\n', "could not convert"),
        ('driver_id = "x"\nheadway_speeds_mps = [5.0, nan, 25.0, 35.0]\n', "finite and increase"),
        ('driver_id = "x"\nheadway_speeds_mps = [5.0, 15.0, 15.0, 35.0]\n', "finite and increase"),
        ('driver_id = "x"\nstandstill_m = "4"\n', "not supported"),
        ('driver_id = "../../etc/x"\n', "driver_id must be"),
        ("driver_id = 5\n", "driver_id must be"),
        ('driver_id = ""\n', "driver_id must be"),
    ],
)
def test_bad_driver_files(tmp_path: Path, body: str, match: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(body)
    with pytest.raises(DriverError, match=match):
        load_driver(path)


def test_unknown_name_and_suffix(tmp_path: Path) -> None:
    with pytest.raises(DriverError, match="unknown driver"):
        load_driver("d42")
    path = tmp_path / "x.yaml"
    path.write_text("driver_id: x\n")
    with pytest.raises(DriverError, match=".toml or .json"):
        load_driver(path)
