"""The logical roles: the input roles' resting values are defined once and cover every field;
a network whose signals cannot hold a field's documented range is refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from dbc import BINDING_PATH, DBC_PATH
from dbc.binding import load_binding
from dbc.codec import load_codec
from dbc.errors import BindingError
from dbc.schema import REQUIRED_ROLES, ROLES, resting_values


def test_resting_values_cover_every_field_of_every_input_role() -> None:
    rest = resting_values()
    assert set(rest) == {r for r in REQUIRED_ROLES if r != "command"}
    for role, fields in rest.items():
        assert set(fields) == set(ROLES[role]), role


def test_resting_values_are_a_fresh_copy_with_overrides() -> None:
    a = resting_values(ego={"speed_mps": 20.0})
    a["radar"]["gap_m"] = 99.0
    b = resting_values()
    assert a["ego"]["speed_mps"] == 20.0 and b["ego"]["speed_mps"] == 0.0
    assert b["radar"]["gap_m"] == 0.0 and b["hmi"]["gap_setting"] == 2


def _network(tmp_path: Path, dbc_text: str, binding_text: str) -> tuple[Path, Path]:
    dbc, binding = tmp_path / "car.dbc", tmp_path / "car.binding.toml"
    dbc.write_text(dbc_text)
    binding.write_text(binding_text.replace('dbc = "pacc.dbc"', 'dbc = "car.dbc"'))
    return dbc, binding


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "VehicleSpeed : 16|16@1+ (0.01,0) [0|90]",
            "VehicleSpeed : 16|16@1+ (0.01,0) [0|1]",
            r"speed_mps range \[0, 1\] cannot hold \[0, 40\]",
        ),
        (
            "LeadDistance : 16|16@1+ (0.05,0) [0|250]",
            "LeadDistance : 16|16@1+ (0.05,0) [0|50]",
            r"gap_m range \[0, 50\] cannot hold \[0, 200\]",
        ),
        (
            "DgptVersion : 32|16@1+ (1,0) [0|65535]",
            "DgptVersion : 32|8@1+ (1,0) [0|255]",
            r"dgpt_version range \[0, 255\] cannot hold \[0, 65535\]",
        ),
    ],
)
def test_a_signal_that_cannot_hold_the_fields_range_is_refused_at_load(
    tmp_path: Path, old: str, new: str, message: str
) -> None:
    """A DBC whose VehicleSpeed is [0|1] m/s would clamp the car's speed on the bus while it
    drives at 20 m/s: the network is refused when it is loaded, naming the field."""
    text = DBC_PATH.read_text()
    assert old in text
    dbc, binding = _network(tmp_path, text.replace(old, new), BINDING_PATH.read_text())
    with pytest.raises(BindingError, match=message):
        load_codec(dbc, binding)


def test_a_binding_nested_too_deep_is_a_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "deep.binding.toml"
    path.write_text("x = " + "[" * 200_000 + "]" * 200_000 + "\n")
    with pytest.raises(BindingError, match="nested too deep"):
        load_binding(path)
