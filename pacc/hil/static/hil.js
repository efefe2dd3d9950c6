// pacc hil: the driving page. Standard APIs only (Canvas 2D, WebSocket, Gamepad, Web Audio).
'use strict';
(() => {
  const canvas = document.getElementById('view');
  const ctx = canvas.getContext('2d');
  const $ = (id) => document.getElementById(id);
  const STEP_TICKS = 10;            // lockstep: plant ticks (10 ms) per step message
  const BODY = 'rgb(30,60,200)';    // the lead's body colour (the screenshot test counts it)
  const KEYS = { accel: ['ArrowUp'], brake: ['ArrowDown'] };
  const BTN_KEYS = { m: 'main', s: 'set', r: 'resume', c: 'cancel', g: 'gap' };
  const DEFAULT_MAP = { accel: { button: 7 }, brake: { button: 6 }, set: { button: 0 },
    resume: { button: 1 }, cancel: { button: 2 }, main: { button: 3 }, gap: { button: 5 } };
  const hil = window.__hil = { view: null, frames: 0, frameTimes: [], manual: false, waiters: {},
    sent: 0, nextId: 1, chimes: 0, cueShown: 0 };
  let ws = null; let inflight = false; let keysHeld = { accel: false, brake: false };
  let mapping = null; let lastPad = null; let padButtons = {}; let cues = 0; let odo = 0;
  let lastT = null; let audio = null; let cueUntil = 0; let shownSeq = -1;

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
  function chime() {
    hil.chimes += 1;
    try {
      audio = audio || new AudioContext();
      [0, 0.18].forEach((dt, i) => {
        const o = audio.createOscillator(); const g = audio.createGain();
        o.frequency.value = i ? 660 : 880; g.gain.value = 0.2;
        o.connect(g).connect(audio.destination);
        o.start(audio.currentTime + dt); o.stop(audio.currentTime + dt + 0.14);
      });
    } catch (e) { /* no audio device: the visual cue stays */ }
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

  function show(v) {
    if (v.seq === shownSeq && v.phase === 'driving') return;
    shownSeq = v.seq;
    const ov = $('overlay'); const step = v.step;
    const set = (title, text, action, label) => {
      ov.classList.remove('hidden'); $('title').textContent = title; $('text').textContent = text;
      const b = $('primary'); b.dataset.action = action || ''; b.textContent = label || '';
      b.classList.toggle('hidden', !action);
    };
    $('rating').classList.add('hidden');
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
      set(v.label, v.acc ? 'Drive off, then press S to switch the cruise control on (set). Follow the car ahead; press a pedal '
        + 'whenever you are not happy with the gap.' : 'Drive by hand (cruise control off): follow the car ahead '
        + 'at a distance you like.', 'start', 'Start (Enter)');
    } else if (v.phase === 'syncing') set('Drive finished', 'Saving your drive… please wait.', null);
    else if (v.phase === 'paused') set('Paused', 'The connection was lost; the car is held still.', 'continue', 'Continue (Enter)');
    else if (v.phase === 'after') {
      set('Drive finished', v.message || (v.rate ? 'How was this drive? (optional)' : ''), 'continue', 'Continue (Enter)');
      if (v.rate) { $('rating').classList.remove('hidden'); document.querySelectorAll('#rating input').forEach((i) => { i.checked = false; }); }
    } else ov.classList.add('hidden');
  }

  function draw(s) {
    const W = canvas.width; const H = canvas.height; const hz = H * 0.42; const F = H * 1.2; const camH = 1.2;
    ctx.fillStyle = '#8cc4f0'; ctx.fillRect(0, 0, W, hz);
    ctx.fillStyle = '#3d7a3a'; ctx.fillRect(0, hz, W, H - hz);
    const roadHalf = 5.5; const x0 = W / 2;
    const sy = (d) => hz + (F * camH) / d;
    ctx.fillStyle = '#555';
    ctx.beginPath(); ctx.moveTo(x0 - (F * roadHalf) / 1.5, sy(1.5)); ctx.lineTo(x0, hz);
    ctx.lineTo(x0 + (F * roadHalf) / 1.5, sy(1.5)); ctx.fill();
    ctx.fillStyle = '#eee';
    for (let d = 3 - (odo % 12); d < 300; d += 12) {
      if (d < 2) continue;
      const y1 = sy(d); const y2 = sy(d + 5); const w1 = (F * 0.12) / d;
      ctx.beginPath(); ctx.moveTo(x0 - (F * 1.8) / d, y1); ctx.lineTo(x0 - (F * 1.8) / (d + 5), y2);
      ctx.lineTo(x0 - (F * 1.8) / (d + 5) + w1, y2); ctx.lineTo(x0 - (F * 1.8) / d + w1, y1); ctx.fill();
    }
    if (s) {
      const d = Math.max(1.5, s.gap + 2.0);   // gap + the bonnet's length to the eye, m
      const w = (F * 1.8) / d; const h = (F * 1.4) / d; const yb = sy(d);
      ctx.fillStyle = BODY; ctx.fillRect(x0 - w / 2, yb - h, w, h);
      ctx.fillStyle = '#223'; ctx.fillRect(x0 - w * 0.4, yb - h * 0.95, w * 0.8, h * 0.3);
      ctx.fillStyle = s.a_lead < -0.5 ? '#ff2020' : '#5a0000';
      ctx.fillRect(x0 - w / 2, yb - h * 0.55, w * 0.18, h * 0.14);
      ctx.fillRect(x0 + w / 2 - w * 0.18, yb - h * 0.55, w * 0.18, h * 0.14);
      hud(s, W, H);
    }
  }
  function hud(s, W, H) {
    ctx.fillStyle = 'rgba(0,0,0,0.6)'; ctx.fillRect(0, H - 90, W, 90);
    ctx.fillStyle = '#fff'; ctx.font = 'bold 44px sans-serif'; ctx.textAlign = 'left';
    ctx.fillText(`${Math.round(s.v * 3.6)} km/h`, 20, H - 35);
    ctx.font = '18px sans-serif';
    const state = s.acc ? (s.main ? s.acc_state : 'OFF') : 'manual';
    ctx.fillStyle = state === 'ACTIVE' ? '#5f5' : state === 'OVERRIDE' ? '#fd5' : '#ccc';
    ctx.fillText(`ACC ${state}`, 250, H - 55);
    ctx.fillStyle = '#ccc';
    ctx.fillText(s.acc ? `set ${Math.round(s.set_speed * 3.6)} km/h` : '', 250, H - 28);
    ctx.fillText('gap', 430, H - 55);
    for (let i = 0; i < 3; i += 1) { ctx.fillStyle = i < s.gap_setting ? '#fff' : '#555'; ctx.fillRect(470 + i * 16, H - 70, 12, 18); }
    const bar = (x, label, val, col) => {
      ctx.fillStyle = '#333'; ctx.fillRect(x, H - 80, 18, 60); ctx.fillStyle = col;
      ctx.fillRect(x, H - 20 - 60 * val, 18, 60 * val); ctx.fillStyle = '#ccc'; ctx.fillText(label, x - 2, H - 2);
    };
    bar(W - 90, 'B', s.brake, '#f44'); bar(W - 50, 'A', s.accel, '#4f4');
    ctx.fillStyle = '#ccc'; ctx.fillText(`${Math.max(0, s.duration - s.t).toFixed(0)} s`, W - 190, H - 55);
  }

  function frame(ts) {
    hil.frames += 1; hil.frameTimes.push(ts); if (hil.frameTimes.length > 120) hil.frameTimes.shift();
    pollPad();
    const v = hil.view; const s = v && v.state;
    if (s) {
      if (lastT !== null && s.t >= lastT) odo += s.v * (s.t - lastT);
      lastT = s.t;
      if (s.cues > cues) { chime(); cueUntil = ts + 1500; }
      cues = s.cues;
    }
    $('cue').classList.toggle('hidden', ts > cueUntil);
    if (ts <= cueUntil) hil.cueShown += 1;
    draw(v && v.phase !== 'ready' ? s : null);
    if (!inflight && v) {
      if (v.lockstep && v.phase === 'driving') { if (!hil.manual) { inflight = send({ t: 'step', n: STEP_TICKS }); } }
      else inflight = send({ t: 'frame' });
    }
    requestAnimationFrame(frame);
  }
  requestAnimationFrame(frame);
})();
