"""The road as drawn: the lead's angular size, the posts' optic flow, weather, a cut-in.

Every figure is measured from the frames chromium drew (canvas pixels), at a 960 x 540 canvas.
"""

from __future__ import annotations

import io
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from pacc.hil.plan import Step
from tests.hil.conftest import AppFactory
from tests.hil.pages import BODY_RGB, NEXT_FRAME, TWO_FRAMES, open_hil

#: set to a folder (docs/img) to keep the screenshots of the page in each condition
SHOTS_ENV = "PACC_HIL_SCREENSHOTS"
W_PX = 960
POST_RGB = (90, 90, 96)
POST_SPACING_M = 4.0
RAIL_L_M = 1.5 * 3.75 + 0.75 + 0.3  # the left guard rail's distance from the eye, m (road.js)
#: one round trip: step ``n`` ticks, let the page draw it, read canvas row ``y`` (x < ``w``)
STEP_DRAW_ROW = f"""async ([n, y, w]) => {{
  const view = await window.__hil.step(n);
  await {NEXT_FRAME};
  return [view, Array.from(document.getElementById('view').getContext('2d')
    .getImageData(0, y, w, 1).data)];
}}"""


def _drive(tab: Any, hil_app: AppFactory, steps: list[Step], **kw: Any) -> tuple[Any, Any]:
    url, session = hil_app([*steps, Step("done", "done", "End")], lockstep=True, **kw)
    page = open_hil(tab, url, W_PX, 564)
    page.evaluate("window.__hil.manual = true")
    page.evaluate("window.__hil.action('start')")
    return page, session


def _step_to(page: Any, t_s: float, n: int) -> dict[str, Any]:
    """Step ``n`` ticks at a time until the drive's time reaches ``t_s``; the last view."""
    view: dict[str, Any] = page.evaluate("window.__hil.view")
    while view["state"]["t"] < t_s - 1e-6:
        view = page.evaluate(f"window.__hil.step({n})")
    return view


