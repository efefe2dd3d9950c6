"""``pacc plugins`` and the test plug-in package (tests/plugin_pkg, installed by `make`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from dbc.errors import UsageError
from dbc.vocab.plugins import PluginError
from pacc.commands.plugins import main
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from pacc.study.manifest import check_plugins, plugin_origins
from sim_bus.drivers import BUILTIN_DRIVERS
from tests.pacc.test_bad_input import run_case


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


def test_the_manifest_names_each_plugins_distribution_and_a_rerun_checks_it() -> None:
    methods = [
        {"table": "test-timegap", "adaptation": "none", "controller": "test-timegap"},
        {"table": "predefined", "adaptation": "bayes", "controller": "builtin"},
        {"table": "irl", "adaptation": "none", "controller": "pacc_testplugins:TimeGapController"},
    ]
    origins = plugin_origins(methods)
    plug = {"distribution": "pacc-testplugins", "version": "0.1.0"}
    assert origins["pacc.learners:test-timegap"].items() >= plug.items()
    assert origins["pacc.controllers:pacc_testplugins:TimeGapController"].items() >= plug.items()
    assert origins["pacc.adaptations:bayes"]["distribution"] == "pacc"
    assert "pacc.controllers:builtin" not in origins and "pacc.learners:predefined" not in origins
    check_plugins(origins)  # the same here: accepted
    elsewhere = {k: {**v, "version": "9.9"} for k, v in origins.items()}
    with pytest.raises(PluginError, match=r"pacc-testplugins 9\.9, installed here: .* 0\.1\.0"):
        check_plugins({"pacc.learners:test-timegap": elsewhere["pacc.learners:test-timegap"]})


def test_an_adaptation_without_online_adaptation_is_refused(tmp_path: Path) -> None:
    for flag in (["--adaptation", "bayes"], ["--adaptation-mode", "paper"]):
        code, _, err = run_case(["drive", "--duration", "1", *flag], tmp_path)
        assert code == 2 and "is for the +oa controllers" in err, err


def test_pacc_drive_passes_a_plug_ins_parameters(capsys: pytest.CaptureFixture[str]) -> None:
    """``--gap-controller-args`` reaches the plug-in (another gain drives otherwise); bad JSON,
    a non-object and parameters without their plug-in are refused (exit 2)."""
    from pacc.commands.drive import main as drive_main  # noqa: PLC0415

    base = ["--controller", "predefined", "--driver", "d2", "--duration", "20", "--gap-controller"]
    spec = "pacc_testplugins:TimeGapController"
    outs = []
    for gain in ("0.05", "0.4"):
        assert drive_main([*base, spec, "--gap-controller-args", '{"k_gap": ' + gain + "}"]) == 0
        outs.append(capsys.readouterr().out)
    assert outs[0] != outs[1]  # the parameter changed the drive
    for bad in ("{", "[1, 2]"):
        with pytest.raises(SystemExit) as stop:
            drive_main([*base, spec, "--gap-controller-args", bad])
        assert stop.value.code == 2
    with pytest.raises(UsageError, match="--adaptation-args gives the parameters of a"):
        drive_main(["--duration", "5", "--adaptation-args", '{"fraction": 0.3}'])
