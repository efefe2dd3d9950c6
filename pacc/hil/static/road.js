// pacc hil: the road, drawn with Canvas 2D through a pinhole camera (no library, no network).
// A point (x right, y up, z ahead; m, from the eye) lands at
//   u = W/2 + f·x/z,  v = horizon + f·(EYE_M − y)/z,  f = (W/2) / tan(fov/2)  (px),
// so an object of width w at distance z is drawn f·w/z px wide: the angle it subtends in a car
// when the screen fills the participant's horizontal field of view `fov`.
// The road is a German Autobahn cross-section (RAA 2008 / RMS 1980): 3.75-m lanes, lane lines
// of 6-m dashes and 12-m gaps, 0.15 m wide, 0.30-m edge lines, a 2.5-m hard shoulder, and
// guard rail (einfache Schutzplanke) on posts every 4 m on both sides for optic flow.
'use strict';
(() => {
  const LANE_M = 3.75; const DASH_M = 6.0; const DASH_GAP_M = 12.0;
  const LINE_M = 0.15; const EDGE_M = 0.30; const SHOULDER_M = 2.5; const VERGE_L_M = 0.75;
  const POST_SPACING_M = 4.0; const POST_W_M = 0.12; const RAIL_LOW_M = 0.45; const RAIL_TOP_M = 0.75;
  const EYE_M = 1.2;                 // eye height over the road, m
  // the lead's rear is drawn at the radar gap: the eye sits at the ego car's front bumper
  const CAR = { w: 1.8, h: 1.45, l: 4.5 };          // a mid-size car, m
  const TRUCK = { w: 2.55, h: 4.0, l: 16.5 };       // an articulated lorry, m
  const NEAR_M = 0.5; const FAR_M = 400; const POSTS_FAR_M = 160;
  const EDGE_X = 1.5 * LANE_M;                      // the carriageway's edges, m (ego: middle lane)
  const RAIL_L = -(EDGE_X + VERGE_L_M + 0.3); const RAIL_R = EDGE_X + SHOULDER_M + 0.3;
  const BODY = 'rgb(30,60,200)';     // the lead's body (the tests count it)
  const POST = 'rgb(90,90,96)';      // guard-rail posts (the tests count them)
  const BRAKE = '#ff2020';           // lit brake lights (the tests count them)
  const PALETTE = ['rgb(190,190,196)', 'rgb(150,30,30)', 'rgb(40,40,44)', 'rgb(200,170,60)'];
  const LOOKS = {
    day: { sky: ['#7fb6e6', '#d4e8f6'], grass: '#55803c', road: '#5b5b5f', shoulder: '#68686c',
      line: '#f0f0f0', rail: '#b4b4ba', haze: [210, 225, 240], hazeA: 0.6, hazeM: 200, dim: [0, 0] },
    rain: { sky: ['#7d848c', '#a9aeb4'], grass: '#3f5a36', road: '#3b3c40', shoulder: '#46474b',
      line: '#cfcfcf', rail: '#8e9096', haze: [160, 166, 172], hazeA: 0.95, hazeM: 60, dim: [0.25, 0.1] },
    night: { sky: ['#03050b', '#0b1020'], grass: '#101a0e', road: '#2a2a2e', shoulder: '#303034',
      line: '#e8e8e8', rail: '#9a9aa0', haze: [2, 3, 6], hazeA: 0.97, hazeM: 60, dim: [0.85, 0.3] },
  };
  // adjacent-lane traffic: lane (-1 left, +1 right), speed against the lead's flow (m/s),
  // start position (m ahead), truck or car; it never enters the ego lane
  const TRAFFIC = [[-1, 3.0, 25, 0], [-1, 2.0, 140, 0], [-1, 4.0, -40, 0], [1, -1.5, 60, 1],
    [1, -1.0, 190, 0], [1, -2.0, 300, 1]];
  const road = window.__road = { odo: 0, f: 0, lastT: null, traffic: null, ghosts: [], events: 0,
    leadColor: BODY, leadSide: 0, leadSince: -1e9, colors: 0 };

  function reset() {
    road.odo = 0; road.lastT = null; road.ghosts = []; road.events = 0; road.leadColor = BODY;
    road.leadSide = 0; road.traffic = TRAFFIC.map(([lane, dv, x, truck]) => ({ lane, dv, x, truck }));
  }
  reset();

  function advance(s) {
    if (road.lastT !== null && s.t < road.lastT) reset();       // a new drive
    const dt = road.lastT === null ? 0 : s.t - road.lastT;
    road.lastT = s.t;
    road.odo += s.v * dt;
    for (const c of road.traffic) {
      c.x += (Math.max(0, s.v_lead + c.dv) - s.v) * dt;
      if (c.x > 340) c.x -= 420; else if (c.x < -80) c.x += 420;
    }
    road.ghosts = road.ghosts.filter((g) => {
      g.d += (g.v - s.v) * dt; return g.d > -10 && g.d < FAR_M && s.t - g.t0 < 60;
    });
    const evs = s.events || [];
    for (; road.events < evs.length; road.events += 1) {
      const [t0, kind] = evs[road.events];
      const side = road.events % 2 ? 1 : -1;
      if (road.prev && road.prev.lead) {   // the old lead drives on: ahead (cut-in) or out of lane
        const out = kind === 'cut_out' || kind === 'lead_loss';
        road.ghosts.push({ d: road.prev.gap, v: road.prev.v_lead, color: road.leadColor, t0, side: out ? side : 0 });
      }
      road.colors += 1; road.leadColor = PALETTE[road.colors % PALETTE.length];
      road.leadSide = kind === 'cut_in' ? side : 0; road.leadSince = t0;
    }
    road.prev = s;
  }

  const ease = (u) => { const c = Math.min(1, Math.max(0, u)); return c * c * (3 - 2 * c); };

  road.draw = (canvas, s, opts) => {
    const dpr = 1;   // CSS pixels: software rendering stays cheap; the geometry is the same
    const W = Math.round(canvas.clientWidth * dpr); const H = Math.round(canvas.clientHeight * dpr);
    if (canvas.width !== W || canvas.height !== H) { canvas.width = W; canvas.height = H; }
    const ctx = canvas.getContext('2d');
    const look = LOOKS[opts.weather] || LOOKS.day;
    const dash = Math.round(Math.min(120, H * 0.22));
    const hz = Math.round((H - dash) * 0.42);
    const f = road.f = (W / 2) / Math.tan(((opts.fov || 50) * Math.PI) / 360);
    if (s) advance(s);
    const t = s ? s.t : 0; const odo = road.odo;
    const u = (x, z) => W / 2 + (f * x) / z;
    const vy = (y, z) => hz + (f * (EYE_M - y)) / z;
    const quad = (pts, fill) => {
      ctx.fillStyle = fill; ctx.beginPath(); ctx.moveTo(pts[0], pts[1]);
      for (let i = 2; i < pts.length; i += 2) ctx.lineTo(pts[i], pts[i + 1]);
      ctx.fill();
    };
    const ground = (x1, x2, z1, z2, fill) => quad([u(x1, z1), vy(0, z1), u(x1, z2), vy(0, z2),
      u(x2, z2), vy(0, z2), u(x2, z1), vy(0, z1)], fill);
    // sky and verge
    const g = ctx.createLinearGradient(0, 0, 0, hz);
    g.addColorStop(0, look.sky[0]); g.addColorStop(1, look.sky[1]);
    ctx.fillStyle = g; ctx.fillRect(0, 0, W, hz);
    ctx.fillStyle = look.grass; ctx.fillRect(0, hz, W, H - hz);
    // carriageway, shoulders, markings
    ground(RAIL_L, RAIL_R, NEAR_M, FAR_M, look.shoulder);
    ground(-EDGE_X, EDGE_X, NEAR_M, FAR_M, look.road);
    ground(-EDGE_X, -EDGE_X + EDGE_M, NEAR_M, FAR_M, look.line);
    ground(EDGE_X - EDGE_M, EDGE_X, NEAR_M, FAR_M, look.line);
    const period = DASH_M + DASH_GAP_M;
    for (let k = Math.floor(odo / period); k * period - odo < 250; k += 1) {
      const z1 = Math.max(NEAR_M, k * period - odo); const z2 = k * period + DASH_M - odo;
      if (z2 <= NEAR_M) continue;
      for (const x of [-LANE_M / 2, LANE_M / 2]) ground(x - LINE_M / 2, x + LINE_M / 2, z1, z2, look.line);
    }
    // guard rail: posts every POST_SPACING_M, then the rail in front of them
    ctx.fillStyle = POST;
    for (let k = Math.ceil((odo + NEAR_M) / POST_SPACING_M); k * POST_SPACING_M - odo < POSTS_FAR_M; k += 1) {
      const z = k * POST_SPACING_M - odo;
      for (const x of [RAIL_L, RAIL_R]) {
        const x0 = u(x - POST_W_M / 2, z); ctx.fillRect(x0, vy(RAIL_TOP_M, z), u(x + POST_W_M / 2, z) - x0, (f * RAIL_TOP_M) / z);
      }
    }
    for (const x of [RAIL_L, RAIL_R]) {
      quad([u(x, NEAR_M), vy(RAIL_TOP_M, NEAR_M), u(x, FAR_M), vy(RAIL_TOP_M, FAR_M),
        u(x, FAR_M), vy(RAIL_LOW_M, FAR_M), u(x, NEAR_M), vy(RAIL_LOW_M, NEAR_M)], look.rail);
    }
    // vehicles, far to near
    const cars = [];
    if (s) {
      for (const c of road.traffic) cars.push({ x: c.lane * LANE_M, z: c.x, dims: c.truck ? TRUCK : CAR, color: c.truck ? '#e4e4e0' : PALETTE[(c.lane + 2) % PALETTE.length], brake: false });
      for (const gh of road.ghosts) cars.push({ x: gh.side * LANE_M * ease((t - gh.t0) / 3), z: gh.d, dims: CAR, color: gh.color, brake: false });
      if (s.lead) cars.push({ x: road.leadSide * LANE_M * 0.7 * (1 - ease((t - road.leadSince) / 2.5)), z: s.gap, dims: CAR, color: road.leadColor, brake: s.a_lead < -0.5, lead: true });
    }
    cars.sort((a, b) => b.z - a.z);
    // haze (rain: spray and fog; night: beyond the low beams) over the road by screen row;
    // the cars, drawn after, take the haze of their own distance and their lights glow
    const haze = `rgba(${look.haze.join(',')},`;
    const y0 = hz - 40; const yh = Math.min(H, vy(0, look.hazeM)); const yd = H - dash;
    const hg = ctx.createLinearGradient(0, y0, 0, yh);
    hg.addColorStop(0, `${haze}${look.hazeA})`); hg.addColorStop(1, `${haze}0)`);
    ctx.fillStyle = hg; ctx.fillRect(0, 0, W, yh);
    if (look.dim[0] > 0) {
      const dg = ctx.createLinearGradient(0, hz, 0, yd);
      dg.addColorStop(0, `${haze}${look.dim[0]})`); dg.addColorStop(1, `${haze}${look.dim[1]})`);
      ctx.fillStyle = dg; ctx.fillRect(0, 0, W, yd);
    }
    const fog = (z) => {   // the overlays' opacity at a car's ground row (0 by day: clear air)
      if (opts.weather === 'day') return 0;
      const y = vy(0, Math.max(z, NEAR_M));
      const a = look.hazeA * Math.min(1, Math.max(0, (yh - y) / (yh - y0)));
      const d = look.dim[0] + (look.dim[1] - look.dim[0]) * Math.min(1, Math.max(0, (y - hz) / (yd - hz)));
      return 1 - (1 - a) * (1 - d);
    };
    for (const c of cars) drawCar(ctx, c, u, vy, f, fog(c.z), look.haze, opts.weather !== 'day');
    if (opts.weather === 'rain') rain(ctx, W, H - dash);
    if (s) cluster(ctx, s, W, H, dash);
  };

  function drawCar(ctx, c, u, vy, f, fog, hazeRgb, lightsOn) {
    const { w, h, l } = c.dims; const z = c.z;
    const tint = (col) => (fog > 0 ? mix(col, hazeRgb, fog) : col);
    if (z + l < NEAR_M) return;
    const near = Math.max(NEAR_M, z);
    // the side facing the camera (a car in another lane, or drifting across)
    const sx = c.x > 0.3 ? c.x - w / 2 : c.x < -0.3 ? c.x + w / 2 : null;
    if (sx !== null) {
      ctx.fillStyle = tint(shade(c.color)); ctx.beginPath();
      ctx.moveTo(u(sx, near), vy(0.3, near)); ctx.lineTo(u(sx, z + l), vy(0.3, z + l));
      ctx.lineTo(u(sx, z + l), vy(h, z + l)); ctx.lineTo(u(sx, near), vy(h, near)); ctx.fill();
    }
    if (z < NEAR_M) return;
    const X = (x) => u(c.x + x, z); const Y = (y) => vy(y, z); const k = f / z;
    const rect = (x, y, ww, hh, fill, glow) => {
      ctx.fillStyle = glow ? fill : tint(fill); ctx.fillRect(X(x), Y(y + hh), ww * k, hh * k);
    };
    rect(-w / 2 + 0.1, 0, 0.3, 0.35, '#111');                 // wheels
    rect(w / 2 - 0.4, 0, 0.3, 0.35, '#111');
    if (c.dims === TRUCK) {
      rect(-w / 2, 0.6, w, h - 0.6, c.color); rect(-w / 2, 0.45, w, 0.15, '#333');
    } else {
      rect(-w / 2, 0.3, w, 0.7, c.color);                      // lower body: full width
      rect(-w / 2 + 0.15, 1.0, w - 0.3, h - 1.0, c.color);     // cabin
      rect(-w / 2 + 0.25, 1.05, w - 0.5, h - 1.15, '#1c2230'); // rear window
      rect(-0.26, 0.42, 0.52, 0.12, '#eee');                   // number plate
      rect(-w / 2, 0.3, w, 0.1, '#222');                       // bumper
    }
    const lit = !!c.brake; const ly = c.dims === TRUCK ? 0.5 : 0.78; const lh = c.dims === TRUCK ? 0.12 : 0.16;
    for (const x of [-w / 2, w / 2 - 0.3]) rect(x, ly, 0.3, lh, lit ? BRAKE : lightsOn ? '#c01010' : '#5a0000', lit || lightsOn);
  }

  const rgbOf = (col) => (col[0] === '#'
    ? (col.length === 4 ? [1, 2, 3].map((i) => 17 * parseInt(col[i], 16)) : [1, 3, 5].map((i) => parseInt(col.slice(i, i + 2), 16)))
    : col.slice(4, -1).split(',').map(Number));
  const shade = (col) => `rgb(${rgbOf(col).map((v) => Math.round(v * 0.7)).join(',')})`;
  const mix = (col, to, a) => `rgb(${rgbOf(col).map((v, i) => Math.round(v + (to[i] - v) * a)).join(',')})`;

  function rain(ctx, W, H) {
    let seed = Math.floor(performance.now() / 33) * 7919 + 1;
    const rnd = () => { seed = (seed * 16807) % 2147483647; return seed / 2147483647; };
    ctx.strokeStyle = 'rgba(220,225,235,0.45)'; ctx.lineWidth = 1; ctx.beginPath();
    for (let i = 0; i < 160; i += 1) {
      const x = rnd() * W; const len = 8 + rnd() * 14; const y = rnd() * (H - len);
      ctx.moveTo(x, y); ctx.lineTo(x - len * 0.15, y + len);
    }
    ctx.stroke();
  }

  // the dashboard cluster: speedometer, ACC state, set speed, gap bars, pedals, time left
  function cluster(ctx, s, W, H, D) {
    const y0 = H - D;
    ctx.fillStyle = '#15171b'; ctx.fillRect(0, y0, W, D);
    const r = D * 0.38; const cx = W * 0.16; const cy = y0 + D * 0.5;
    const a = (kmh) => Math.PI * (0.75 + (1.5 * Math.min(kmh, 200)) / 200);
    ctx.strokeStyle = '#777'; ctx.lineWidth = 2; ctx.beginPath(); ctx.arc(cx, cy, r, a(0), a(200)); ctx.stroke();
    ctx.fillStyle = '#bbb'; ctx.font = `${Math.round(D * 0.1)}px sans-serif`; ctx.textAlign = 'center';
    for (let k = 0; k <= 200; k += 40) ctx.fillText(`${k}`, cx + 0.78 * r * Math.cos(a(k)), cy + 0.78 * r * Math.sin(a(k)) + 4);
    const kmh = s.v * 3.6;
    ctx.strokeStyle = '#f33'; ctx.lineWidth = 3; ctx.beginPath(); ctx.moveTo(cx, cy);
    ctx.lineTo(cx + r * Math.cos(a(kmh)), cy + r * Math.sin(a(kmh))); ctx.stroke();
    ctx.fillStyle = '#fff'; ctx.font = `bold ${Math.round(D * 0.3)}px sans-serif`; ctx.textAlign = 'left';
    ctx.fillText(`${Math.round(kmh)} km/h`, cx + r * 1.25, y0 + D * 0.45);
    ctx.font = `${Math.round(D * 0.15)}px sans-serif`;
    const state = s.acc ? (s.main ? s.acc_state : 'OFF') : 'manual';
    ctx.fillStyle = { ACTIVE: '#5f5', OVERRIDE: '#fd5', FAULT: '#f55' }[state] || '#bbb';
    ctx.fillText(`ACC ${state}`, cx + r * 1.25, y0 + D * 0.78);
    const x2 = W * 0.62;
    ctx.fillStyle = '#ccc';
    if (s.acc) {
      ctx.fillText(s.set_speed > 0 ? `SET ${Math.round(s.set_speed * 3.6)} km/h` : 'SET —', x2, y0 + D * 0.35);
      ctx.fillText('GAP', x2, y0 + D * 0.72);
      for (let i = 0; i < 3; i += 1) {
        ctx.fillStyle = i < s.gap_setting ? '#fff' : '#444';
        ctx.fillRect(x2 + D * 0.45 + i * D * 0.16, y0 + D * (0.72 - 0.18), D * 0.11, D * 0.18);
      }
    }
    ctx.fillStyle = '#ccc'; ctx.textAlign = 'right';
    const left = Math.max(0, s.duration - s.t);
    ctx.fillText(`time left ${Math.floor(left / 60)}:${String(Math.floor(left % 60)).padStart(2, '0')}`, W - 12, y0 + D * 0.25);
    const bar = (x, label, val, col) => {
      ctx.fillStyle = '#333'; ctx.fillRect(x, y0 + D * 0.35, D * 0.14, D * 0.5); ctx.fillStyle = col;
      ctx.fillRect(x, y0 + D * (0.85 - 0.5 * val), D * 0.14, D * 0.5 * val);
      ctx.fillStyle = '#aaa'; ctx.textAlign = 'center'; ctx.fillText(label, x + D * 0.07, y0 + D * 0.98);
    };
    bar(W - D * 0.7, 'B', s.brake, '#f44'); bar(W - D * 0.4, 'A', s.accel, '#4f4');
  }
})();