def _runs(row: np.ndarray, rgb: tuple[int, int, int]) -> list[tuple[int, int]]:
    """(start, length) of each run of pixels of colour ``rgb`` (± 6) in a row (W x 3)."""
    hit = np.abs(row.astype(int) - np.array(rgb)).sum(axis=1) <= 6
    edges = np.flatnonzero(np.diff(np.concatenate([[0], hit.astype(int), [0]])))
    return [(int(a), int(b - a)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _canvas(page: Any) -> np.ndarray:
    png = page.locator("#view").screenshot()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


@pytest.mark.slow
@pytest.mark.parametrize("fov_deg", [50.0, 70.0])
def test_lead_subtends_its_real_angle(tab: Any, hil_app: AppFactory, fov_deg: float) -> None:
    """The lead's drawn width at gaps of 10, 30 and 60 m is f · 1.8 m / g (within 5 %),
    f = (W/2) / tan(fov/2): the angle a 1.8-m-wide car subtends at that gap."""
    page, _ = _drive(tab, hil_app, [Step("d", "drive", "D", "B", None)], fov_deg=fov_deg)
    page.evaluate("window.__hil.step(10)")
    f_px = (W_PX / 2) / math.tan(math.radians(fov_deg) / 2)
    for gap in (10.0, 30.0, 60.0):
        page.evaluate(f"window.__hil.view.state = {{...window.__hil.view.state, gap: {gap}}}")
        page.evaluate(TWO_FRAMES)
        img = _canvas(page)
        width = max((n for y in range(img.shape[0]) for _, n in _runs(img[y], BODY_RGB)), default=0)
        want = f_px * 1.8 / gap
        assert abs(width - want) <= 0.05 * want, (fov_deg, gap, width, want)


@pytest.mark.slow
def test_posts_pass_at_speed_over_spacing(tab: Any, hil_app: AppFactory) -> None:
    """The guard-rail posts found in the frames sit 4 m apart and move with the car: one
    passes every spacing / speed seconds (counted where the nearest post leaves a band)."""
    page, _ = _drive(tab, hil_app, [Step("d", "drive", "D", "B", None)], short_s=60.0)
    page.keyboard.down("ArrowUp")
    view = page.evaluate("window.__hil.step(200)")
    page.keyboard.up("ArrowUp")
    page.evaluate(TWO_FRAMES)
    f_px = (W_PX / 2) / math.tan(math.radians(50.0) / 2)
    hz = round((540 - round(min(120, 540 * 0.22))) * 0.42)
    y = hz + 40  # a row through the posts' visible feet, 19..31 m ahead on the left
    band = ((1.2 - 0.45) * f_px / 40, 1.2 * f_px / 40)  # eye 1.2 m, rail's lower edge 0.45 m
    odo, t = 0.0, view["state"]["t"]
    phases: list[float] = []
    nearest: list[float] = []
    for _ in range(60):
        view, data = page.evaluate(STEP_DRAW_ROW, [5, y, W_PX // 2])
        s = view["state"]
        odo += s["v"] * (s["t"] - t)
        t = s["t"]
        row = np.asarray(data, dtype=np.uint8).reshape(-1, 4)[:, :3]
        zs = sorted(f_px * RAIL_L_M / (W_PX / 2 - (a + n / 2)) for a, n in _runs(row, POST_RGB))
        zs = [z for z in zs if band[0] - 0.5 < z < band[1] + 0.5]  # feet below the rail
        assert len(zs) >= 2, zs
        gaps = np.diff(zs)
        assert np.all(np.abs(gaps - POST_SPACING_M) < 0.4), zs
        phases += [(z + odo) % POST_SPACING_M for z in zs]
        nearest.append(zs[0])
    # the posts stand still in the world: position + distance travelled is constant
    ang = np.asarray(phases) / POST_SPACING_M * 2 * np.pi
    spread_m = np.hypot(np.sin(ang).mean(), np.cos(ang).mean())
    assert spread_m > 0.98, spread_m  # circular concentration: within about ±0.3 m
    passed = sum(1 for a, b in zip(nearest, nearest[1:], strict=False) if b > a + 1.0)
    assert odo > 5 * POST_SPACING_M
    assert abs(passed - odo / POST_SPACING_M) <= 1.0, (passed, odo / POST_SPACING_M)


def _luma(img: np.ndarray) -> float:
    return float((img[:380].astype(float) @ [0.299, 0.587, 0.114]).mean())


@pytest.mark.slow
def test_day_rain_night_and_a_cut_in(tab: Any, hil_app: AppFactory, tmp_path: Path) -> None:
    """Each drive's condition is drawn (night darker, rain greyer than day) and a cut-in is
    shown as it happens: the new lead comes across from the next lane, the old one ahead."""
    keep = os.environ.get(SHOTS_ENV)
    shots: dict[str, np.ndarray] = {}
    for name, scenario, until in (
        ("day", "B", 6.0),
        ("rain", "B", 6.0),
        ("night", "B", 6.0),
        ("cutin", "cutin", 31.3),
    ):
        weather = name if name != "cutin" else "day"
        step = Step("d", "drive", "D", scenario, "predefined", weather=weather)
        page, _ = _drive(tab, hil_app, [step], short_s=40.0, out=tmp_path / name)
        page.evaluate("window.__hil.step(100)")
        page.keyboard.press("s")
        _step_to(page, until - 1.0, 100)  # the same world in fewer round trips
        view = _step_to(page, until, 10)  # the last second as the page steps it
        page.evaluate(TWO_FRAMES)
        png = page.screenshot()
        shots[name] = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
        if name == "cutin":
            assert view["state"]["events"] and view["state"]["events"][0][1] == "cut_in"
            shift = page.evaluate("window.__road.leadSide")
            assert shift != 0 and page.evaluate("window.__road.ghosts.length") == 1
        if keep:
            Path(keep).mkdir(parents=True, exist_ok=True)
            (Path(keep) / f"hil-{name}.png").write_bytes(png)
    assert _luma(shots["night"]) < 0.5 * _luma(shots["day"])
    day_sky, rain_sky = shots["day"][20:100].reshape(-1, 3), shots["rain"][20:100].reshape(-1, 3)
    assert np.ptp(rain_sky.mean(axis=0)) < np.ptp(day_sky.mean(axis=0))  # grey, not blue
