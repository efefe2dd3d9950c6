"""The cloud you can see: list endpoints under the token rules, and the dashboard in a real
browser (Debian's chromium driven by Playwright) after an upload."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from cloud_sync.service.rules import CloudService
from cloud_sync.service.trips import record_trip
from dbc.vocab.triplog_file import write_trip

from .conftest import follower_trip, takeover_segment
from .served import OPERATOR, Served


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Served, str, str]]:
    """A cloud with two vehicles, one driver each; car-a's driver uploaded a manual trip, has
    a learned table, then drove two ACC trips with it (one takeover segment) and reported them."""
    tmp = tmp_path_factory.mktemp("views")
    pool = ThreadPoolExecutor(max_workers=1)
    service = CloudService.open(tmp / "cloud", executor=pool)
    token_a = service.register_vehicle("car-a")
    service.register_driver("car-a", "syn")
    token_b = service.register_vehicle("car-b")
    service.register_driver("car-b", "other")
    path = tmp / "t.mcap"
    write_trip(path, follower_trip(0, minutes=2.0))
    service.upload("car-a", path.read_bytes())
    service.wait_idle(120.0)
    write_trip(path, takeover_segment(1, [(50, 80, "accel")]))
    segment = service.upload("car-a", path.read_bytes()).digest
    for trip_id, segments, acc_on_s in (("t1", [segment], 120.0), ("t2", [], 150.0)):
        report = {"driver_id": "syn", "trip_id": trip_id, "dgpt_version": 1}
        record_trip(service, "car-a", {**report, "acc_on_s": acc_on_s, "segments": segments})
    service.wait_idle(120.0)
    s = Served(service)
    yield s, token_a, token_b
    s.stop()
    pool.shutdown(wait=True)
    service.store.close()


def test_lists_follow_the_vehicle_token_rules(served: tuple[Served, str, str]) -> None:
    s, token_a, token_b = served
    assert [d["driver_id"] for d in s.get("/v1/drivers", token_a).json()] == ["syn"]
    assert [d["driver_id"] for d in s.get("/v1/drivers", token_b).json()] == ["other"]
    every = s.get("/v1/drivers", OPERATOR).json()
    assert {(d["driver_id"], d["vehicle_id"]) for d in every} == {
        ("syn", "car-a"),
        ("other", "car-b"),
    }
    assert s.get("/v1/drivers", None).status_code == 401
    assert s.get("/v1/drivers", "nope").status_code == 401
    assert s.get("/v1/drivers/syn/versions", token_b).status_code == 403
    assert s.get("/v1/drivers/syn/batches", token_b).status_code == 403
    assert s.get("/v1/drivers/ghost/versions", OPERATOR).status_code == 404
    versions = s.get("/v1/drivers/syn/versions", token_a).json()
    assert versions == s.get("/v1/drivers/syn/versions", OPERATOR).json()
    v = versions[0]  # learned from the manual trip
    assert v["condition"] == "default" and v["source"] == "irl" and v["version"] == 1
    assert len(v["speed_mps"]) == len(v["gap_m"]) > 10
    assert v["meta"]["n_trips"] == 1 and v["meta"]["covered_mps"]
    batches = s.get("/v1/drivers/syn/batches", token_a).json()
    assert [b["kind"] for b in batches] == ["manual", "takeover"]
    assert v["batches"] == [batches[0]["digest"]]
    assert batches[0]["used_in_version"] == 1
    trips = s.get("/v1/drivers/syn/trips", token_a).json()
    assert [(t["trip_id"], t["takeovers"]) for t in trips] == [("t1", 1), ("t2", 0)]
    assert trips[0]["poi_pct"] == pytest.approx(100.0 * 3.0 / 120.0)  # 30 samples of 0.1 s
    assert s.get("/v1/drivers/syn/trips", token_b).status_code == 403
    jobs = s.get("/v1/jobs", token_a).json()
    assert jobs == [{"driver_id": "syn", "condition": "default", "state": "idle"}]
    assert s.get("/v1/jobs", token_b).json() == []


CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
#: where to save a screenshot of the dashboard (for docs; unset: none)
SHOT = os.environ.get("PACC_DASHBOARD_SHOT")
#: JavaScript: how many pixels of the canvas matching a selector are drawn on
_INKED = """(sel) => { const c = document.querySelector(sel);
    const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
    let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++;
    return n; }"""


@pytest.mark.slow
def test_dashboard_in_chromium_shows_the_drivers_table_plot(
    served: tuple[Served, str, str],
) -> None:
    playwright = pytest.importorskip("playwright.sync_api")
    if not Path(CHROMIUM).exists():
        pytest.skip("Debian's chromium is not installed (make installs it)")
    s, token_a, _ = served
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True)
        page = browser.new_page()
        page.goto(s.url + "/dashboard")
        page.fill("#token", "wrong")
        page.click("button[type=submit]")
        page.wait_for_function("document.getElementById('error').textContent.includes('401')")
        page.fill("#token", token_a)
        page.click("button[type=submit]")
        page.wait_for_selector("body[data-loaded='1']", timeout=20_000)
        plot = page.locator("canvas.dgpt-plot[data-driver='syn']")
        assert plot.count() == 1
        assert page.locator("#driver-other").count() == 0  # car-a does not see car-b's
        drawn = page.evaluate(_INKED, "canvas.dgpt-plot")
        assert drawn > 2000  # axes, the covered range and the table's curve
        assert "v1" in page.inner_text("table.versions")
        # the per-trip learning curve: one point per reported trip, marked with its version
        curve = page.locator("canvas.trip-curve[data-driver='syn']")
        assert curve.get_attribute("data-points") == "2"
        assert page.evaluate(_INKED, "canvas.trip-curve") > 1000
        if SHOT:
            page.screenshot(path=SHOT, full_page=True)
        rows = page.inner_text("table.trips")
        assert "t1" in rows and "t2" in rows and "2.50" in rows  # t1's PoI, %
        assert "idle" in page.inner_text("#jobs")
        browser.close()
