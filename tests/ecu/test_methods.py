"""Plug-in methods in the ECU: the built-ins through the interface, faulty plug-ins, bayes."""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from dbc.vocab.dgpt import Dgpt, SafetyBounds, predefined
from dbc.vocab.plugins import PluginError
from ecu.adaptation import Decision, Reason, TakeoverSummary
from ecu.config import EcuConfig
from ecu.controller import ControlInput, desired_accel
from ecu.methods import PidController, make_adaptation, make_controller
from ecu.methods.bayes import BayesAdaptation
from ecu.methods.guard import GuardedController
from ecu.node import EcuNode
from tests.ecu.test_node import DT, EPS, JERK, Loop

HERE = "tests.ecu.test_methods"


class RaisingController:
    """Raises every call."""

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        raise RuntimeError("boom")


class NanController:
    """Returns NaN every other call, a wild value otherwise."""

    def __init__(self) -> None:
        self.n = 0

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        self.n += 1
        return (math.nan, memory) if self.n % 2 else (1e9 * (-1) ** (self.n // 2), memory)


class SleepyController:
    """Sleeps past any budget."""

    def __init__(self, sleep_s: float = 0.02) -> None:
        self.sleep_s = sleep_s

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        time.sleep(self.sleep_s)
        return 2.0, memory


class HugeController:
    """Returns a number no float can hold (float(10**400) raises OverflowError)."""

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[Any, float]:
        return 10**400, memory


class ExitingController:
    """Ends the process, if the guard let it."""

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        raise SystemExit(0)


class SlowFloat:
    """A number whose conversion to float takes 20 ms (the plug-in's time, not the ECU's)."""

    def __float__(self) -> float:
        time.sleep(0.02)
        return 1.0


class SlowNumberController:
    """Returns a :class:`SlowFloat`."""

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[Any, float]:
        return SlowFloat(), memory


class ExitingNumberController:
    """Returns a number whose conversion to float ends the process."""

    class _Exit:
        def __float__(self) -> float:
            raise SystemExit(0)

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[Any, float]:
        return self._Exit(), memory


class WrongShapeController:
    """Returns a bare float."""

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> Any:
        return 0.5


class BadAdaptation:
    """``kind``: raise, nan (a table of NaN), wide (far outside the bounds), shape."""

    def __init__(self, kind: str = "raise") -> None:
        self.kind = kind

    def update(
        self, table: Dgpt, takeover: TakeoverSummary, **_: Any
    ) -> tuple[Dgpt | None, Decision]:
        done = Decision(applied=True, reason=Reason.APPLIED, bin_index=0)
        if self.kind == "raise":
            raise ValueError("bad adaptation")
        if self.kind == "exit":
            raise SystemExit(0)
        if self.kind == "nan":
            gaps = table.gap_m.copy()
            gaps[3] = math.nan
            return replace(table, gap_m=gaps, version=table.version + 1), done
        if self.kind == "wide":
            return table.with_gaps(table.gap_m * 0.0 + 1000.0, "adapted"), done
        return "not a table", done  # type: ignore[return-value]


def _drive(node: EcuNode, seconds: float = 20.0) -> tuple[Loop, list[float]]:
    """Engage, follow, press the accelerator 3 s, follow on; every request (m/s^2)."""
    loop = Loop(node, v=20.0, gap=40.0, v_lead=18.0)
    loop.engage()
    requests = []
    for phase, kw in (
        (seconds / 2, {}),
        (3.0, {"accel_pressed": True, "accel_pedal": 0.3}),
        (seconds / 2, {}),
    ):
        loop.driver_accel = 1.0 if kw else 0.0
        for _ in range(int(round(phase / DT))):
            out = loop.run(DT, **kw)
            requests.append(out.accel_request_mps2)
    return loop, requests


def _inside_envelope(requests: list[float]) -> None:
    r = np.asarray(requests)
    assert np.all(np.isfinite(r)) and r.min() >= -3.5 - EPS and r.max() <= 2.0 + EPS
    assert np.all(np.abs(np.diff(r)) <= 10.0 * DT + EPS)  # emergency jerk at most
    rising = np.diff(r)
    assert np.all(rising <= JERK * DT + EPS)


def test_the_builtins_through_the_interface_are_bit_identical() -> None:
    direct = EcuNode(EcuConfig(set_speed_mps=30.0), predefined(2.0))
    plugged = EcuNode(
        EcuConfig(set_speed_mps=30.0, gap_controller="pid", adaptation_method="timegap"),
        predefined(2.0),
    )
    loop_a, ra = _drive(direct)
    loop_b, rb = _drive(plugged)
    assert ra == rb and loop_a.gap == loop_b.gap
    assert direct.table.gap_m.tolist() == plugged.table.gap_m.tolist()
    assert direct.adaptations == plugged.adaptations == 1
    assert plugged.plugin_faults == {}


@pytest.mark.parametrize(
    ("spec", "kind"),
    [
        (f"{HERE}:RaisingController", "controller raised"),
        (f"{HERE}:NanController", "controller non_finite"),
        (f"{HERE}:WrongShapeController", "controller bad_output"),
        (f"{HERE}:HugeController", "controller non_finite"),
        (f"{HERE}:SleepyController", "controller overrun"),
        (f"{HERE}:ExitingController", "controller raised"),
        (f"{HERE}:ExitingNumberController", "controller raised"),
        (f"{HERE}:SlowNumberController", "controller overrun"),
    ],
)
def test_a_faulty_controller_leaves_the_ecu_in_its_envelope_and_is_reported(
    spec: str, kind: str
) -> None:
    node = EcuNode(EcuConfig(set_speed_mps=30.0, gap_controller=spec), predefined(2.0))
    loop, requests = _drive(node, seconds=6.0)
    _inside_envelope(requests)
    faults = node.plugin_faults
    assert faults.get(kind, 0) >= 1, faults
    assert loop.gap > node.config.bounds.lower_m(loop.v)  # the safe output kept the gap
    if kind == "controller overrun":  # switched off after 3 overruns: the loop keeps its time
        assert faults[kind] == 3 and faults["controller disabled"] > 100


def test_the_nan_controller_alternates_with_wild_values_that_the_envelope_clips() -> None:
    node = EcuNode(
        EcuConfig(set_speed_mps=30.0, gap_controller=f"{HERE}:NanController"), predefined(2.0)
    )
    _, requests = _drive(node, seconds=4.0)
    assert max(requests) <= 2.0 and min(requests) >= -3.5
    assert node.plugin_faults["controller non_finite"] > 50


@pytest.mark.parametrize("kind", ["raise", "exit", "nan", "shape"])
def test_a_faulty_adaptation_keeps_the_table_and_is_reported(kind: str) -> None:
    node = EcuNode(
        EcuConfig(
            set_speed_mps=30.0,
            adaptation_method=f"{HERE}:BadAdaptation",
            adaptation_args={"kind": kind},
        ),
        predefined(2.0),
    )
    _drive(node, seconds=6.0)
    assert node.table.version == 0 and node.adaptations == 0
    assert node.decisions[Reason.INVALID_INPUT] == 1
    assert sum(node.plugin_faults.values()) == 1


def test_a_table_outside_the_bounds_is_clipped_by_the_ecu() -> None:
    node = EcuNode(
        EcuConfig(adaptation_method=f"{HERE}:BadAdaptation", adaptation_args={"kind": "wide"}),
        predefined(2.0),
    )
    _drive(node, seconds=6.0)
    assert node.adaptations == 1
    upper = SafetyBounds().upper_m(node.table.speed_mps)
    assert np.all(node.table.gap_m <= upper + EPS)


def test_unknown_methods_are_refused_at_construction() -> None:
    with pytest.raises(PluginError, match="one of pid"):
        EcuNode(EcuConfig(gap_controller="nope"), predefined(2.0))
    with pytest.raises(PluginError, match="cannot load"):
        make_adaptation("tests.ecu.nowhere:Thing", {})
    with pytest.raises(PluginError, match="refused its parameters"):
        make_controller("pid", {"no_such_gain": 1.0})
    assert isinstance(make_controller("pid", {"k_lead_accel": 0.3}), PidController)


def _release(v: float, gap: float, pedal: str = "brake") -> TakeoverSummary:
    return TakeoverSummary(duration_s=3.0, v_mps=v, v_lead_mps=v, gap_m=gap, pedal=pedal)


def test_bayes_moves_by_evidence_and_grows_surer() -> None:
    bayes = BayesAdaptation()
    table = predefined(1.5)
    kw: dict[str, Any] = {"bounds": SafetyBounds(), "short_run": False, "created_utc": "x"}
    target = 60.0  # a driver who wants 60 m at 20 m/s (the table says 34 m)
    new, d1 = bayes.update(table, _release(20.0, target), **kw)
    assert new is not None and d1.applied
    first = new.gap_m[40] - table.gap_m[40]
    assert 0.3 * (target - 34.0) < first < target - 34.0  # part of the way, not all of it
    var1 = bayes.variance_m2()
    assert var1 is not None
    again, d2 = bayes.update(new, _release(20.0, target), **kw)
    assert again is not None
    second = again.gap_m[40] - new.gap_m[40]
    assert 0 < second < first  # the same evidence again moves less
    var2 = bayes.variance_m2()
    assert var2 is not None and var2[40] < var1[40]
    assert again.gap_m[60] > table.gap_m[60]  # carried over speed
    # the accelerator cannot lengthen the table
    skipped, d3 = bayes.update(again, _release(20.0, 100.0, "accel"), **kw)
    assert skipped is None and d3.reason is Reason.AGAINST_PEDAL


def test_bayes_learns_nothing_from_a_press_forced_by_a_cut_in() -> None:
    """A brake press 2 s after a radar target switch is the cut-in's, not a preference; 8 s
    after, it is evidence (the same rule as Algorithm 1's, ``switch_window_s`` 5 s)."""
    bayes = BayesAdaptation()
    kw: dict[str, Any] = {"bounds": SafetyBounds(), "short_run": False, "created_utc": "x"}
    forced = TakeoverSummary(3.0, 20.0, 20.0, 60.0, pedal="brake", after_switch_s=2.0)
    new, decision = bayes.update(predefined(1.5), forced, **kw)
    assert new is None and decision.reason is Reason.TARGET_SWITCH
    assert bayes.variance_m2() is None  # the belief is untouched
    later = TakeoverSummary(3.0, 20.0, 20.0, 60.0, pedal="brake", after_switch_s=8.0)
    new, decision = bayes.update(predefined(1.5), later, **kw)
    assert new is not None and decision.applied


def test_bayes_in_the_loop_through_the_entry_of_its_name() -> None:
    node = EcuNode(EcuConfig(set_speed_mps=30.0, adaptation_method="bayes"), predefined(2.0))
    _, requests = _drive(node, seconds=6.0)
    _inside_envelope(requests)
    assert node.adaptations == 1 and node.plugin_faults == {}


def test_the_fallback_pid_reads_a_plugin_memory_only_inside_its_integral_clamp() -> None:
    """A plug-in that raised after leaving a huge memory must not hold the PID on the cruise
    law (an integral of 1e300 would ignore the lead): the fallback clamps it first."""
    params = EcuConfig().controller
    guard = GuardedController(RaisingController(), params, name="raises")
    obs = ControlInput(
        v_mps=25.0,
        a_mps2=0.0,
        set_speed_mps=35.0,
        lead_valid=True,
        gap_m=40.0,
        rel_speed_mps=-2.0,
        lead_accel_mps2=0.0,
        desired_gap_m=40.0,
        desired_gap_slope_s=1.5,
    )
    accel, _ = guard(obs, 1e300, DT)
    limit = params.integral_limit_m_s
    assert accel == desired_accel(params, obs, limit, DT, integrate=True)[0]
    assert accel < desired_accel(params, obs, 1e300, DT, integrate=True)[0]  # not the cruise law


class MeddlingController:
    """Tries to tell the ECU that the braking lead is far and accelerating, then raises."""

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        obs.lead_accel_mps2 = 5.0  # type: ignore[misc]  # what code outside mypy may try
        obs.gap_m = 200.0  # type: ignore[misc]
        raise RuntimeError("boom")


def test_a_plugin_cannot_weaken_the_ecus_limits_through_what_it_is_handed() -> None:
    """25 m/s, 30 m behind a lead 10 m/s slower braking at 4 m/s^2: a plug-in that writes into
    its ControlInput gets a frozen one (refused, as a plain assignment is), and the command
    equals the one behind a plug-in that only raises: the same braking at emergency jerk."""
    from dbc.vocab.acc_state import AccState  # noqa: PLC0415
    from ecu.cycle.command import ControlMemory, control  # noqa: PLC0415
    from ecu.cycle.phases import plan  # noqa: PLC0415
    from ecu.cycle.road import RoadMemory  # noqa: PLC0415
    from ecu.signals import NodeInputs  # noqa: PLC0415

    cfg = EcuConfig()
    inp = NodeInputs(
        v_mps=25.0,
        lead_valid=True,
        gap_m=30.0,
        rel_speed_mps=-10.0,
        lead_accel_mps2=-4.0,
        lead_accel_valid=True,
        main_switch=True,
    )
    p = plan(predefined(1.5), inp.v_mps)
    mem = ControlMemory(0.0, 0.0, RoadMemory())
    commands = []
    for plugin in (RaisingController(), MeddlingController()):
        law = GuardedController(plugin, cfg.controller, name=type(plugin).__name__)
        cmd, _ = control(
            cfg,
            AccState.ACTIVE,
            inp,
            p,
            set_speed_mps=30.0,
            fault_ramp=False,
            mem=mem,
            dt_s=DT,
            law=law,
        )
        commands.append(cmd)
    assert commands[0] == commands[1]
    assert commands[1].emergency and commands[1].accel_mps2 < 0.0
