// pacc hil: the driving page. Standard APIs only (WebSocket, Gamepad, Web Audio); the road is
// drawn by road.js (Canvas 2D, pinhole projection).
'use strict';
(() => {
  const canvas = document.getElementById('view');
  const $ = (id) => document.getElementById(id);
  const STEP_TICKS = 10;            // lockstep: plant ticks (10 ms) per step message
  const KEYS = { accel: ['ArrowUp'], brake: ['ArrowDown'] };
  const BTN_KEYS = { m: 'main', s: 'set', r: 'resume', c: 'cancel', g: 'gap' };
  const DEFAULT_MAP = { accel: { button: 7 }, brake: { button: 6 }, set: { button: 0 },
    resume: { button: 1 }, cancel: { button: 2 }, main: { button: 3 }, gap: { button: 5 } };
  const FCW_TTC_S = 2.6;            // forward-collision warning below this time to collision
  const hil = window.__hil = { view: null, frames: 0, frameTimes: [], manual: false, waiters: {},
    sent: 0, nextId: 1, chimes: 0, cueShown: 0, warnings: 0, sound: false, drawMs: [] };
  const road = window.__road;
  let ws = null; let inflight = false; const keysHeld = { accel: false, brake: false };
  let mapping = null; let lastPad = null; const padButtons = {}; let cues = 0;
  let audio = null; let engine = null; let cueUntil = 0; let toastUntil = 0; let lastMain = null;
  let shownKey = ''; let ratedKey = ''; let lastBeep = 0;

  fetch('/api/mapping').then((r) => r.json()).then((m) => { mapping = m; }).catch(() => {});

  function send(msg) {
    if (ws && ws.readyState === 1) { ws.send(JSON.stringify(msg)); hil.sent += 1; return true; }
    return false;
  }
  function connect() {
    ws = new WebSocket(`ws://${location.host}/ws`);
    ws.onmessage = (ev) => {
      const v = JSON.parse(ev.data); hil.view = v; show(v);
      if (v.id !== undefined) { const f = hil.waiters[v.id]; delete hil.waiters[v.id]; if (f) f(v); } else inflight = false;
    };
    ws.onclose = () => { inflight = false; setTimeout(connect, 500); };
  }
  connect();

  // lockstep test hook: one step of n ticks, resolves with the view after it
  const request = (msg) => new Promise((resolve) => {
    const id = hil.nextId; hil.nextId += 1; hil.waiters[id] = resolve; send(Object.assign({ id }, msg));
  });
  hil.step = (n) => request({ t: 'step', n: n || STEP_TICKS });
  hil.action = (name, extra) => request(Object.assign({ t: 'action', name }, extra || {}));
  hil.fps = () => {
    const t = hil.frameTimes; if (t.length < 2) return 0;
    return (t.length - 1) / ((t[t.length - 1] - t[0]) / 1000);
  };

  function sendKeys() { if (!lastPad) send({ t: 'in', ka: keysHeld.accel, kb: keysHeld.brake }); }
  function tone(freqs, gain, len) {
    try {
      audio = audio || new AudioContext();
      freqs.forEach((f, i) => {
        const o = audio.createOscillator(); const g = audio.createGain();
        o.frequency.value = f; g.gain.value = gain;
        o.connect(g).connect(audio.destination);
        o.start(audio.currentTime + i * (len + 0.04)); o.stop(audio.currentTime + i * (len + 0.04) + len);
      });
    } catch (e) { /* no audio device: the visual cue stays */ }
  }
  // engine sound (E toggles): a sawtooth whose pitch follows the speed (speed perception)
  function engineSound(v) {
    if (!hil.sound || !audio) { if (engine) { engine.g.gain.value = 0; } return; }
    if (!engine) {
      const o = audio.createOscillator(); const g = audio.createGain(); const lp = audio.createBiquadFilter();
      o.type = 'sawtooth'; lp.frequency.value = 400; o.connect(lp).connect(g).connect(audio.destination);
      o.start(); engine = { o, g };
    }
    engine.o.frequency.value = hil.engineHz = 35 + 4.0 * ((v * 3.6) % 50);   // a 50-km/h "gear"
    engine.g.gain.value = 0.05;
  }
  function primary() {
    const v = hil.view; if (!v || !v.step) return;
    const b = $('primary'); if (b.dataset.action) doAction(b.dataset.action);
  }
  function doAction(name) {
    const extra = {};
    if (name === 'continue' && hil.view && hil.view.phase === 'after') {
      document.querySelectorAll('#rating input:checked').forEach((i) => { extra[i.name] = +i.value; });
    }
    send(Object.assign({ t: 'action', name }, extra));
  }
  addEventListener('keydown', (e) => {
    if (audio === null) { try { audio = new AudioContext(); } catch (err) { audio = undefined; } }
    for (const k of Object.keys(KEYS)) {
      if (KEYS[k].includes(e.key)) { e.preventDefault(); if (!keysHeld[k]) { keysHeld[k] = true; sendKeys(); } return; }
    }
    if (e.repeat) return;
    const b = BTN_KEYS[e.key.toLowerCase()];
    if (b) { send({ t: 'btn', name: b }); return; }
    if (e.key.toLowerCase() === 'e') { hil.sound = !hil.sound; return; }
    if (e.key === 'Enter') primary();
  });
  addEventListener('keyup', (e) => {
    for (const k of Object.keys(KEYS)) if (KEYS[k].includes(e.key)) { keysHeld[k] = false; sendKeys(); }
  });
  $('primary').addEventListener('click', primary);
  document.querySelectorAll('.scale').forEach((div) => {
    for (let i = 1; i <= 7; i += 1) {
      const l = document.createElement('label');
      l.innerHTML = `<input type="radio" name="${div.dataset.name}" value="${i}">${i}`;
      div.appendChild(l);
    }
  });

  function axisValue(pad, spec) {
    if (!spec) return 0;
    if ('button' in spec) { const b = pad.buttons[spec.button]; return b ? b.value : 0; }
    const a = pad.axes[spec.axis]; if (a === undefined) return 0;
    return Math.min(1, Math.max(0, (a - spec.rest) / (spec.full - spec.rest)));
  }
  function pollPad() {
    const pads = navigator.getGamepads ? navigator.getGamepads() : [];
    const pad = Array.from(pads || []).find((p) => p && p.connected);
    if (!pad) { if (lastPad) { lastPad = null; sendKeys(); } return; }
    const m = mapping || DEFAULT_MAP;
    const pa = axisValue(pad, m.accel); const pb = axisValue(pad, m.brake);
    if (!lastPad || Math.abs(pa - lastPad[0]) > 1e-3 || Math.abs(pb - lastPad[1]) > 1e-3) {
      send({ t: 'in', pa, pb }); lastPad = [pa, pb];
    }
    for (const name of ['set', 'resume', 'cancel', 'main', 'gap']) {
      const spec = m[name]; if (!spec || !('button' in spec)) continue;
      const b = pad.buttons[spec.button]; const down = !!(b && b.pressed);
      if (down && !padButtons[name]) send({ t: 'btn', name });
      padButtons[name] = down;
    }
  }

  // the overlay is rebuilt only when what it says changes (the per-frame replies repeat it),
  // and the rating radios are cleared only when a new drive's rating opens
  function show(v) {
    const step = v.step;
    const key = `${v.seq}|${v.phase}|${step ? step.id : ''}`;
    if (key === shownKey) return;
    shownKey = key;
    const ov = $('overlay');
    const set = (title, text, action, label) => {
      ov.classList.remove('hidden'); $('title').textContent = title; $('text').textContent = text;
      const b = $('primary'); b.dataset.action = action || ''; b.textContent = label || '';
      b.classList.toggle('hidden', !action);
    };
    const rating = v.phase === 'after' && v.rate;
    $('rating').classList.toggle('hidden', !rating);
    if (rating && ratedKey !== step.id) {
      ratedKey = step.id;
      document.querySelectorAll('#rating input').forEach((i) => { i.checked = false; });
    }
    if (!step) { set('Session complete', 'Thank you.', null); return; }
    if (step.kind === 'consent') {
      set('Consent', 'You will drive a simulated car behind another car, by hand and with an adaptive cruise '
        + 'control. Your pedal and button inputs are recorded without your name. You may stop at any time.',
      'consent', 'I agree (Enter)');
    } else if (step.kind === 'break') set('Break', 'Take a short break. Continue when you are ready.', 'continue', 'Continue (Enter)');
    else if (step.kind === 'done') set(v.label, 'The session is complete. Thank you!', null);
    else if (step.kind === 'learn') {
      if (v.phase === 'learning') set(v.label, 'Uploading your drives and learning… please wait.', null);
      else set(v.label, v.message || 'Your manual drives go to the cloud, which learns your gap preference.', 'start',
        v.phase === 'failed' ? 'Try again (Enter)' : 'Upload and learn (Enter)');
    } else if (v.phase === 'ready') {
      const brake = v.brake_mode === 'cancel' ? 'The brake switches the cruise control off (S sets it again).'
        : 'Braking takes over only while you brake.';
      const at = v.set_kmh ? `to ${Math.round(v.set_kmh)} km/h (it follows the car ahead below that)` : 'at your current speed';
      set(v.label, (v.acc ? `The car starts rolling behind the car ahead. Press S to set the cruise control ${at}; `
        + `G changes its gap. ${brake} Press a pedal whenever you are not happy with the gap.`
        : 'Drive by hand (cruise control off): follow the car ahead at a distance you like.')
        + (v.message ? ` — ${v.message}` : ''), 'start', 'Start (Enter)');
    } else if (v.phase === 'syncing') set('Drive finished', 'Saving your drive… please wait.', null);
    else if (v.phase === 'paused') set('Paused', 'The connection was lost; the car is held still.', 'continue', 'Continue (Enter)');
    else if (v.phase === 'after') {
      set('Drive finished', v.message || (v.rate ? 'How was this drive? (optional)' : ''), 'continue', 'Continue (Enter)');
    } else ov.classList.add('hidden');
  }

  // forward-collision warning: closing in on the lead with under FCW_TTC_S s to collision
  function warning(s) {
    if (!s || !s.lead || s.collided) return false;
    const closing = s.v - s.v_lead;
    return s.gap < 2.0 || (closing > 0.5 && s.gap / closing < FCW_TTC_S);
  }

  function frame(ts) {
    hil.frames += 1; hil.frameTimes.push(ts); if (hil.frameTimes.length > 120) hil.frameTimes.shift();
    pollPad();
    const v = hil.view; const s = v && v.phase !== 'ready' ? v.state : null;
    if (s) {
      if (s.cues > cues) { hil.chimes += 1; tone([880, 660], 0.2, 0.14); cueUntil = ts + 1500; }
      cues = s.cues;
      if (lastMain !== null && s.main !== lastMain) toastUntil = ts + 2000;
      lastMain = s.main;
    }
    const warn = warning(s) && v.phase === 'driving';
    if (warn) { hil.warnings += 1; if (ts - lastBeep > 400) { lastBeep = ts; tone([1400], 0.15, 0.08); } }
    $('warn').classList.toggle('hidden', !warn);
    $('cue').classList.toggle('hidden', ts > cueUntil);
    if (ts <= cueUntil) hil.cueShown += 1;
    const toast = $('toast'); const say = s && ts <= toastUntil
      ? (s.main ? 'Cruise control ON (main switch)' : 'Cruise control OFF (M switches it on)') : '';
    if (toast.textContent !== say) { toast.textContent = say; toast.classList.toggle('hidden', !say); }
    const t0 = performance.now();
    road.draw(canvas, s, v ? { fov: v.fov, weather: v.weather } : { fov: 50, weather: 'day' });
    hil.drawMs.push(performance.now() - t0); if (hil.drawMs.length > 600) hil.drawMs.shift();
    engineSound(s ? s.v : 0);
    if (!inflight && v) {
      if (v.lockstep && v.phase === 'driving') { if (!hil.manual) { inflight = send({ t: 'step', n: STEP_TICKS }); } }
      else inflight = send({ t: 'frame' });
    }
    requestAnimationFrame(frame);
  }
  requestAnimationFrame(frame);
})();
