// pacc hil: gamepad calibration. Captures an axis (rest and full travel) or a button per control.
'use strict';
(() => {
  const CONTROLS = ['accel', 'brake', 'set', 'resume', 'cancel', 'main', 'gap'];
  const $ = (id) => document.getElementById(id);
  const cal = window.__cal = { mapping: {}, capturing: null };
  let base = null; let best = null;
  fetch('/api/mapping').then((r) => r.json()).then((m) => { if (m) cal.mapping = m; render(); });
  const pad = () => Array.from(navigator.getGamepads ? navigator.getGamepads() : []).find((p) => p && p.connected);
  function render() {
    const t = $('controls');
    while (t.rows.length > 1) t.deleteRow(1);
    for (const c of CONTROLS) {
      const r = t.insertRow(); r.insertCell().textContent = c;
      const m = cal.mapping[c];
      r.insertCell().textContent = !m ? '—' : ('axis' in m ? `axis ${m.axis} (${m.rest.toFixed(2)} → ${m.full.toFixed(2)})` : `button ${m.button}`);
      const b = document.createElement('button'); b.type = 'button'; b.id = `cap-${c}`;
      b.textContent = cal.capturing === c ? 'waiting…' : 'Capture';
      b.onclick = () => cal.capture(c); r.insertCell().appendChild(b);
    }
  }
  cal.capture = (c) => {
    const p = pad(); if (!p) { $('status').textContent = 'no gamepad'; return; }
    cal.capturing = c; best = null;
    base = { axes: p.axes.slice(), buttons: p.buttons.map((b) => b.value) };
    render();
  };
  function poll() {
    const p = pad();
    if (p) {
      $('pad').textContent = `Gamepad: ${p.id}`;
      $('live').textContent = `axes ${p.axes.map((a) => a.toFixed(2)).join(' ')}\nbuttons ${p.buttons.map((b) => b.value.toFixed(1)).join(' ')}`;
    }
    if (p && cal.capturing) {
      p.axes.forEach((a, i) => {
        const dev = Math.abs(a - base.axes[i]);
        if (dev > 0.5 && (!best || (best.axis === i ? dev > Math.abs(best.full - best.rest) : !('axis' in best) || dev > Math.abs(best.full - best.rest) + 0.2))) {
          best = { axis: i, rest: base.axes[i], full: a };
        }
      });
      p.buttons.forEach((b, i) => { if (!best && b.pressed && base.buttons[i] < 0.5) best = { button: i }; });
      const released = best && ('axis' in best ? Math.abs(p.axes[best.axis] - best.rest) < 0.2 : !p.buttons[best.button].pressed);
      if (released) { cal.mapping[cal.capturing] = best; cal.capturing = null; best = null; render(); }
    }
    requestAnimationFrame(poll);
  }
  $('save').onclick = () => fetch('/api/mapping', { method: 'PUT', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(cal.mapping) })
    .then((r) => r.json()).then((j) => { $('status').textContent = j.saved ? `saved (${j.saved})` : JSON.stringify(j); cal.saved = !!j.saved; });
  render(); requestAnimationFrame(poll);
})();
