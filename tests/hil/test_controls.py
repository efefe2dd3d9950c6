"""A participant's controls, pressed as a person presses them, checked in the bus frames."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest

from pacc.commands import hil as hil_cmd
from pacc.hil.plan import Step
from pacc.hil.session import Session, SessionConfig
from sim_bus.faults import parse_faults
from tests.hil.conftest import AppFactory
from tests.hil.pages import NEXT_FRAME, TWO_FRAMES, open_hil


def _acc_plan(scenario: str = "B", controller: str = "predefined") -> list[Step]:
    return [
        Step("acc1-B", "drive", "Drive 1 of 1", scenario, controller),
        Step("done", "done", "End"),
    ]


def _open(tab: Any, url: str) -> Any:
    page = open_hil(tab, url, 960, 564)  # the canvas at 960 x 540
    page.evaluate("window.__hil.manual = true")
    return page


class Frames:
    """The drive's bus frames as the simulator's node sees them, decoded by role."""

    def __init__(self, session: Session) -> None:
        assert session.drive is not None
        codec = session.drive.codec
        self.by_role: dict[str, list[dict[str, Any]]] = {}

        def tap(t: float, key: int, data: Any, rx: bool) -> None:
            d = codec.by_id[key].decode(data)
            self.by_role.setdefault(d.role, []).append(dict(d.values))

        session.drive.node.tap = tap

    def last(self, role: str) -> dict[str, Any]:
        return self.by_role[role][-1]


def _steps(page: Any, seconds: float) -> dict[str, Any]:
    """``seconds`` of the drive in one step message (lockstep: the world is the same as in
    10-tick steps, nothing else reaches it in between); the view after."""
    view: dict[str, Any] = page.evaluate(f"window.__hil.step({round(seconds * 100)})")
    return view


@pytest.mark.slow
def test_ratings_clicked_are_saved(tab: Any, hil_app: AppFactory) -> None:
    url, session = hil_app(_acc_plan(), short_s=2.0, lockstep=True)
    page = _open(tab, url)
    page.keyboard.press("Enter")  # Start
    page.wait_for_function("window.__hil.view.phase === 'driving'")
    view = _steps(page, 3.0)
    assert view["phase"] == "after" and view["rate"]
    page.wait_for_selector("#rating:not(.hidden)")
    page.click("input[name=comfort][value='5']")
    page.click("input[name=trust][value='6']")
    frames = page.evaluate("window.__hil.frames")  # ten frames, each answered with the view:
    page.wait_for_function(f"window.__hil.frames >= {frames + 10}")  # the clicks stay
    assert page.is_checked("input[name=comfort][value='5']")
    page.keyboard.press("Enter")
    page.wait_for_function("window.__hil.view.step.kind === 'done'")
    rows = list(csv.DictReader((session.folder / "ratings.csv").open()))
    assert [(r["step"], r["comfort"], r["trust"]) for r in rows] == [("acc1-B", "5", "6")]
    manifest = json.loads((session.folder / "manifest.json").read_text())
    assert manifest["done"]["acc1-B"]["ratings"] == {"comfort": 5, "trust": 6}


@pytest.mark.slow
def test_set_gap_and_main_switch_in_the_bus_frames(tab: Any, hil_app: AppFactory) -> None:
    url, session = hil_app(_acc_plan(), short_s=60.0, lockstep=True)
    page = _open(tab, url)
    text = page.inner_text("#text")
    assert "Drive off" not in text and "current speed" in text
    page.keyboard.press("Enter")
    page.wait_for_function("window.__hil.view.phase === 'driving'")
    frames = Frames(session)
    view = _steps(page, 2.0)
    assert view["state"]["v"] > 3.0  # the car rolls behind the lead from the start
    page.keyboard.press("s")
    view = _steps(page, 1.0)
    status = frames.last("status")
    assert view["state"]["acc_state"] == "ACTIVE"
    # SET takes the speed the car had (not a fixed study speed), and the page shows it
    assert 3.0 < status["set_speed_mps"] < 40.0
    assert view["state"]["set_speed"] == pytest.approx(status["set_speed_mps"], abs=0.01)
    v = frames.by_role["ego"][-1]["speed_mps"]
    assert status["desired_gap_m"] == pytest.approx(4.0 + 3.0 * v, abs=1.0)  # medium: 3 s
    page.keyboard.press("g")  # 2 -> 3: the high setting, 4 s
    _steps(page, 1.0)
    assert frames.last("hmi")["gap_setting"] == 3
    v = frames.by_role["ego"][-1]["speed_mps"]
    assert frames.last("status")["desired_gap_m"] == pytest.approx(4.0 + 4.0 * v, abs=1.0)
    page.keyboard.press("g")  # 3 -> 1: the low setting, 1 s
    _steps(page, 1.0)
    v = frames.by_role["ego"][-1]["speed_mps"]
    assert frames.last("hmi")["gap_setting"] == 1
    assert frames.last("status")["desired_gap_m"] == pytest.approx(4.0 + 1.0 * v, abs=1.0)
    page.keyboard.press("m")  # main switch off: the ACC is off and the page says so
    view = _steps(page, 0.5)
    page.evaluate(TWO_FRAMES)
    assert frames.last("hmi")["main_switch"] == 0 and view["state"]["acc_state"] == "OFF"
    assert "OFF" in page.inner_text("#toast") and page.is_visible("#toast")
    page.keyboard.press("m")  # on again: STANDBY, S engages
    view = _steps(page, 0.5)
    assert frames.last("hmi")["main_switch"] == 1 and view["state"]["acc_state"] == "STANDBY"
    page.keyboard.press("s")
    view = _steps(page, 0.5)
    assert view["state"]["acc_state"] == "ACTIVE"
    page.keyboard.press("e")  # engine sound on: its pitch follows the speed
    view = _steps(page, 0.1)
    page.evaluate(TWO_FRAMES)
    kmh = view["state"]["v"] * 3.6
    assert page.evaluate("window.__hil.engineHz") == pytest.approx(35 + 4 * (kmh % 50), abs=0.01)


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["resume", "cancel"])
def test_brake_resumes_or_cancels_as_the_study_says(
    tab: Any, hil_app: AppFactory, mode: str
) -> None:
    url, session = hil_app(_acc_plan(), short_s=60.0, lockstep=True, brake_mode=mode)
    page = _open(tab, url)
    assert ("switches the cruise control off" in page.inner_text("#text")) == (mode == "cancel")
    page.keyboard.press("Enter")
    page.wait_for_function("window.__hil.view.phase === 'driving'")
    frames = Frames(session)
    _steps(page, 2.0)
    page.keyboard.press("s")
    assert _steps(page, 1.0)["state"]["acc_state"] == "ACTIVE"
    page.keyboard.down("ArrowDown")
    view = _steps(page, 0.5)
    assert frames.last("pedals")["brake_pressed"] == 1
    assert view["state"]["acc_state"] == ("OVERRIDE" if mode == "resume" else "STANDBY")
    page.keyboard.up("ArrowDown")
    view = _steps(page, 1.5)
    assert view["state"]["acc_state"] == ("ACTIVE" if mode == "resume" else "STANDBY")
    assert frames.last("command")["takeover_request"] == 0
    page.evaluate(TWO_FRAMES)  # the frames have seen the latest view
    assert page.evaluate("window.__hil.chimes") == 0  # the participant's own override


@pytest.mark.slow
def test_take_over_shown_for_the_ecus_request_only(tab: Any, hil_app: AppFactory) -> None:
    url, session = hil_app(_acc_plan(), short_s=60.0, lockstep=True)
    page = _open(tab, url)
    page.keyboard.press("Enter")
    page.wait_for_function("window.__hil.view.phase === 'driving'")
    frames = Frames(session)
    _steps(page, 2.0)
    page.keyboard.press("s")
    _steps(page, 1.0)
    page.keyboard.down("ArrowUp")  # the participant's override: no request, no banner
    assert _steps(page, 0.5)["state"]["acc_state"] == "OVERRIDE"
    page.keyboard.up("ArrowUp")
    _steps(page, 1.0)
    page.evaluate(TWO_FRAMES)
    assert page.evaluate("window.__hil.chimes") == 0 and not page.is_visible("#cue")
    assert session.drive is not None
    t = session.drive.world.t_s
    session.drive.node.faults = parse_faults(f"radar:dropout={t:.1f}-{t + 5:.1f}")
    view = _steps(page, 1.0)
    assert view["state"]["acc_state"] == "FAULT"
    assert frames.last("command")["takeover_request"] == 1
    page.wait_for_function("window.__hil.chimes === 1")
    assert page.is_visible("#cue") and page.inner_text("#cue") == "TAKE OVER"


@pytest.mark.slow
def test_collision_warning_before_a_crash(tab: Any, hil_app: AppFactory) -> None:
    url, _ = hil_app(
        [Step("m", "drive", "Manual", "A", None), Step("done", "done", "End")],
        short_s=60.0,
        lockstep=True,
    )
    page = _open(tab, url)
    page.keyboard.press("Enter")
    page.wait_for_function("window.__hil.view.phase === 'driving'")
    page.keyboard.down("ArrowUp")  # a naive hold of the accelerator
    warned_at = None
    view = page.evaluate("window.__hil.view")
    step_draw = (
        f"async () => [await window.__hil.step(10), await {NEXT_FRAME}, window.__hil.warnings]"
    )
    while view["phase"] == "driving" and not view["state"]["collided"]:
        view, _, warnings = page.evaluate(step_draw)  # one round trip: step, a frame, count
        if warned_at is None and warnings > 0:
            warned_at = view["state"]["t"]
            assert page.is_visible("#warn")
    page.keyboard.up("ArrowUp")
    assert view["state"]["collided"] or view["phase"] == "after"
    crash_t = view["state"]["t"]
    assert warned_at is not None and crash_t - warned_at >= 1.5, (warned_at, crash_t)


def test_foxglove_port_clash_is_a_clear_error(capsys: Any, tmp_path: Path) -> None:
    argv = ["--out", str(tmp_path), "--foxglove"]  # Foxglove's default port
    assert hil_cmd.DEFAULT_PORT != 8765
    assert hil_cmd.main([*argv, "127.0.0.1:9123", "--port", "9123"]) == 2
    assert "the page's port" in capsys.readouterr().err
    import socket  # noqa: PLC0415

    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        assert hil_cmd.main([*argv, f"127.0.0.1:{port}", "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert f"127.0.0.1:{port}: cannot listen there" in err and "Traceback" not in err
    assert hil_cmd.main([*argv[:2], "--weather", "fog"]) == 2
    assert "--weather" in capsys.readouterr().err


def test_study_options_reach_the_session(tmp_path: Path) -> None:
    def cfg(*argv: str) -> Any:
        return hil_cmd.session_of(hil_cmd._parser().parse_args(["--out", str(tmp_path), *argv]))

    paper = cfg("--protocol", "paper", "--participant", "P01", "--weather", "night")
    assert paper.cfg.set_speed_kmh == 130.0 and paper.cfg.brake_mode == "resume"
    assert {s.weather for s in paper.plan if s.kind == "drive"} == {"night"}
    free = cfg("--brake", "cancel", "--fov", "70", "--weather", "rain")
    assert free.cfg.set_speed_kmh is None and free.cfg.brake_mode == "cancel"
    assert free.view()["fov"] == 70.0 and free.view()["weather"] == "rain"


def test_a_taken_live_view_port_leaves_the_page_a_message(tmp_path: Path) -> None:
    import socket  # noqa: PLC0415

    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        cfg = SessionConfig(
            "P05", "t", tmp_path, short_s=2.0, lockstep=True, foxglove=f"127.0.0.1:{port}"
        )
        session = Session(cfg, _acc_plan())
        view = session.handle({"t": "action", "name": "start"})
    assert view is not None and view["phase"] == "ready" and session.drive is None
    assert view["message"].startswith("cannot start the drive:")
    session.close()


@pytest.mark.slow
def test_calibration_link_is_readable(tab: Any, hil_app: AppFactory) -> None:
    url, _ = hil_app(_acc_plan(), short_s=2.0)
    tab.goto(url + "/calibrate")
    color = tab.eval_on_selector("a", "a => getComputedStyle(a).color")
    r, g, b = (int(x) for x in color[4:-1].split(","))
    assert 0.2126 * r + 0.7152 * g + 0.0722 * b > 128, color  # light on the black page
