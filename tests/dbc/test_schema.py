"""The logical roles: the input roles' resting values are defined once and cover every field."""

from __future__ import annotations

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
