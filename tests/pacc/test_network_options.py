"""``--dbc`` / ``--binding`` behave alike on every command that opens a vehicle network."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from dbc import BINDING_PATH, DBC_PATH
from pacc.commands.drive import main as drive_main
from pacc.commands.ecu import main as ecu_main
from pacc.commands.sim import main as sim_main
from pacc.commands.study import main as study_main

COMMANDS: dict[str, Callable[[list[str] | None], int]] = {
    "ecu": ecu_main,
    "sim": sim_main,
    "drive": drive_main,
    "study": study_main,
}


@pytest.mark.parametrize("name", list(COMMANDS))
def test_dbc_without_binding_is_a_usage_error(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    car = tmp_path / "car.dbc"
    car.write_text(DBC_PATH.read_text())
    argv = ["--duration", "1", "--dbc", str(car)]
    assert COMMANDS[name](argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"pacc {name}: error: --dbc {car} needs --binding FILE")
    assert "Traceback" not in err


@pytest.mark.parametrize("name", list(COMMANDS))
def test_binding_for_another_dbc_is_a_usage_error(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    car = tmp_path / "car.dbc"
    car.write_text(DBC_PATH.read_text())
    argv = ["--duration", "1", "--dbc", str(car), "--binding", str(BINDING_PATH)]
    assert COMMANDS[name](argv) == 2
    assert "binds pacc.dbc, not car.dbc" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["sim", "drive", "study"])
def test_binding_missing_a_required_field_is_refused_at_start(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "pacc.dbc").write_text(DBC_PATH.read_text())
    binding = tmp_path / "b.toml"
    binding.write_text(BINDING_PATH.read_text().replace('gap_m = "LeadDistance", ', ""))
    assert COMMANDS[name](["--duration", "1", "--binding", str(binding)]) == 2
    err = capsys.readouterr().err
    assert "role radar: required fields ['gap_m'] are not bound" in err
