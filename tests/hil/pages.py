"""Helpers of the browser tests and the benchmark: a synthetic gamepad, pixel counts."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from PIL import Image

#: the lead vehicle's body colour on the driving page (road.js BODY)
BODY_RGB = (30, 60, 200)

#: a standard-mapping gamepad injected before the page loads (window.__setPad from tests)
GAMEPAD_JS = """
(() => {
  const mkButton = () => ({pressed: false, touched: false, value: 0});
  const pad = {
    id: 'Synthetic Pad (STANDARD GAMEPAD)', index: 0, connected: true,
    mapping: 'standard', timestamp: performance.now(),
    axes: [0, 0, -1, 0], buttons: Array.from({length: 17}, mkButton),
    vibrationActuator: null, hapticActuators: [],
  };
  window.__pad = pad;
  window.__setPad = (axes, buttons) => {
    if (axes) axes.forEach((v, i) => { if (v !== null) pad.axes[i] = v; });
    if (buttons) Object.entries(buttons).forEach(([i, v]) => {
      const b = pad.buttons[+i]; b.value = +v; b.pressed = +v > 0.5; b.touched = +v > 0;
    });
    pad.timestamp = performance.now();
  };
  Object.defineProperty(Navigator.prototype, 'getGamepads',
    {value: () => [pad, null, null, null], configurable: true, writable: true});
})();
"""


#: resolves once two more frames are drawn (the page has shown the view it holds)
TWO_FRAMES = "new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))"
#: resolves after the next frame, once the view just received is drawn: the page's own frame
#: callback was registered in the frame before, so it runs first (callbacks run in order)
NEXT_FRAME = "new Promise((r) => requestAnimationFrame(r))"

#: the lead's brake lights when it brakes (road.js BRAKE)
BRAKE_LIGHT_RGB = (255, 32, 32)


def body_pixels(png: bytes, rgb: tuple[int, int, int] = BODY_RGB) -> int:
    """How many pixels of a screenshot show ``rgb`` (default: the lead's body colour)."""
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    return int((np.abs(img - np.array(rgb)).sum(axis=2) <= 6).sum())


def open_hil(page: Any, url: str, width: int = 480, height: int = 300) -> Any:
    """``page`` (the shared ``tab``) at ``width`` x ``height`` showing the driving page of
    ``url``, its first view received; the page."""
    page.set_viewport_size({"width": width, "height": height})
    page.goto(url + "/")
    page.wait_for_function("window.__hil.view !== null")
    return page


def new_page(browser: Any, width: int = 480, height: int = 300) -> Any:
    """A page with no way out of 127.0.0.1: any other request is aborted and remembered
    (``page.outside``)."""
    page = browser.new_page(viewport={"width": width, "height": height})
    outside: list[str] = []

    def route(r: Any) -> None:
        url = r.request.url
        if url.startswith(("http://127.0.0.1:", "ws://127.0.0.1:", "data:", "blob:")):
            r.continue_()
        else:
            outside.append(url)
            r.abort()

    page.route("**/*", route)
    page.outside = outside
    page.errors = []
    page.on("pageerror", lambda e: page.errors.append(str(e)))
    return page
