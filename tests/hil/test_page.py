"""The driving page in headless chromium: offline, brake lights, a gamepad, determinism."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dbc.vocab.triplog_file import read_trip
from pacc.hil.plan import Step, free_plan
from pacc.hil.session import Session, SessionConfig
from tests.hil.conftest import AppFactory
from tests.hil.pages import BRAKE_LIGHT_RGB, GAMEPAD_JS, TWO_FRAMES, body_pixels, new_page, open_hil
from tests.hil.participant import EVERY, decide, drive_in_browser, drive_without_browser


def test_page_loads_with_no_network(browser: Any, hil_app: AppFactory) -> None:
    url, _ = hil_app(free_plan("B", "predefined"), short_s=5.0)
    page = new_page(browser)  # every request outside 127.0.0.1 aborted and kept
    page.goto(url + "/")
    page.wait_for_function("window.__hil.view !== null")
    view = page.evaluate("window.__hil.view")
    assert view["step"]["kind"] == "drive" and view["phase"] == "ready"
    assert page.outside == [] and page.errors == []
    assert "Start" in page.inner_text("#primary")
    page.close()


@pytest.mark.slow
def test_brake_lights_when_the_lead_brakes(tab: Any, hil_app: AppFactory) -> None:
    url, _ = hil_app(free_plan("A", None), short_s=20.0, lockstep=True)  # A: brakes at 11.5 s
    page = open_hil(tab, url, 960, 540)  # the canvas at 1:1
    page.evaluate("window.__hil.manual = true")
    view = page.evaluate("window.__hil.action('start')")
    shots: dict[str, int] = {}
    held = False
    while view["state"]["a_lead"] > -0.8:
        accel = decide(view["state"])[0]  # follow the lead by the participant's rule
        if accel != held:
            (page.keyboard.down if accel else page.keyboard.up)("ArrowUp")
            held = accel
        view = page.evaluate(f"window.__hil.step({EVERY})")
        if "dark" not in shots and view["state"]["t"] >= 8.0:
            page.evaluate(TWO_FRAMES)
            shots["dark"] = body_pixels(page.screenshot(), BRAKE_LIGHT_RGB)
    page.evaluate(TWO_FRAMES)
    shots["lit"] = body_pixels(page.screenshot(), BRAKE_LIGHT_RGB)
    assert shots["dark"] == 0 and shots["lit"] > 20, shots


@pytest.mark.slow
def test_gamepad_calibrated_then_drives(browser: Any, hil_app: AppFactory, tmp_path: Path) -> None:
    url, session = hil_app(free_plan("B", None), short_s=10.0, lockstep=True)
    page = browser.new_page(viewport={"width": 480, "height": 300})
    page.add_init_script(GAMEPAD_JS)  # a page of its own: the synthetic pad stays with it
    page.goto(url + "/calibrate")
    page.wait_for_function("document.getElementById('pad').textContent.startsWith('Gamepad')")
    # accelerator: axis 2 of a pedal resting at -1; brake: the left trigger (button 6)
    page.click("#cap-accel")
    page.evaluate("window.__setPad([null, null, 1.0])")
    page.evaluate(TWO_FRAMES)  # a frame polls the pad at full travel
    page.evaluate("window.__setPad([null, null, -1.0])")
    page.wait_for_function("window.__cal.mapping.accel !== undefined")
    page.click("#cap-brake")
    page.evaluate("window.__setPad(null, {6: 1})")
    page.evaluate(TWO_FRAMES)
    page.evaluate("window.__setPad(null, {6: 0})")
    page.wait_for_function("window.__cal.mapping.brake !== undefined")
    page.click("#save")
    page.wait_for_function("window.__cal.saved === true")
    saved = json.loads((tmp_path / "gamepad.json").read_text())
    assert saved["accel"] == {"axis": 2, "rest": -1.0, "full": 1.0}
    assert saved["brake"] == {"button": 6}

    page.goto(url + "/")  # the driving page (the pad at rest again)
    page.wait_for_function("window.__hil.view !== null")
    page.wait_for_timeout(200)  # the mapping fetched
    page.evaluate("window.__hil.manual = true")
    page.evaluate("window.__hil.action('start')")
    assert session.drive is not None
    codec = session.drive.codec
    pedals: list[dict[str, Any]] = []

    def tap(t: float, key: int, data: Any, rx: bool) -> None:
        d = codec.by_id[key].decode(data)
        if d.role == "pedals":
            pedals.append(dict(d.values))

    session.drive.node.tap = tap
    page.evaluate("window.__setPad([null, null, 0.0])")  # half way: 50 %
    page.evaluate(TWO_FRAMES)  # a frame polls the pad and sends it
    view = page.evaluate("window.__hil.step(10)")
    assert view["state"]["accel"] == pytest.approx(0.5)
    assert pedals[-1]["accel_pressed"] == 1
    assert pedals[-1]["accel_pedal_pct"] == pytest.approx(50.0, abs=0.5)
    page.evaluate("window.__setPad([null, null, -1.0], {6: 1})")  # off the gas, full brake
    page.evaluate(TWO_FRAMES)
    view = page.evaluate("window.__hil.step(10)")
    assert view["state"]["brake"] == 1.0 and pedals[-1]["brake_pressed"] == 1
    page.close()


@pytest.mark.slow
def test_browser_drive_equals_the_bus_drive_without_browser(
    tab: Any, hil_app: AppFactory, tmp_path: Path
) -> None:
    step = Step("acc", "drive", "Drive", "A", "predefined+oa")
    plan = [step, Step("done", "done", "End")]
    url, session = hil_app(plan, short_s=30.0, lockstep=True)
    view = drive_in_browser(open_hil(tab, url))
    assert view["phase"] == "after"
    record = json.loads((session.folder / "drives" / "acc.json").read_text())
    reference = Session(
        SessionConfig("P01", "test", tmp_path / "ref", short_s=30.0, lockstep=True), plan
    )
    drive = reference.new_drive(step)
    drive_without_browser(drive)
    log = drive.finish()
    browser_trip = session.folder / "logs" / "acc.mcap"
    got = read_trip(browser_trip)
    ref = drive.trip(log, {})
    for name in ("t_s", "v_mps", "gap_m", "accel_pedal", "brake_pedal", "acc_state"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    assert drive.ecu is not None
    assert record["row"]["takeovers"] == drive.ecu.takeovers > 0
    assert record["row"]["adaptations"] == drive.ecu.adaptations
    shutil.rmtree(tmp_path / "ref", ignore_errors=True)
