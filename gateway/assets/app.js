// handgate dashboard page (docs/dashboard.md). Plain JavaScript, no build step; the only
// library is the vendored uPlot (assets/vendor/). Speaks the WebSocket protocol of
// docs/dashboard.md ("Protocol"): hello, status, samples, pads, refused; sends command/safe
// frames only when hello.commands is true.
(function () {
  'use strict';

  /** Seconds of history in each chart. */
  const WINDOW_S = 10;
  /** A chart scrolled out of view is redrawn at most this often (ms); in view, on every
   *  animation frame with new samples. */
  const OFFSCREEN_REDRAW_MS = 500;
  /** The protocol version this page speaks (hello.protocol, docs/dashboard.md). */
  const PROTOCOL = 1;
  /** Reconnect delays after a close, ms (the last one repeats). */
  const BACKOFF_MS = [250, 500, 1000, 2000];
  /** While a device's "command" toggle is on, its slider value is re-sent this often (10 Hz). */
  const COMMAND_PERIOD_MS = 100;
  /** Joint colours (measured solid, commanded dashed in the same colour). */
  const PALETTE = ['#4e79a7', '#f28e2b', '#e15759', '#59a14f', '#b07aa1', '#76b7b2', '#edc948',
    '#9c755f', '#ff9da7', '#17becf', '#bcbd22', '#7f7f7f'];
  /** Pressure colour scale, 0..1 (dark blue, teal, yellow, red). */
  const SCALE_STOPS = [[0, [30, 42, 80]], [0.3, [35, 120, 170]], [0.55, [70, 180, 170]],
    [0.8, [245, 190, 70]], [1, [215, 40, 40]]];

  // --------------------------------------------------------------------------------------
  // Test and bench hook (tests/browser/dashboard.mjs, bench/dashboard_tabs.mjs).

  const hook = {
    /** True between a connection's hello and its close. */
    connected: false,
    /** The last hello frame. */
    hello: null,
    /** Frames received, by type. */
    frames: { hello: 0, status: 0, samples: 0, pads: 0, refused: 0, other: 0 },
    /** Frames the page sent (stays 0 when hello.commands is false). */
    sent: 0,
    /** Closed connections (each followed by a reconnect). */
    closes: 0,
    /** Refused frames, newest last (at most 50). */
    refused: [],
    /** Chart redraws per device since hello. */
    redraws: {},
    /** Animation frames that drew something, and those per second over the last second. */
    drawFrames: 0,
    fps: 0,
    /** Time spent drawing (charts and pads) in those frames, ms: total and the longest. */
    drawMs: 0,
    drawMsMax: 0,
    /** Time of the newest samples frame, s since the gateway started. */
    t: 0,
    /** The last pads frame's arrays of a device (one per pad), or null. */
    pads: (device) => {
      const d = devices.get(device);
      return d && d.padValues ? d.padValues : null;
    },
    /** Device names from hello, in hello's order. */
    devices: () => (hook.hello ? hook.hello.devices.map((d) => d.name) : []),
    /** The last measured value of joint j handed to the device's uPlot chart (its data), or
     *  null (no chart, no point, no reading). */
    plotted: (device, j) => {
      const d = devices.get(device);
      if (!d || !d.chart || !d.chart.data) return null;
      const col = d.chart.data[1 + 2 * j];
      return col && col.length ? col[col.length - 1] : null;
    },
  };
  window.__handgate = hook;

  // --------------------------------------------------------------------------------------
  // Small DOM helpers.

  const $ = (sel) => document.querySelector(sel);
  function el(tag, attrs, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === undefined || v === null || v === false) continue;
      if (k === 'class') e.className = v;
      else if (k === 'text') e.textContent = v;
      else e.setAttribute(k, v === true ? '' : v);
    }
    for (const c of children) {
      if (c !== null && c !== undefined) e.append(c);
    }
    return e;
  }
  function setText(node, text) {
    if (node.textContent !== text) node.textContent = text;
  }
  function fixed(v, digits) {
    return typeof v === 'number' && Number.isFinite(v) ? v.toFixed(digits) : '—';
  }
  function cssVar(name) {
    return getComputedStyle(document.documentElement).getPropertyValue(name).trim();
  }

  // --------------------------------------------------------------------------------------
  // Per-device sample history: a ring buffer of (t, q[0..n], cmd[0..n]); NaN = no value.

  class Ring {
    constructor(capacity, joints) {
      this.cap = capacity;
      this.n = joints;
      this.t = new Float64Array(capacity);
      this.v = new Float64Array(capacity * joints * 2);
      this.head = 0;
      this.len = 0;
    }
    push(t, q, cmd) {
      const s = this.head;
      const n = this.n;
      const base = s * n * 2;
      this.t[s] = t;
      for (let j = 0; j < n; j++) {
        const a = q ? q[j] : null;
        const b = cmd ? cmd[j] : null;
        this.v[base + j] = typeof a === 'number' ? a : NaN;
        this.v[base + n + j] = typeof b === 'number' ? b : NaN;
      }
      this.head = (s + 1) % this.cap;
      if (this.len < this.cap) this.len++;
    }
    /** Storage slot of the k-th oldest entry. */
    slot(k) {
      return (this.head - this.len + k + this.cap) % this.cap;
    }
    /** Index (oldest = 0) of the first entry at or after time `from`. */
    firstFrom(from) {
      let lo = 0;
      let hi = this.len;
      while (lo < hi) {
        const m = (lo + hi) >> 1;
        if (this.t[this.slot(m)] < from) lo = m + 1;
        else hi = m;
      }
      return lo;
    }
    clear() {
      this.head = 0;
      this.len = 0;
    }
  }

  // --------------------------------------------------------------------------------------
  // State.

  let ws = null;
  let attempt = 0;
  let reconnectTimer = null;
  let hello = null;
  /** name -> device view (card, chart, ring, pads, controls). */
  const devices = new Map();
  /** name -> fleet table row cells. */
  const rows = new Map();
  /** Newest samples time, s (the right edge of every chart). */
  let tNow = 0;
  let rafPending = false;
  let fpsWindowStart = performance.now();
  let fpsWindowFrames = 0;

  const scaleLut = buildScaleLut();
  /** Which charts are on screen (or nearly): the others are redrawn less often. */
  const visibility = new IntersectionObserver((entries) => {
    for (const e of entries) {
      const d = [...devices.values()].find((x) => x.chartBox === e.target);
      if (!d) continue;
      d.visible = e.isIntersecting;
      if (d.visible && d.dirty) requestDraw();
    }
  }, { rootMargin: '200px' });

  // --------------------------------------------------------------------------------------
  // Connection.

  function wsUrl() {
    const u = new URL('ws', window.location.href);
    u.protocol = u.protocol === 'https:' ? 'wss:' : 'ws:';
    u.search = '';
    u.hash = '';
    return u.href;
  }

  function setConnected(up, detail) {
    hook.connected = up;
    const c = $('#conn');
    setText(c, up ? 'connected' : 'disconnected');
    c.className = 'conn ' + (up ? 'up' : 'down');
    document.body.classList.toggle('offline', !up);
    setText($('#conn-detail'), detail || '');
  }

  function connect() {
    reconnectTimer = null;
    let sock;
    try {
      sock = new WebSocket(wsUrl());
    } catch (e) {
      scheduleReconnect(String(e));
      return;
    }
    ws = sock;
    sock.onmessage = (ev) => {
      if (sock !== ws) return;
      let f;
      try {
        f = JSON.parse(ev.data);
      } catch (e) {
        hook.frames.other++;
        return;
      }
      onFrame(f);
    };
    sock.onerror = () => {
      if (sock === ws) setConnected(false, '');
    };
    sock.onclose = () => {
      if (sock !== ws) return;
      ws = null;
      hello = null; // nothing is sent until the next hello says what is allowed
      hook.closes++;
      stopAllCommanding();
      scheduleReconnect('');
    };
  }

  function scheduleReconnect(why) {
    if (reconnectTimer !== null) return;
    const delay = BACKOFF_MS[Math.min(attempt, BACKOFF_MS.length - 1)];
    attempt++;
    setConnected(false, `reconnecting in ${(delay / 1000).toFixed(2)} s${why ? ' (' + why + ')' : ''}`);
    reconnectTimer = setTimeout(connect, delay);
  }

  function send(frame) {
    if (!hello || !hello.commands || !ws || ws.readyState !== WebSocket.OPEN) return false;
    ws.send(JSON.stringify(frame));
    hook.sent++;
    return true;
  }

  function onFrame(f) {
    switch (f.type) {
      case 'hello':
        hook.frames.hello++;
        onHello(f);
        break;
      case 'status':
        hook.frames.status++;
        onStatus(f);
        break;
      case 'samples':
        hook.frames.samples++;
        onSamples(f);
        break;
      case 'pads':
        hook.frames.pads++;
        onPads(f);
        break;
      case 'refused':
        hook.frames.refused++;
        onRefused(f);
        break;
      default:
        hook.frames.other++;
    }
  }

  // --------------------------------------------------------------------------------------
  // hello: (re)build the page for this fleet.

  function onHello(h) {
    attempt = 0;
    hello = h;
    hook.hello = h;
    teardown();
    const mode = $('#mode');
    mode.hidden = false;
    mode.className = 'badge ' + (h.commands ? 'warn' : '');
    setText(mode, h.commands ? 'commands enabled' : 'read-only');
    const capacity = Math.min(20000, Math.max(64, Math.ceil((h.sample_hz || 50) * WINDOW_S * 1.5) + 16));
    const cards = $('#cards');
    const tbody = $('#fleet tbody');
    for (const dev of h.devices) {
      const fronts = (h.fronts || []).filter((f) => (f.devices || []).includes(dev.name));
      const d = buildCard(dev, fronts, capacity, h.commands);
      devices.set(dev.name, d);
      hook.redraws[dev.name] = 0;
      cards.append(d.card);
      d.chart = buildChart(d);
      tbody.append(fleetRow(dev.name).tr);
    }
    tNow = 0;
    setConnected(true, h.protocol === PROTOCOL ? ''
      : `the gateway speaks protocol ${h.protocol}, this page ${PROTOCOL}: reload the page`);
  }

  function teardown() {
    stopAllCommanding();
    for (const d of devices.values()) {
      if (d.resize) d.resize.disconnect();
      visibility.unobserve(d.chartBox);
      if (d.padResize) d.padResize.disconnect();
      if (d.chart) d.chart.destroy();
      d.card.remove();
    }
    devices.clear();
    hook.redraws = {};
    for (const r of rows.values()) r.tr.remove();
    rows.clear();
  }

  function buildCard(dev, fronts, capacity, commands) {
    const joints = dev.joints || [];
    const d = {
      name: dev.name,
      info: dev,
      joints,
      ring: new Ring(capacity, joints.length),
      data: [[]].concat(joints.flatMap(() => [[], []])),
      dirty: false,
      visible: true,
      lastDraw: -Infinity,
      chart: null,
      pads: dev.pads || [],
      padValues: null,
      padsDirty: false,
      commanding: null,
    };
    const badges = el('span', { class: 'card-badges' });
    d.freshBadge = el('span', { class: 'badge', text: '…' });
    d.safeBadge = el('span', { class: 'badge bad', text: 'safe state', hidden: true });
    // "Reports but does not move" (docs/adapters.md, "Motion"): the verdict and its joint.
    d.motionBadge = el('span', { class: 'badge bad', 'data-motion': '', hidden: true });
    badges.append(d.freshBadge, ' ', d.safeBadge, ' ', d.motionBadge);
    const sub = [dev.kind, dev.side, dev.backend].filter(Boolean).join(' · ');
    const topics = fronts.map((f) => f.cmd_topic || f.state_topic).filter(Boolean);
    const head = el('div', { class: 'card-head' },
      el('h2', { class: 'mono', text: dev.name }),
      el('span', { class: 'meta', text: sub }),
      badges,
      el('span', { class: 'spacer' }),
      el('span', { class: 'meta mono', text: topics.join('  '), title: 'fronts serving this device' }));
    d.chartBox = el('div', { class: 'chart' });
    const body = el('div', { class: 'card-body' }, d.chartBox);
    if (d.pads.length) body.append(buildPads(d));
    const legend = el('div', { class: 'legend' },
      el('span', { class: 'solid' }, el('i'), 'measured'),
      el('span', { class: 'dash' }, el('i'), 'commanded'),
      ...joints.map((j, i) => el('span', { title: `${j.name}: ${fixed(j.min, 3)} … ${fixed(j.max, 3)} rad` },
        el('i', { style: `background:${PALETTE[i % PALETTE.length]}` }), j.name)));
    d.owner = el('div', { class: 'meta' });
    d.refusedLine = el('div', { class: 'refused', role: 'alert' });
    d.card = el('article', { class: 'panel card', 'data-device': dev.name }, head, body, legend, d.owner);
    if (commands) d.card.append(buildControls(d));
    d.card.append(d.refusedLine);
    return d;
  }

  function buildChart(d) {
    const muted = cssVar('--muted') || '#666';
    const grid = cssVar('--grid') || 'rgba(0,0,0,0.08)';
    let lo = Infinity;
    let hi = -Infinity;
    for (const j of d.joints) {
      if (typeof j.min === 'number') lo = Math.min(lo, j.min);
      if (typeof j.max === 'number') hi = Math.max(hi, j.max);
    }
    const yRange = Number.isFinite(lo) && Number.isFinite(hi) && hi > lo
      ? [lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)]
      : null;
    const series = [{ label: 't' }];
    d.joints.forEach((j, i) => {
      const c = PALETTE[i % PALETTE.length];
      series.push({ label: j.name, stroke: c, width: 1.6, points: { show: false } });
      series.push({ label: j.name + ' cmd', stroke: c, width: 1.1, dash: [5, 4], points: { show: false } });
    });
    const axis = { stroke: muted, grid: { stroke: grid, width: 1 }, ticks: { stroke: grid, width: 1 } };
    const opts = {
      width: Math.max(200, d.chartBox.clientWidth || 480),
      height: 210,
      legend: { show: false },
      cursor: { drag: { x: false, y: false }, points: { show: false } },
      scales: {
        x: { time: false, range: [-WINDOW_S, 0] },
        y: yRange ? { range: yRange } : {},
      },
      axes: [
        Object.assign({}, axis, {
          values: (u, vals) => vals.map((v) => (v === 0 ? 'now' : `${v} s`)),
        }),
        Object.assign({}, axis, { label: 'rad', size: 46, labelSize: 14 }),
      ],
      series,
    };
    const chart = new uPlot(opts, d.data, d.chartBox);
    d.resize = new ResizeObserver(() => {
      const w = d.chartBox.clientWidth;
      if (w > 0 && Math.abs(w - chart.width) > 1) chart.setSize({ width: w, height: 210 });
    });
    d.resize.observe(d.chartBox);
    visibility.observe(d.chartBox);
    return chart;
  }

  // --------------------------------------------------------------------------------------
  // samples: into the rings; charts redraw on the next animation frame.

  function onSamples(f) {
    if (typeof f.t !== 'number') return;
    if (f.t < tNow) {
      // The gateway's clock went back (it restarted): old history is on another clock.
      for (const d of devices.values()) d.ring.clear();
    }
    tNow = f.t;
    hook.t = f.t;
    for (const [name, s] of Object.entries(f.devices || {})) {
      const d = devices.get(name);
      if (!d || !s) continue;
      d.ring.push(f.t, s.q, s.cmd);
      d.dirty = true;
    }
    requestDraw();
  }

  function requestDraw() {
    if (rafPending) return;
    rafPending = true;
    requestAnimationFrame(draw);
  }

  function draw(ts) {
    rafPending = false;
    const start = performance.now();
    let drew = false;
    for (const d of devices.values()) {
      if (d.dirty && d.chart && (d.visible || ts - d.lastDraw >= OFFSCREEN_REDRAW_MS)) {
        d.dirty = false;
        d.lastDraw = ts;
        drawChart(d);
        hook.redraws[d.name]++;
        drew = true;
      }
      if (d.padsDirty) {
        d.padsDirty = false;
        drawPads(d);
        drew = true;
      }
    }
    if (drew) {
      const ms = performance.now() - start;
      hook.drawFrames++;
      hook.drawMs += ms;
      if (ms > hook.drawMsMax) hook.drawMsMax = ms;
      fpsWindowFrames++;
    }
    if (ts - fpsWindowStart >= 1000) {
      hook.fps = Math.round((fpsWindowFrames * 1000) / (ts - fpsWindowStart));
      fpsWindowStart = ts;
      fpsWindowFrames = 0;
    }
  }

  /** The last WINDOW_S seconds of the ring, oldest first, x relative to the newest sample. */
  function drawChart(d) {
    const r = d.ring;
    const n = d.joints.length;
    const first = r.firstFrom(tNow - WINDOW_S);
    const count = r.len - first;
    const data = d.data;
    for (const a of data) a.length = count;
    const xs = data[0];
    for (let k = 0; k < count; k++) {
      const s = r.slot(first + k);
      const base = s * n * 2;
      xs[k] = r.t[s] - tNow;
      for (let j = 0; j < n; j++) {
        const q = r.v[base + j];
        const c = r.v[base + n + j];
        data[1 + 2 * j][k] = q === q ? q : null;
        data[2 + 2 * j][k] = c === c ? c : null;
      }
    }
    // batch: uPlot draws before returning (instead of in a microtask), so the frame's drawing
    // time is measured (hook.drawMs) and the chart never shows data older than the ring's.
    d.chart.batch(() => d.chart.setData(data));
  }

  // --------------------------------------------------------------------------------------
  // Pads: each pad's rows x cols cells at its (x, y, w, h) in the hand's unit square.

  function buildScaleLut() {
    const lut = [];
    for (let i = 0; i < 256; i++) {
      const v = i / 255;
      let k = 1;
      while (k < SCALE_STOPS.length - 1 && SCALE_STOPS[k][0] < v) k++;
      const [v0, c0] = SCALE_STOPS[k - 1];
      const [v1, c1] = SCALE_STOPS[k];
      const f = Math.min(1, Math.max(0, (v - v0) / (v1 - v0)));
      const c = c0.map((x, m) => Math.round(x + (c1[m] - x) * f));
      lut.push(`rgb(${c[0]},${c[1]},${c[2]})`);
    }
    return lut;
  }

  const PADS_HINT = 'palm view, fingers up';

  function buildPads(d) {
    d.padCanvas = el('canvas', { role: 'img', 'aria-label': `${d.name} tactile pads` });
    d.padCaption = el('div', { class: 'caption', text: PADS_HINT });
    const bar = el('span', { class: 'bar' });
    bar.style.background = `linear-gradient(90deg, ${[0, 0.25, 0.5, 0.75, 1].map((v) => scaleLut[Math.round(v * 255)]).join(', ')})`;
    const scale = el('div', { class: 'scale' }, el('span', { text: '0' }), bar, el('span', { text: '1' }),
      el('span', { class: 'nodata', title: 'no reading' }), el('span', { text: 'none' }));
    const box = el('div', { class: 'pads' }, d.padCanvas, scale, d.padCaption);
    d.padCanvas.addEventListener('mousemove', (ev) => padHover(d, ev));
    d.padCanvas.addEventListener('mouseleave', () => setText(d.padCaption, PADS_HINT));
    d.padResize = new ResizeObserver(() => {
      d.padsDirty = true;
      requestDraw();
    });
    d.padResize.observe(d.padCanvas);
    d.padsDirty = true;
    return box;
  }

  /** rows, cols of pad i: hello's, or one row of the values when they do not fit it. */
  function padGrid(place, vals) {
    const n = vals ? vals.length : 0;
    if (place.rows > 0 && place.cols > 0 && (n === 0 || place.rows * place.cols === n)) {
      return [place.rows, place.cols];
    }
    return [1, Math.max(1, n)];
  }

  function drawPads(d) {
    const cv = d.padCanvas;
    const dpr = window.devicePixelRatio || 1;
    const size = Math.max(1, Math.round(cv.clientWidth * dpr));
    if (cv.width !== size || cv.height !== size) {
      cv.width = size;
      cv.height = size;
    }
    const ctx = cv.getContext('2d');
    ctx.clearRect(0, 0, size, size);
    const empty = cssVar('--empty') || '#888';
    const line = cssVar('--line') || '#ccc';
    const gap = Math.max(1, dpr);
    d.pads.forEach((place, i) => {
      const vals = d.padValues ? d.padValues[i] : null;
      const [rows, cols] = padGrid(place, vals);
      const x0 = place.x * size;
      const y0 = place.y * size;
      const cw = (place.w * size) / cols;
      const ch = (place.h * size) / rows;
      for (let r = 0; r < rows; r++) {
        for (let c = 0; c < cols; c++) {
          const v = vals && vals.length ? vals[r * cols + c] : null;
          ctx.fillStyle = typeof v === 'number' && v >= 0
            ? scaleLut[Math.round(Math.min(1, v) * 255)]
            : empty;
          ctx.fillRect(x0 + c * cw, y0 + r * ch, Math.max(1, cw - gap), Math.max(1, ch - gap));
        }
      }
      ctx.strokeStyle = line;
      ctx.lineWidth = dpr;
      ctx.strokeRect(x0 - gap, y0 - gap, place.w * size + gap, place.h * size + gap);
    });
  }

  function padHover(d, ev) {
    const rect = d.padCanvas.getBoundingClientRect();
    const x = (ev.clientX - rect.left) / rect.width;
    const y = (ev.clientY - rect.top) / rect.height;
    let text = '';
    d.pads.forEach((place, i) => {
      if (x < place.x || x >= place.x + place.w || y < place.y || y >= place.y + place.h) return;
      const vals = d.padValues ? d.padValues[i] : null;
      const [rows, cols] = padGrid(place, vals);
      const c = Math.min(cols - 1, Math.floor(((x - place.x) / place.w) * cols));
      const r = Math.min(rows - 1, Math.floor(((y - place.y) / place.h) * rows));
      const v = vals && vals.length ? vals[r * cols + c] : null;
      const reading = typeof v === 'number' && v >= 0 ? v.toFixed(2) : 'no reading';
      text = `${place.name} (${rows}×${cols}) row ${r} col ${c}: ${reading}`;
    });
    d.padCanvas.title = text || d.pads.map((p) => p.name).join(', ');
    setText(d.padCaption, text || PADS_HINT);
  }

  function onPads(f) {
    for (const [name, arrays] of Object.entries(f.devices || {})) {
      const d = devices.get(name);
      if (!d || !d.padCanvas) continue;
      d.padValues = arrays;
      d.padsDirty = true;
    }
    requestDraw();
  }

  // --------------------------------------------------------------------------------------
  // status: fleet table, card badges, diagnostics.

  const FLEET_COLS = ['device', 'kind', 'backend', 'state', 'safe', 'cmd', 'stateHz', 'age', 'crc', 'bad',
    'wdog', 'recon', 'missed', 'foreign', 'dup', 'reord', 'late', 'notallowed', 'faults', 'closure', 'owner',
    'track', 'motion'];
  const NUMERIC = new Set(['cmd', 'stateHz', 'age', 'crc', 'bad', 'wdog', 'recon', 'missed', 'foreign', 'dup',
    'reord', 'late', 'notallowed', 'closure', 'track']);
  /** The card's words for a motion verdict (`DeviceStatus_::motion`), and the joint it names. */
  const MOTION_WORDS = { frozen: 'frozen', joint_stuck: 'joint stuck', not_following: 'not following',
    holding: 'holding an object' };

  function motionText(dev) {
    const w = MOTION_WORDS[dev.motion];
    if (!w) return '';
    return dev.motion_joint ? `${w}: ${dev.motion_joint}` : w;
  }

  function fleetRow(name) {
    let r = rows.get(name);
    if (r) return r;
    const tr = el('tr', { 'data-row': name });
    r = { tr, cells: {} };
    for (const k of FLEET_COLS) {
      const td = el('td', { class: NUMERIC.has(k) ? 'num' : k === 'owner' ? 'owner' : null, 'data-col': k });
      r.cells[k] = td;
      tr.append(td);
    }
    r.cells.device.className = 'mono';
    setText(r.cells.device, name);
    rows.set(name, r);
    return r;
  }

  function onStatus(s) {
    const meta = [`profile ${s.profile}`];
    if (hello && hello.version) meta.push(`v${hello.version}`);
    meta.push(`uptime ${fixed((s.uptime_ms || 0) / 1000, 1)} s`);
    if (s.record_messages || s.record_dropped) {
      meta.push(`recorded ${s.record_messages} (dropped ${s.record_dropped})`);
    }
    if (typeof s.clients === 'number') meta.push(`${s.clients} page${s.clients === 1 ? '' : 's'}`);
    setText($('#meta'), meta.join(' · '));
    const tbody = $('#fleet tbody');
    for (const dev of s.devices || []) {
      const r = fleetRow(dev.device);
      if (!r.tr.parentNode) tbody.append(r.tr);
      const c = r.cells;
      const fresh = dev.freshness || 'stale';
      setText(c.kind, dev.kind || '');
      setText(c.backend, dev.backend || '');
      setText(c.state, fresh === 'commanded_only' ? 'cmd-only' : fresh);
      c.state.className = fresh;
      setText(c.safe, dev.safe ? 'yes' : 'no');
      c.safe.className = dev.safe ? 'alert' : '';
      setText(c.cmd, fixed(dev.cmd_rate_hz, 1));
      setText(c.stateHz, fixed(dev.state_rate_hz, 1));
      setText(c.age, fixed(dev.age_ms, 1));
      for (const [k, field] of [['crc', 'crc_errors'], ['bad', 'bad_input'], ['wdog', 'watchdog_trips'],
        ['recon', 'reconnects'], ['missed', 'missed_cycles'], ['foreign', 'foreign_cmd'],
        ['dup', 'duplicate_cmd'], ['reord', 'reordered_cmd'], ['late', 'late_cmd'],
        ['notallowed', 'not_allowed_cmd']]) {
        setText(c[k], String(dev[field] ?? '—'));
      }
      const faults = dev.faults && dev.faults.length ? dev.faults.join(', ') : 'none';
      setText(c.faults, faults);
      c.faults.className = faults === 'none' ? '' : 'alert';
      setText(c.closure, fixed(dev.closure, 2));
      setText(c.owner, shortOwner(dev.owner) || '—');
      c.owner.title = dev.owner || 'nobody commanded it yet';
      setText(c.track, fixed(dev.tracking_error, 3));
      const motion = motionText(dev);
      setText(c.motion, motion || 'ok');
      const holding = dev.motion === 'holding';
      c.motion.className = motion && !holding ? 'alert' : '';

      const d = devices.get(dev.device);
      if (d) {
        setText(d.freshBadge, fresh === 'commanded_only' ? 'commanded only' : fresh);
        d.freshBadge.className = 'badge ' + (fresh === 'fresh' ? 'ok' : fresh === 'stale' ? 'bad' : 'warn');
        d.safeBadge.hidden = !dev.safe;
        d.motionBadge.hidden = !motion;
        d.motionBadge.dataset.motion = dev.motion || 'ok';
        d.motionBadge.className = 'badge ' + (holding ? 'ok' : 'bad');
        setText(d.motionBadge, motion);
        d.motionBadge.title = !motion ? ''
          : holding ? `stopped closing in contact: tracking error ${fixed(dev.tracking_error, 3)} rad`
            : `reports but does not move: tracking error ${fixed(dev.tracking_error, 3)} rad`;
        d.owner.title = dev.owner || '';
        setText(d.owner, `commanded by: ${shortOwner(dev.owner) || 'nobody yet'}` +
          (faults === 'none' ? '' : ` · faults: ${faults}`));
      }
    }
    renderDiagnostics(s.diagnostics || []);
    renderEndpoints(s.endpoints || []);
  }

  /** Who commands a device, without the DDS writer's GUID (kept in the element's title). */
  function shortOwner(owner) {
    return owner ? owner.replace(/\s*\(writer [0-9a-f:]+\)\s*$/i, '') : '';
  }

  function renderDiagnostics(list) {
    const box = $('#diagnostics');
    const key = JSON.stringify(list);
    if (box.dataset.key === key) return;
    box.dataset.key = key;
    box.replaceChildren();
    if (!list.length) {
      box.append(el('p', { class: 'none', text: 'none' }));
      return;
    }
    const ul = el('ul', { class: 'diag' });
    for (const g of list) {
      const sev = g.severity === 'problem' ? 'problem' : 'note';
      ul.append(el('li', { class: sev },
        el('div', {},
          el('span', { class: 'badge ' + (sev === 'problem' ? 'bad' : ''), text: sev }), ' ',
          el('strong', { class: 'mono', text: g.kind || '' }), ' ',
          el('span', { class: 'meta', text: [g.owner, g.topic].filter(Boolean).join(' · ') })),
        el('div', { text: g.detail || '' }),
        g.fix ? el('div', { class: 'fix', text: 'fix: ' + g.fix }) : null));
    }
    box.append(ul);
  }

  /** Endpoints with a matched counterpart in a table; the others listed under a fold. */
  function renderEndpoints(list) {
    const box = $('#endpoints');
    const key = JSON.stringify(list);
    if (box.dataset.key === key) return;
    box.dataset.key = key;
    const wasOpen = box.querySelector('details')?.open || false;
    box.replaceChildren();
    const matched = list.filter((e) => e.matched > 0);
    const alone = list.filter((e) => !(e.matched > 0));
    if (!matched.length) box.append(el('p', { class: 'none', text: 'none' }));
    else box.append(endpointTable(matched));
    if (alone.length) {
      const details = el('details', {},
        el('summary', { class: 'meta', text: `${alone.length} endpoint${alone.length === 1 ? '' : 's'} with no counterpart` }),
        endpointTable(alone));
      details.open = wasOpen;
      box.append(details);
    }
  }

  function endpointTable(list) {
    const tbody = el('tbody');
    for (const e of list) {
      const who = e.who && e.who.length ? e.who.join('; ') : '';
      tbody.append(el('tr', {},
        el('td', { text: e.owner || '' }),
        el('td', { text: e.role || '' }),
        el('td', { class: 'mono', text: e.topic || '' }),
        el('td', { class: 'num', text: String(e.matched ?? 0) }),
        el('td', { class: 'wrap', text: who || '—' })));
    }
    return el('div', { class: 'scroll' }, el('table', { class: 'grid' },
      el('thead', {}, el('tr', {},
        el('th', { text: 'owner' }), el('th', { text: 'role' }), el('th', { text: 'topic' }),
        el('th', { class: 'num', text: 'matched' }), el('th', { text: 'who' }))),
      tbody));
  }

  // --------------------------------------------------------------------------------------
  // Commanding (only rendered when hello.commands is true).

  function buildControls(d) {
    const id = `closure-${d.name}`;
    const slider = el('input', { type: 'range', min: '0', max: '1', step: '0.01', value: '0', id,
      'data-control': 'closure', 'aria-label': `${d.name} closure` });
    const out = el('output', { for: id, text: '0.00' });
    const toggle = el('input', { type: 'checkbox', 'data-control': 'command' });
    const safe = el('button', { type: 'button', 'data-control': 'safe', text: 'safe',
      title: `move ${d.name} to its safe action (${d.info.safe_action || 'watchdog safe action'})` });
    d.controls = { slider, out, toggle, safe };
    slider.addEventListener('input', () => {
      setText(out, Number(slider.value).toFixed(2));
      if (d.commanding !== null) sendClosure(d);
    });
    toggle.addEventListener('change', () => {
      if (toggle.checked) startCommanding(d);
      else stopCommanding(d);
    });
    safe.addEventListener('click', () => {
      stopCommanding(d);
      send({ type: 'safe', device: d.name });
    });
    return el('div', { class: 'controls' },
      el('label', {}, toggle, ' command'),
      el('label', { for: id, text: 'closure' }), slider, out, safe);
  }

  function sendClosure(d) {
    send({ type: 'command', device: d.name, closure: Number(d.controls.slider.value) });
  }

  function startCommanding(d) {
    if (d.commanding !== null) return;
    setText(d.refusedLine, '');
    sendClosure(d);
    d.commanding = setInterval(() => sendClosure(d), COMMAND_PERIOD_MS);
  }

  function stopCommanding(d) {
    if (d.commanding !== null) {
      clearInterval(d.commanding);
      d.commanding = null;
    }
    if (d.controls) d.controls.toggle.checked = false;
  }

  function stopAllCommanding() {
    for (const d of devices.values()) stopCommanding(d);
  }

  function onRefused(f) {
    hook.refused.push(f);
    if (hook.refused.length > 50) hook.refused.shift();
    const d = devices.get(f.device);
    const text = `refused: ${f.reason || 'no reason given'}`;
    if (d) setText(d.refusedLine, text);
    else setText($('#conn-detail'), text);
  }

  // --------------------------------------------------------------------------------------

  setConnected(false, 'connecting');
  connect();
})();
