"""``pacc plugins`` and the test plug-in package (tests/plugin_pkg, installed by `make`)."""

from __future__ import annotations

import pytest

from pacc.commands.plugins import main
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS


def test_plugins_lists_builtins_and_entry_points(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--check"]) == 0
    out = capsys.readouterr().out
    for name in ("pid", "timegap", "paper", "bayes", "irl", "empirical", "gp"):
        assert f"  {name} " in out
    # the test package's three entry points, found by their groups
    assert out.count("pacc-testplugins") == 3
    assert "test-halfstep" in out and "pacc_testplugins:TimeGapLearner  ok" in out


@pytest.mark.slow
def test_a_drive_with_entry_point_methods() -> None:
    """The entry-point controller and adaptation run a 60-s drive: no collision, no fault,
    the adaptation applied, the summary says the plug-ins behaved."""
    driver = BUILTIN_DRIVERS["d3"]
    cfg = DriveConfig(
        scenario="B",
        driver_id="d3",
        controller="predefined+oa",
        duration_s=60.0,
        gap_controller="test-timegap",
        adaptation_method="test-halfstep",
    )
    result = run_drive(cfg, driver, predefined_table(driver))
    assert not result.collision
    assert result.summary.plugin_faults == {}
    assert result.adaptations >= 1
