"""Fault SPEC parsing."""

from __future__ import annotations

import pytest

from sim_bus.errors import FaultSpecError
from sim_bus.faults import ROLES, FaultPlan, parse_faults


def test_parse_full_spec() -> None:
    spec = parse_faults(
        "radar:dropout=20-25,crc=0.1;ego:delay=0.02,drop=0.05;"
        "pedals:counter=0.01,freeze=3-4;all:silence=100-100.5"
    )
    r = spec.plans.get("radar")
    assert r is not None and r.crc == 0.1 and (20.0, 25.0) in r.silent
    assert r.silent_at(22.0) and not r.silent_at(25.0) and r.silent_at(100.2)
    ego = spec.plans.get("ego")
    assert ego is not None and ego.delay_s == 0.02 and ego.drop == 0.05 and ego.random
    ped = spec.plans.get("pedals")
    assert ped is not None and ped.counter == 0.01 and ped.frozen_at(3.5) == (3.0, 4.0)
    hmi = spec.plans.get("hmi")
    assert hmi is not None and hmi.silent_at(100.1) and not hmi.random


def test_clauses_of_one_role_merge() -> None:
    spec = parse_faults(
        "radar:drop=0.1;radar:crc=0.2,dropout=1-2;radar:dropout=3-4;radar:drop=0.3;all:freeze=5-6"
    )
    assert spec.plans.get("radar") == FaultPlan(
        drop=0.3, crc=0.2, silent=((1.0, 2.0), (3.0, 4.0)), freeze=((5.0, 6.0),)
    )  # the later drop wins
    assert all(spec.plans.get(r) == FaultPlan(freeze=((5.0, 6.0),)) for r in ROLES if r != "radar")


def test_empty_spec_means_no_faults() -> None:
    assert parse_faults("").plans == {} and parse_faults(None).plans == {}
    assert all(parse_faults(" ; ").plans.get(r) is None for r in ROLES)


@pytest.mark.parametrize(
    "text,match",
    [
        ("radar", "ROLE:KIND"),
        ("wheel:drop=0.1", "unknown role"),
        ("radar:drop", "KIND=VALUE"),
        ("radar:drop=2", "0..1"),
        ("radar:drop=x", "probability"),
        ("radar:dropout=5", "START-END"),
        ("radar:dropout=5-3", "START < END"),
        ("radar:dropout=1e308-1e309", "finite 0 <= START < END"),
        ("radar:freeze=inf-inf", "finite 0 <= START < END"),
        ("radar:delay=-1", "0..10"),
        ("radar:melt=1", "unknown fault kind"),
    ],
)
def test_bad_specs(text: str, match: str) -> None:
    with pytest.raises(FaultSpecError, match=match):
        parse_faults(text)
