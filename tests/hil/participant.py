"""A scripted participant: follows the lead by a known gap rule, with the page's keys.

:func:`decide` is a pure function of what the page shows (the view's ``state``): which pedal
keys to hold and whether to press SET. :func:`drive_in_browser` plays it through a real page
(keyboard events, lockstep steps); :func:`drive_without_browser` plays it straight into a
:class:`~pacc.hil.loop.HilDrive` on the bus, for the determinism test.
"""

from __future__ import annotations

from typing import Any

from pacc.hil.loop import HilDrive

#: the participant's gap rule: want 5 m + HEADWAY_S · v by hand
HEADWAY_S = 1.6
#: under ACC it takes over when the gap is off by more than these factors of its wish
TOO_CLOSE, TOO_FAR = 0.7, 1.5
#: ticks (10 ms) between decisions, one lockstep step: 0.2 s, about a person's reaction time
EVERY = 20


def decide(s: dict[str, Any], headway_s: float = HEADWAY_S) -> tuple[bool, bool, bool]:
    """(hold accelerator, hold brake, press SET) from the page's state; ``headway_s``: the
    time gap it wants (5 m + headway · v)."""
    want = 5.0 + headway_s * s["v"]
    err = s["gap"] - want - 2.0 * (s["v"] - s["v_lead"])  # the gap it will have in 2 s
    if s["acc"] and s["main"] and s["acc_state"] in ("ACTIVE", "OVERRIDE"):
        return (
            s["gap"] > TOO_FAR * want and s["v_lead"] >= s["v"],
            s["gap"] < TOO_CLOSE * want or err < -0.6 * want,
            False,
        )
    press_set = s["acc"] and s["acc_state"] == "STANDBY" and s["t"] >= 1.5 and abs(err) < 8.0
    return err > 1.0, err < -4.0, press_set and int(round(s["t"] * 10)) % 10 == 0


def drive_without_browser(drive: HilDrive) -> None:
    """Play the participant into ``drive`` directly (lockstep, no page, no WebSocket)."""

    while not drive.done:
        if drive.node.tick % EVERY == 0:
            accel, brake, press_set = decide(drive.snapshot())
            drive.pedals.keys(accel, brake)
            if press_set:
                drive.pedals.press("set")
        drive.step()


def drive_in_browser(page: Any, headway_s: float = HEADWAY_S) -> dict[str, Any]:
    """Play the participant through ``page`` (a lockstep session's page in its ``ready``
    phase): start, then per step read the state, press keys, step. The final view."""
    page.evaluate("window.__hil.manual = true")
    view: dict[str, Any] = page.evaluate("window.__hil.action('start')")
    held = {"ArrowUp": False, "ArrowDown": False}
    while view["phase"] == "driving":
        accel, brake, press_set = decide(view["state"], headway_s)
        for key, want in (("ArrowUp", accel), ("ArrowDown", brake)):
            if want != held[key]:
                (page.keyboard.down if want else page.keyboard.up)(key)
                held[key] = want
        if press_set:
            page.keyboard.press("s")
        view = page.evaluate(f"window.__hil.step({EVERY})")
    for key, down in held.items():
        if down:
            page.keyboard.up(key)
    return view
