"""The paper's protocol, shortened, completed by a scripted participant in a real browser."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from dbc.vocab.dgpt_file import load_dgpt
from dbc.vocab.triplog_file import read_trip
from pacc.commands import study as study_cmd
from pacc.hil.plan import paper_plan
from pacc.hil.report import build_table
from tests.hil.conftest import AppFactory
from tests.hil.participant import EVERY, HEADWAY_S, drive_in_browser

SHORT_S = 20.0
#: the page keeps count of the WebSocket messages it receives and those naming a controller
#: (cheaper than a Playwright event per message)
BLIND_JS = r"""(() => {
  const Native = window.WebSocket;
  window.__received = 0;
  window.__named = [];
  window.WebSocket = class extends Native {
    constructor(...args) {
      super(...args);
      this.addEventListener('message', (e) => {
        window.__received += 1;
        if (/predefined|irl|\+oa/.test(e.data)) window.__named.push(e.data);
      });
    }
  };
})();"""


def _walk(page: Any) -> dict[str, Any]:
    """Take every step of the plan as the page offers it; the last view."""
    view: dict[str, Any] = page.evaluate("window.__hil.view")
    while view["step"] is not None and view["step"]["kind"] != "done":
        kind = view["step"]["kind"]
        if kind == "consent":
            view = page.evaluate("window.__hil.action('consent')")
        elif kind == "break":
            view = page.evaluate("window.__hil.action('continue')")
        elif kind == "learn":
            if view["phase"] != "learning":
                page.evaluate("window.__hil.action('start')")
            # the page's frames bring the phase (no timeout of its own: as long as it learns)
            page.wait_for_function("window.__hil.view.phase !== 'learning'", timeout=0)
            view = page.evaluate("window.__hil.view")
            assert view["phase"] != "failed", view["message"]
        else:
            # in the incremental drives the participant has come to like longer gaps
            headway = 3.0 if view["step"]["id"].startswith("inc") else HEADWAY_S
            view = drive_in_browser(page, headway)
            if view["phase"] == "syncing":  # an incremental drive's takeovers go up
                page.wait_for_function("window.__hil.view.phase !== 'syncing'", timeout=0)
                view = page.evaluate("window.__hil.view")
            assert view["phase"] == "after", view
            rating = {"comfort": 5, "trust": 6} if view["rate"] else {}
            view = page.evaluate(f"window.__hil.action('continue', {json.dumps(rating)})")
    return view


@pytest.mark.slow
def test_shortened_protocol_in_a_browser(browser: Any, hil_app: AppFactory, tmp_path: Path) -> None:
    out = tmp_path / "sessions"
    url, session = hil_app(
        paper_plan("P02", incremental=2),
        participant="P02",
        protocol="paper",
        short_s=SHORT_S,
        lockstep=True,
        out=out,
        set_speed_kmh=130.0,  # pacc hil --protocol's: the lead governs
    )
    page = browser.new_page(viewport={"width": 480, "height": 300})
    page.add_init_script(BLIND_JS)
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url + "/")
    page.wait_for_function("window.__hil.view !== null")
    view = _walk(page)
    assert view["step"]["kind"] == "done" and not errors
    # the participant's own overrides are no takeover request: no chime, no TAKE OVER
    assert page.evaluate("window.__hil.chimes") == 0
    assert page.evaluate("window.__hil.cueShown") == 0
    folder = out / "P02"
    manifest = json.loads((folder / "manifest.json").read_text())
    plan = paper_plan("P02", incremental=2)
    assert set(manifest["done"]) == {s.id for s in plan if s.kind != "done"}
    # manual drives recorded as manual trips, the table learned (signed, verified on download)
    for name in ("manual1", "manual2", "manual3", "manual4"):
        trip = read_trip(folder / "logs" / f"{name}.mcap")
        assert trip.meta["mode"] == "manual" and trip.meta["driver_id"] == "P02"
        assert (trip.acc_state == 0).all() and trip.accel_pedal.max() > 0.0
    assert manifest["done"]["learn"]["signed"] and manifest["done"]["learn"]["batches"] >= 1
    irl = load_dgpt(folder / "tables" / "irl.json")
    assert irl.driver_id == "P02"
    assert any((folder / "spool" / "profiles").rglob("*"))
    # ACC drives: takeovers recorded, the +oa tables adapted
    records = [json.loads(p.read_text()) for p in (folder / "drives").glob("acc*.json")]
    assert len(records) == 8
    assert sum(r["row"]["takeovers"] for r in records) > 0
    adapted = [r for r in records if r["row"]["controller"].endswith("+oa")]
    assert any(r["row"]["adaptations"] > 0 for r in adapted)
    assert (folder / "ratings.csv").read_text().count("\n") == 11
    # incremental learning: the second trip drove the version the first one's takeovers made
    inc = [json.loads((folder / "drives" / f"inc{k}-B.json").read_text()) for k in (1, 2)]
    assert inc[0]["row"]["takeovers"] > 0 and inc[0]["incremental"]["uploaded"] >= 1
    assert inc[1]["table_version"] == inc[0]["incremental"]["next_version"]
    assert inc[1]["row"] != inc[0]["row"]  # trip k drives with plant noise seed + k
    # blind: no message to the page named a controller
    steps = len([s for s in plan if s.kind == "drive"]) * SHORT_S * 100 / EVERY
    assert page.evaluate("window.__received") > steps and page.evaluate("window.__named") == []
    page.close()
    # Table I from the session folder
    table = build_table(out, tmp_path / "table")
    assert "P02" in table and "IRL + OA" in table and "Incremental learning" in table
    assert (tmp_path / "table" / "table1.md").is_file()
    # the command, with the rows of a synthetic study beside (here: the same rows renamed)
    synthetic = (tmp_path / "table" / "drives.csv").read_text().replace("P02", "d9")
    (tmp_path / "synthetic.csv").write_text(synthetic)
    argv = [
        "--hil",
        str(out),
        "--out",
        str(tmp_path / "t2"),
        "--beside",
        str(tmp_path / "synthetic.csv"),
    ]
    assert study_cmd.main(argv) == 0
    text = (tmp_path / "t2" / "table1.md").read_text()
    assert "People beside synthetic drivers" in text and "1 people, 1 synthetic drivers." in text
