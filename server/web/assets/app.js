// The live view of excite-server: polls the JSON API (/api/...) and draws the
// selected session on canvases sized to the page. No libraries, nothing fetched
// from elsewhere. Each canvas also carries what it shows in data-* attributes
// (labels, ticks, ranges, series sizes) for the browser test.
'use strict';

const REFRESH_MS = 1500;
const GRID = 24;  // the std map is GRID x GRID predictions
const COLOURS = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#8c564b', '#e377c2', '#17becf'];

const view = {
  token: sessionStorage.getItem('excite-token') || '',
  selected: '',
  session: null,
  archive: null,
  archiveKey: '',
  history: null,
  historyKey: '',
  rollout: null,
  rolloutKey: '',
  std: null,
  stdKey: '',
  fixedFor: '',
};

const $ = (id) => document.getElementById(id);

// #token=T&session=ID: the token goes to sessionStorage and leaves the address bar.
function readHash() {
  const params = new URLSearchParams(location.hash.slice(1));
  if (params.has('token')) {
    view.token = params.get('token');
    sessionStorage.setItem('excite-token', view.token);
    params.delete('token');
    history.replaceState(null, '', '#' + params.toString());
  }
  if (params.has('session')) view.selected = params.get('session');
}

function select(id) {
  if (id === view.selected) return;
  Object.assign(view, {selected: id, session: null, archive: null, archiveKey: '', history: null,
                       historyKey: '', rollout: null, rolloutKey: '', std: null, stdKey: '',
                       fixedFor: ''});
  history.replaceState(null, '', '#session=' + encodeURIComponent(id));
  refresh();
}

async function api(path, body) {
  const headers = {};
  if (view.token) headers['Authorization'] = 'Bearer ' + view.token;
  const options = {headers};
  if (body !== undefined) {
    options.method = 'POST';
    headers['Content-Type'] = 'application/json';
    options.body = JSON.stringify(body);
  }
  const res = await fetch(path, options);
  const data = await res.json().catch(() => ({message: res.statusText}));
  if (res.status === 401) $('token-form').hidden = false;
  if (!res.ok) throw new Error((data.code || res.status) + ': ' + data.message);
  return data;
}

const num = (v) => Number(v);  // int64 fields arrive as strings
const shortName = (e) => String(e).replace(/^(STRATEGY|SOLVER_STATUS)_/, '').toLowerCase();

function fmt(v, digits = 3) {
  if (!isFinite(v)) return String(v);
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e5)) return v.toExponential(digits - 1);
  return String(Number(v.toPrecision(digits)));
}

// A tick's label: as short as the value allows ("1e-4", "0.25", "-15").
function tickLabel(v) {
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e5)) return v.toExponential().replace(/\.?0+e/, 'e').replace('e+', 'e');
  return String(Number(v.toPrecision(6)));
}

function wrapAngle(a) {
  const r = a - 2 * Math.PI * Math.round(a / (2 * Math.PI));
  return r <= -Math.PI ? r + 2 * Math.PI : r;
}

// --- the session's dimensions -----------------------------------------------------

// z = (x, u): name, label with unit, angle, region and safe box of each.
function dimensions(config) {
  const angles = new Set((config.angle_dims || []).map(Number));
  const safe = (config.safety && config.safety.state_bounds) || [];
  const dims = [];
  const add = (name, unit, angle, region, box) => dims.push({
    name, unit, angle, region, box, label: unit ? `${name} [${unit}]` : name});
  for (let i = 0; i < config.state_dim; i++) {
    add((config.state_names || [])[i] || 'x' + i, (config.state_units || [])[i] || '',
        angles.has(i), (config.state_bounds || [])[i], safe[i]);
  }
  for (let i = 0; i < config.input_dim; i++) {
    add((config.input_names || [])[i] || 'u' + i, (config.input_units || [])[i] || '',
        false, (config.input_bounds || [])[i], undefined);
  }
  return dims;
}

// The GP's kernel inputs: z's order, an angle's (sin, cos) pair where it was.
function kernelInputs(dims) {
  const names = [];
  for (const d of dims) {
    if (d.angle) names.push('sin ' + d.name, 'cos ' + d.name);
    else names.push(d.name);
  }
  return names;
}

// A sample's z as drawn: angles on (-pi, pi], as the model sees them.
function shownZ(t, dims) {
  return t.state.concat(t.input).map((v, i) => (dims[i].angle ? wrapAngle(v) : v));
}

function fillSelect(select, labels, fallback) {
  const key = labels.join('|');
  if (select.dataset.key === key) return;
  select.dataset.key = key;
  select.innerHTML = '';
  labels.forEach((n, i) => select.add(new Option(n, String(i))));
  select.value = String(Math.min(fallback, labels.length - 1));
}

// --- axes ----------------------------------------------------------------------

// 1, 2 or 5 times a power of ten, near span / count.
function niceStep(span, count) {
  const raw = span / count;
  const p = 10 ** Math.floor(Math.log10(raw));
  const f = raw / p;
  return (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10) * p;
}

// A linear axis over the finite `values`, widened to whole steps (from 0 if
// fromZero); ticks at multiples of the step.
function linearAxis(values, fromZero = false) {
  let lo = Infinity, hi = -Infinity;
  for (const v of values) if (isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!isFinite(lo)) { lo = 0; hi = 1; }
  if (fromZero) lo = Math.min(0, lo);
  if (hi - lo < 1e-12) { const d = Math.abs(lo) * 0.1 || 1; lo -= d; hi += d; }
  const step = niceStep(hi - lo, 5);
  lo = Math.floor(lo / step + 1e-9) * step;
  hi = Math.ceil(hi / step - 1e-9) * step;
  const ticks = [];
  for (let k = Math.round(lo / step); k <= Math.round(hi / step); k++) ticks.push(Number((k * step).toPrecision(12)));
  return {lo, hi, ticks, log: false};
}

// A log10 axis over the positive `values`: whole decades, ticks at 1 (and 2, 5
// within one or two decades) times each power of ten.
function logAxis(values) {
  const positive = values.filter((v) => isFinite(v) && v > 0);
  if (!positive.length) return {lo: 0.1, hi: 1, ticks: [0.1, 0.2, 0.5, 1], log: true};
  let lo = Math.floor(Math.log10(Math.min(...positive)) + 1e-9);
  let hi = Math.ceil(Math.log10(Math.max(...positive)) - 1e-9);
  if (hi <= lo) hi = lo + 1;
  const ticks = [];
  for (let k = lo; k <= hi; k++) {
    for (const m of hi - lo <= 2 ? [1, 2, 5] : [1]) {
      if (k < hi || m === 1) ticks.push(Number((m * 10 ** k).toPrecision(12)));
    }
  }
  return {lo: 10 ** lo, hi: 10 ** hi, ticks, log: true};
}

// Sizes the canvas to its box (device pixels), clears it and draws the frame,
// ticks and labels; returns the mapping. `rightMargin` leaves room (colour bar).
function frame(canvas, xa, ya, xlabel, ylabel, rightMargin = 12) {
  const dpr = window.devicePixelRatio || 1;
  const cssW = Math.max(200, canvas.clientWidth), cssH = Math.round(cssW * 0.62);
  if (canvas.width !== Math.round(cssW * dpr) || canvas.height !== Math.round(cssH * dpr)) {
    canvas.width = Math.round(cssW * dpr);
    canvas.height = Math.round(cssH * dpr);
  }
  canvas.style.height = cssH + 'px';
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, cssW, cssH);
  const L = 62, R = rightMargin, T = 10, B = 40;
  const W = cssW - L - R, H = cssH - T - B;
  const tx = (a, v) => (a.log ? Math.log10(v) : v);
  const sx = (x) => L + (tx(xa, x) - tx(xa, xa.lo)) / (tx(xa, xa.hi) - tx(xa, xa.lo)) * W;
  const sy = (y) => T + H - (tx(ya, y) - tx(ya, ya.lo)) / (tx(ya, ya.hi) - tx(ya, ya.lo)) * H;
  ctx.strokeStyle = '#888';
  ctx.fillStyle = '#333';
  ctx.font = '11px sans-serif';
  ctx.lineWidth = 1;
  ctx.strokeRect(L, T, W, H);
  ctx.textAlign = 'center';
  for (const x of xa.ticks) {
    ctx.beginPath(); ctx.moveTo(sx(x), T + H); ctx.lineTo(sx(x), T + H + 4); ctx.stroke();
    ctx.fillText(tickLabel(x), sx(x), T + H + 15);
  }
  ctx.fillText(xlabel, L + W / 2, cssH - 6);
  ctx.textAlign = 'right';
  for (const y of ya.ticks) {
    ctx.beginPath(); ctx.moveTo(L - 4, sy(y)); ctx.lineTo(L, sy(y)); ctx.stroke();
    ctx.fillText(tickLabel(y), L - 6, sy(y) + 4);
  }
  ctx.save();
  ctx.translate(13, T + H / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textAlign = 'center';
  ctx.fillText(ylabel, 0, 0);
  ctx.restore();
  Object.assign(canvas.dataset, {
    xlabel, ylabel, xticks: JSON.stringify(xa.ticks), yticks: JSON.stringify(ya.ticks),
    xrange: JSON.stringify([xa.lo, xa.hi]), yrange: JSON.stringify([ya.lo, ya.hi])});
  return {ctx, sx, sy, L, T, W, H, cssW, cssH};
}

function message(canvas, text) {
  const dpr = window.devicePixelRatio || 1;
  const cssW = Math.max(200, canvas.clientWidth), cssH = Math.round(cssW * 0.62);
  canvas.width = Math.round(cssW * dpr);
  canvas.height = Math.round(cssH * dpr);
  canvas.style.height = cssH + 'px';
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.fillStyle = '#666';
  ctx.font = '13px sans-serif';
  ctx.textAlign = 'center';
  ctx.fillText(text, cssW / 2, cssH / 2);
  canvas.dataset.series = '0';
}

// Clips drawing to the plot area of frame `f`.
function clipped(f, draw) {
  f.ctx.save();
  f.ctx.beginPath();
  f.ctx.rect(f.L, f.T, f.W, f.H);
  f.ctx.clip();
  draw();
  f.ctx.restore();
}

function legend(f, entries) {
  const ctx = f.ctx;
  ctx.font = '11px sans-serif';
  ctx.textAlign = 'left';
  const width = Math.max(...entries.map((e) => ctx.measureText(e.text).width)) + 30;
  let y = f.T + 14;
  const x = f.L + f.W - width - 4;
  ctx.fillStyle = 'rgba(255,255,255,0.85)';
  ctx.fillRect(x - 4, f.T + 3, width + 6, entries.length * 15 + 4);
  for (const e of entries) {
    ctx.strokeStyle = e.colour;
    ctx.fillStyle = e.colour;
    ctx.setLineDash(e.dash || []);
    ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(x, y - 4); ctx.lineTo(x + 20, y - 4); ctx.stroke();
    ctx.setLineDash([]);
    ctx.fillStyle = '#222';
    ctx.fillText(e.text, x + 25, y);
    y += 15;
  }
  ctx.lineWidth = 1;
}

// `breaks(a, b)`: no segment from point a to b (an angle that wrapped).
function polyline(f, points, colour, dash, breaks) {
  const ctx = f.ctx;
  ctx.strokeStyle = colour;
  ctx.lineWidth = 2;
  ctx.setLineDash(dash || []);
  ctx.beginPath();
  points.forEach((p, i) => {
    const jump = i === 0 || (breaks && breaks(points[i - 1], p));
    (jump ? ctx.moveTo : ctx.lineTo).call(ctx, f.sx(p[0]), f.sy(p[1]));
  });
  ctx.stroke();
  ctx.setLineDash([]);
  ctx.lineWidth = 1;
}

// The region (dashed blue) and the safe box (orange) in the (dx, dy) plane.
function drawBoxes(f, dims, dx, dy) {
  const entries = [];
  const box = (lo, hi, colour, dash, text) => {
    f.ctx.strokeStyle = colour;
    f.ctx.lineWidth = 2;
    f.ctx.setLineDash(dash);
    f.ctx.strokeRect(f.sx(lo[0]), f.sy(hi[1]), f.sx(hi[0]) - f.sx(lo[0]), f.sy(lo[1]) - f.sy(hi[1]));
    f.ctx.setLineDash([]);
    f.ctx.lineWidth = 1;
    entries.push({colour, dash, text});
  };
  const a = dims[dx], b = dims[dy];
  // A dimension without an interval spans the whole axis in that direction.
  const side = (d, key, axisLo, axisHi) => (d[key] ? [num(d[key].lower), num(d[key].upper)] : [axisLo, axisHi]);
  const xr = JSON.parse(f.ctx.canvas.dataset.xrange), yr = JSON.parse(f.ctx.canvas.dataset.yrange);
  if (a.region || b.region) {
    const [x0, x1] = side(a, 'region', xr[0], xr[1]), [y0, y1] = side(b, 'region', yr[0], yr[1]);
    clipped(f, () => box([x0, y0], [x1, y1], '#1f5fbf', [6, 4], 'region (state/input bounds)'));
  }
  if (a.box || b.box) {
    const [x0, x1] = side(a, 'box', xr[0], xr[1]), [y0, y1] = side(b, 'box', yr[0], yr[1]);
    clipped(f, () => box([x0, y0], [x1, y1], '#e67e00', [], 'safe box'));
  }
  f.ctx.canvas.dataset.region = entries.length ? entries.map((e) => e.text).join('; ') : 'none';
  return entries;
}

// --- plots ------------------------------------------------------------------------

function drawSamples(samples) {
  const canvas = $('plot-samples');
  if (!samples.length) return message(canvas, 'no samples yet');
  const t0 = samples[0].timestamp_s;
  const timed = samples.every((s, i) => s.timestamp_s > 0 && (i === 0 || s.timestamp_s >= samples[i - 1].timestamp_s));
  const xs = samples.map((s, i) => (timed ? s.timestamp_s - t0 : i));
  const f = frame(canvas, linearAxis(xs, true), linearAxis([0, samples.length], true),
                  timed ? 'seconds since the first sample' : 'sample', 'samples stored');
  clipped(f, () => polyline(f, xs.map((x, i) => [x, i + 1]), '#1f5fbf'));
  canvas.dataset.series = String(samples.length);
}

// The plan's predicted states as drawn (angles wrapped), in z's coordinates
// (inputs of step k follow its state).
function planZ(plan, config, dims) {
  if (!plan || !plan.predicted_states || !plan.predicted_states.length) return [];
  const dx = config.state_dim, du = config.input_dim, rows = [];
  for (let k = 0; k * dx < plan.predicted_states.length; k++) {
    const z = plan.predicted_states.slice(k * dx, k * dx + dx).concat(plan.inputs.slice(k * du, k * du + du));
    rows.push(z.map((v, i) => (dims[i].angle ? wrapAngle(v) : v)));
  }
  return rows;
}

// One axis for coordinate d shared by the visited states and the std map:
// the samples, the plan, the region and the safe box.
function sharedAxis(zs, dims, d) {
  const values = zs.map((z) => z[d]);
  for (const key of ['region', 'box']) {
    if (dims[d][key]) values.push(num(dims[d][key].lower), num(dims[d][key].upper));
  }
  if (dims[d].angle) values.push(-Math.PI, Math.PI);
  return linearAxis(values);
}

function drawStates(zs, plan, dims, dx, dy, axes) {
  const canvas = $('plot-states');
  if (!zs.length) return message(canvas, 'no samples yet');
  const f = frame(canvas, axes[0], axes[1], dims[dx].label, dims[dy].label);
  const n = zs.length;
  clipped(f, () => {
    zs.forEach((z, i) => {
      const shade = Math.round(200 - 170 * (n > 1 ? i / (n - 1) : 1));
      f.ctx.fillStyle = `rgb(${shade},${shade},${Math.min(255, shade + 60)})`;
      f.ctx.fillRect(f.sx(z[dx]) - 2, f.sy(z[dy]) - 2, 4, 4);
    });
  });
  const entries = drawBoxes(f, dims, dx, dy);
  if (plan.length) {
    clipped(f, () => {
      // Where an angle wraps the trajectory leaves one side and enters the other.
      const wrapped = (a, b) => (dims[dx].angle && Math.abs(b[0] - a[0]) > Math.PI) ||
                                (dims[dy].angle && Math.abs(b[1] - a[1]) > Math.PI);
      polyline(f, plan.map((z) => [z[dx], z[dy]]), '#d62728', null, wrapped);
      f.ctx.fillStyle = '#d62728';
      for (const z of plan) { f.ctx.beginPath(); f.ctx.arc(f.sx(z[dx]), f.sy(z[dy]), 3, 0, 2 * Math.PI); f.ctx.fill(); }
    });
    entries.push({colour: '#d62728', text: 'latest plan (predicted)'});
  }
  if (entries.length) legend(f, entries);
  canvas.dataset.series = String(n);
}

// Viridis-like: dark blue (low) to yellow (high).
function colour(t) {
  const stops = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  const x = Math.max(0, Math.min(1, t)) * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(x)), u = x - i;
  const c = stops[i].map((v, k) => Math.round(v + (stops[i + 1][k] - v) * u));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

function drawStd(std, zs, dims) {
  const canvas = $('plot-std');
  if (!std) return message(canvas, 'waiting for the model');
  const f = frame(canvas, std.axes[0], std.axes[1], dims[std.dx].label, dims[std.dy].label, 78);
  const vmin = Math.min(...std.values), vmax = Math.max(...std.values);
  const cw = f.W / GRID, ch = f.H / GRID;
  for (let j = 0; j < GRID; j++) {
    for (let i = 0; i < GRID; i++) {
      const v = std.values[j * GRID + i];
      f.ctx.fillStyle = colour(vmax > vmin ? (v - vmin) / (vmax - vmin) : 0.5);
      f.ctx.fillRect(f.L + i * cw, f.T + (GRID - 1 - j) * ch, cw + 0.5, ch + 0.5);
    }
  }
  clipped(f, () => {
    f.ctx.fillStyle = 'rgba(255,255,255,0.8)';
    for (const z of zs) f.ctx.fillRect(f.sx(z[std.dx]) - 1, f.sy(z[std.dy]) - 1, 2, 2);
  });
  drawBoxes(f, dims, std.dx, std.dy);
  // Colour bar with its own ticks, in the output's units.
  const bar = linearAxis([vmin, vmax]);
  const bx = f.L + f.W + 12, bw = 12;
  const by = (v) => f.T + f.H - (v - bar.lo) / (bar.hi - bar.lo) * f.H;
  for (let p = 0; p < f.H; p++) {
    const v = bar.lo + (bar.hi - bar.lo) * (1 - p / f.H);
    f.ctx.fillStyle = v < vmin || v > vmax ? '#eee' : colour(vmax > vmin ? (v - vmin) / (vmax - vmin) : 0.5);
    f.ctx.fillRect(bx, f.T + p, bw, 1.5);
  }
  f.ctx.strokeStyle = '#888';
  f.ctx.strokeRect(bx, f.T, bw, f.H);
  f.ctx.fillStyle = '#333';
  f.ctx.textAlign = 'left';
  for (const v of bar.ticks) f.ctx.fillText(tickLabel(v), bx + bw + 3, by(v) + 4);
  canvas.dataset.colorbar = JSON.stringify([vmin, vmax]);
  canvas.dataset.series = String(std.values.length);
  const out = dims[std.output];
  $('std-range').textContent = `std of ${out.label} from ${fmt(vmin)} to ${fmt(vmax)}`;
}

// The one-step RMSE of each batch (dots) and its running value over the last
// RUNNING_BATCHES batches, weighted by their sizes (solid line).
const RUNNING_BATCHES = 10;
function runningRmse(errors, d) {
  const out = [];
  for (let i = 0; i < errors.length; i++) {
    let squares = 0, count = 0;
    for (let k = Math.max(0, i - RUNNING_BATCHES + 1); k <= i; k++) {
      const n = num(errors[k].batch_size);
      squares += n * errors[k].rmse[d] ** 2;
      count += n;
    }
    out.push([num(errors[i].sample_count) + num(errors[i].batch_size), Math.sqrt(squares / count)]);
  }
  return out;
}

// One-step error of each batch before it was added (dots, running value solid)
// and the mean std over the region (dashed), per state dimension, over samples:
// log scale.
function drawCurve(hist, dims, stateDim) {
  const canvas = $('plot-curve');
  const errors = (hist && hist.batch_errors) || [], stds = (hist && hist.uncertainty) || [];
  if (!errors.length && !stds.length) return message(canvas, 'no learning curve yet (the model is fitted at the first plan)');
  const xs = errors.map((e) => num(e.sample_count) + num(e.batch_size)).concat(stds.map((u) => num(u.sample_count)));
  const ys = [];
  for (const e of errors) ys.push(...e.rmse);
  for (const u of stds) ys.push(...u.mean_std);
  const ya = logAxis(ys);
  const f = frame(canvas, linearAxis(xs, true), ya, 'samples', 'per dimension, in its units');
  // A zero (a batch predicted exactly) is drawn below the axis, not at -infinity.
  const at = (v) => Math.max(v, ya.lo / 2);
  const entries = [];
  for (let d = 0; d < stateDim; d++) {
    const c = COLOURS[d % COLOURS.length];
    clipped(f, () => {
      if (errors.length) {
        f.ctx.fillStyle = c;
        f.ctx.globalAlpha = 0.35;
        for (const e of errors) f.ctx.fillRect(f.sx(num(e.sample_count) + num(e.batch_size)) - 1.5, f.sy(at(e.rmse[d])) - 1.5, 3, 3);
        f.ctx.globalAlpha = 1;
        polyline(f, runningRmse(errors, d).map((p) => [p[0], at(p[1])]), c);
      }
      if (stds.length) polyline(f, stds.map((u) => [num(u.sample_count), at(u.mean_std[d])]), c, [5, 4]);
    });
    if (errors.length) entries.push({colour: c, text: `${dims[d].label}: one-step RMSE of new data (last ${RUNNING_BATCHES} batches)`});
    if (stds.length) entries.push({colour: c, dash: [5, 4], text: `${dims[d].label}: mean std over region`});
  }
  legend(f, entries);
  canvas.dataset.series = String(errors.length + stds.length);
  canvas.dataset.errors = String(errors.length);
  canvas.dataset.uncertainty = String(stds.length);
}

// The latest plan rolled out by the server (Rollout): the selected output's mean
// and +- 2 standard deviations over the plan's steps.
function drawRollout(rolled, dims, stateDim, out) {
  const canvas = $('plot-rollout');
  if (!rolled || !rolled.means || !rolled.means.length) return message(canvas, 'no model-based plan yet');
  const steps = rolled.means.length / stateDim;
  const pts = [];
  for (let k = 0; k < steps; k++) {
    const m = rolled.means[k * stateDim + out], sd = Math.sqrt(Math.max(0, rolled.variances[k * stateDim + out]));
    pts.push([k, m, sd]);
  }
  const f = frame(canvas, linearAxis(pts.map((p) => p[0]), true),
                  linearAxis(pts.flatMap((p) => [p[1] - 2 * p[2], p[1] + 2 * p[2]])),
                  'step of the latest plan', dims[out].label);
  const c = COLOURS[out % COLOURS.length];
  clipped(f, () => {
    f.ctx.fillStyle = c;
    f.ctx.globalAlpha = 0.18;
    f.ctx.beginPath();
    pts.forEach((p, i) => (i ? f.ctx.lineTo(f.sx(p[0]), f.sy(p[1] + 2 * p[2])) : f.ctx.moveTo(f.sx(p[0]), f.sy(p[1] + 2 * p[2]))));
    for (let i = pts.length - 1; i >= 0; i--) f.ctx.lineTo(f.sx(pts[i][0]), f.sy(pts[i][1] - 2 * pts[i][2]));
    f.ctx.closePath();
    f.ctx.fill();
    f.ctx.globalAlpha = 1;
    polyline(f, pts.map((p) => [p[0], p[1]]), c);
  });
  legend(f, [{colour: c, text: 'predicted mean'}, {colour: 'rgba(0,0,0,0.25)', text: '\u00b1 2 std (propagated)'}]);
  canvas.dataset.series = String(steps);
  canvas.dataset.band = JSON.stringify(pts.map((p) => p[2]));
}

function drawObjectives(hist) {
  const canvas = $('plot-objective');
  const plans = (hist && hist.plans) || [];
  if (!plans.length) return message(canvas, 'no plan yet');
  const points = plans.map((p) => [num(p.sample_count), p.objective, p.solver_status]);
  const f = frame(canvas, linearAxis(points.map((p) => p[0]), true), linearAxis(points.map((p) => p[1])),
                  'samples', 'objective of the plan');
  clipped(f, () => {
    polyline(f, points, '#2a7f2a');
    for (const p of points) {
      const limited = p[2] === 'SOLVER_STATUS_TIME_LIMIT';
      f.ctx.fillStyle = limited ? '#d62728' : '#2a7f2a';
      f.ctx.fillRect(f.sx(p[0]) - 2, f.sy(p[1]) - 2, 4, 4);
    }
  });
  const limited = points.filter((p) => p[2] === 'SOLVER_STATUS_TIME_LIMIT').length;
  legend(f, [{colour: '#2a7f2a', text: 'plan'}].concat(limited ? [{colour: '#d62728', text: `hit the time limit (${limited})`}] : []));
  canvas.dataset.series = String(points.length);
}

// --- data ----------------------------------------------------------------------

function renderSessions(sessions) {
  const list = $('sessions');
  list.innerHTML = '';
  if (!sessions.length) list.innerHTML = '<li class="muted">no sessions</li>';
  for (const s of sessions) {
    const id = s.name.slice('sessions/'.length);
    const li = document.createElement('li');
    li.dataset.id = id;
    li.className = id === view.selected ? 'selected' : '';
    const title = document.createElement('span');
    title.textContent = s.display_name ? `${s.display_name} (${id})` : id;
    const facts = document.createElement('small');
    const labels = Object.entries(s.labels || {}).map(([k, v]) => `${k}=${v}`).join(', ');
    facts.textContent = `${shortName(s.config.strategy)}, ${num(s.sample_count)} samples` + (labels ? `; ${labels}` : '');
    li.append(title, facts);
    li.onclick = () => select(id);
    list.append(li);
  }
}

// Nothing picked yet: the most recently created session.
function newest(sessions) {
  let best = null;
  for (const s of sessions) if (!best || (s.create_time || '') > (best.create_time || '')) best = s;
  return best ? best.name.slice('sessions/'.length) : '';
}

function renderHyperparameters(s, dims) {
  const inputs = kernelInputs(dims);
  const head = $('hyperparameters').tHead.rows[0];
  const want = ['output', 'signal variance', 'noise variance'].concat(inputs.map((n) => 'lengthscale ' + n), ['log marginal likelihood']);
  if (head.dataset.key !== want.join('|')) {
    head.dataset.key = want.join('|');
    head.innerHTML = '';
    for (const text of want) { const th = document.createElement('th'); th.textContent = text; head.append(th); }
  }
  const body = $('hyperparameters').tBodies[0];
  body.innerHTML = '';
  (s.outputs || []).forEach((o, i) => {
    const h = o.hyperparameters || {};
    const atBound = new Set((o.lengthscales_at_bound || []).map(Number));
    const row = body.insertRow();
    row.insertCell().textContent = dims[i].label;
    const sv = row.insertCell();
    sv.textContent = fmt(h.signal_variance);
    if (o.signal_variance_at_bound) { sv.className = 'at-bound'; sv.title = 'at a bound of kernel.signal_variance_bounds'; }
    row.insertCell().textContent = fmt(h.noise_variance);
    (h.lengthscales || []).forEach((l, k) => {
      const cell = row.insertCell();
      cell.textContent = fmt(l);
      cell.dataset.input = inputs[k] || '';
      if (atBound.has(k)) {
        cell.className = 'at-bound';
        cell.title = 'at a bound of kernel.lengthscale_bounds: the data does not pin it down';
      }
    });
    row.insertCell().textContent = o.log_marginal_likelihood ? fmt(o.log_marginal_likelihood, 5) : '-';
  });
}

function renderSession(s, dims) {
  const c = s.config;
  $('session').hidden = false;
  $('session-title').textContent = s.display_name ? `${s.display_name} (${s.name})` : s.name;
  $('session-facts').textContent = `strategy ${shortName(c.strategy)}, ${dims.slice(0, c.state_dim).map((d) => d.label).join(', ')}; ` +
    `inputs ${dims.slice(c.state_dim).map((d) => d.label).join(', ')}; horizon ${c.horizon}, model version ${num(s.model_version)}` +
    (s.create_time ? `, created ${s.create_time}` : '');
  $('sample-count').textContent = String(num(s.sample_count));
  const labels = dims.map((d) => d.label);
  fillSelect($('dim-x'), labels, 0);
  fillSelect($('dim-y'), labels, 1);
  fillSelect($('output'), labels.slice(0, c.state_dim), 0);
  renderHyperparameters(s, dims);
  const plan = s.last_plan;
  if (plan) {
    $('plan-facts').textContent = `planned by ${shortName(plan.planned_by)}: objective ${fmt(plan.objective, 5)}, ${plan.horizon} inputs (apply ${plan.apply_count}), ` +
      `${shortName(plan.solver_status)}, ${plan.iterations} iterations, ${fmt(plan.wall_time_ms)} ms, model version ${num(plan.model_version)}; first input ` +
      plan.inputs.slice(0, c.input_dim).map((u, i) => `${dims[c.state_dim + i].name} = ${fmt(u)}`).join(', ');
  }
}

// Samples outside the region (angles count on the circle).
function outside(zs, dims, stateDim) {
  let count = 0;
  for (const z of zs) {
    for (let i = 0; i < stateDim; i++) {
      const r = dims[i].region;
      if (r && (z[i] < num(r.lower) || z[i] > num(r.upper))) { count++; break; }
    }
  }
  return count;
}

function fixedPoint(zs, width) {
  const typed = $('fixed').value.split(',').map((v) => Number(v.trim()));
  if (typed.length === width && typed.every(isFinite) && $('fixed').value.trim()) return typed;
  return zs.length ? zs[zs.length - 1] : new Array(width).fill(0);
}

async function refreshStd(s, zs, dims, axes) {
  const c = s.config, width = c.state_dim + c.input_dim;
  const dx = Number($('dim-x').value), dy = Number($('dim-y').value), out = Number($('output').value);
  if (!zs.length || !(s.outputs || []).length) { view.std = null; return; }
  if (view.fixedFor !== s.name) {
    $('fixed').value = zs[zs.length - 1].map((v) => fmt(v, 4)).join(', ');
    view.fixedFor = s.name;
  }
  const fixed = fixedPoint(zs, width);
  const key = [s.model_version, dx, dy, out, fixed.join(','), axes[0].lo, axes[0].hi, axes[1].lo, axes[1].hi].join('|');
  if (key === view.stdKey) return;
  const inputs = [];
  for (let j = 0; j < GRID; j++) {
    for (let i = 0; i < GRID; i++) {
      const z = fixed.slice();
      z[dx] = axes[0].lo + (axes[0].hi - axes[0].lo) * (i + 0.5) / GRID;
      z[dy] = axes[1].lo + (axes[1].hi - axes[1].lo) * (j + 0.5) / GRID;
      inputs.push(...z);
    }
  }
  const id = s.name.slice('sessions/'.length);
  const reply = await api(`/api/sessions/${id}/predict`, {inputs});
  const values = [];
  for (let p = 0; p < GRID * GRID; p++) values.push(Math.sqrt(Math.max(0, reply.variance[p * c.state_dim + out])));
  view.std = {dx, dy, output: out, axes, values};
  view.stdKey = key;
}

// Rolls the latest model-based plan out on the server once per plan.
async function refreshRollout(s) {
  const plan = s.last_plan, dx = s.config.state_dim;
  if (!plan || !plan.predicted_states || !plan.predicted_states.length) { view.rollout = null; return; }
  const key = num(plan.model_version) + '|' + plan.wall_time_ms;
  if (key === view.rolloutKey) return;
  const id = s.name.slice('sessions/'.length);
  view.rollout = await api(`/api/sessions/${id}/rollout`,
                           {state: plan.predicted_states.slice(0, dx), inputs: plan.inputs});
  view.rolloutKey = key;
}

function draw() {
  const s = view.session;
  if (!s) return;
  const dims = dimensions(s.config);
  const samples = (view.archive && view.archive.samples) || [];
  const zs = samples.map((t) => shownZ(t, dims));
  const dx = Number($('dim-x').value), dy = Number($('dim-y').value);
  const plan = planZ(s.last_plan, s.config, dims);
  const axes = [sharedAxis(zs.concat(plan), dims, dx), sharedAxis(zs.concat(plan), dims, dy)];
  drawSamples(samples);
  drawStates(zs, plan, dims, dx, dy, axes);
  drawStd(view.std, zs, dims);
  drawCurve(view.history, dims, s.config.state_dim);
  drawObjectives(view.history);
  drawRollout(view.rollout, dims, s.config.state_dim, Number($('output').value));
  const away = outside(zs, dims, s.config.state_dim);
  $('outside').textContent = zs.length ? `${away} of ${zs.length} samples outside the region` : '';
  return {dims, zs, axes};
}

let busy = false;  // one refresh at a time: a slow one is not overtaken

async function refresh() {
  if (busy) return;
  busy = true;
  try {
    const filter = $('filter').value.trim();
    const list = await api('/api/sessions' + (filter ? '?filter=' + encodeURIComponent(filter) : ''));
    const sessions = list.sessions || [];
    if (!view.selected && sessions.length) {
      view.selected = newest(sessions);
      history.replaceState(null, '', '#session=' + encodeURIComponent(view.selected));
    }
    renderSessions(sessions);
    if (view.selected) {
      const id = view.selected;
      const s = await api('/api/sessions/' + id);
      if (id !== view.selected) return;
      view.session = s;
      const dims = dimensions(s.config);
      renderSession(s, dims);
      const key = s.sample_count + '|' + s.model_version;
      if (key !== view.archiveKey) {
        view.archive = await api(`/api/sessions/${id}/archive`);
        view.archiveKey = key;
      }
      const planKey = key + '|' + (s.last_plan ? s.last_plan.wall_time_ms : '');
      if (planKey !== view.historyKey) {
        view.history = await api(`/api/sessions/${id}/history`);
        view.historyKey = planKey;
      }
      await refreshRollout(s);
      const drawn = draw();
      await refreshStd(s, drawn.zs, drawn.dims, drawn.axes);
      drawStd(view.std, drawn.zs, drawn.dims);
    }
    $('status').textContent = 'live';
    $('status').className = 'muted';
    $('updated').textContent = new Date().toLocaleTimeString();
  } catch (e) {
    $('status').textContent = e.message;
    $('status').className = 'error';
  } finally {
    busy = false;
  }
}

function start() {
  readHash();
  $('token-form').onsubmit = (e) => {
    e.preventDefault();
    view.token = $('token-input').value.trim();
    sessionStorage.setItem('excite-token', view.token);
    $('token-form').hidden = true;
    refresh();
  };
  for (const id of ['dim-x', 'dim-y', 'output', 'fixed', 'filter']) $(id).onchange = refresh;
  let resizing = 0;
  window.addEventListener('resize', () => { clearTimeout(resizing); resizing = setTimeout(draw, 100); });
  refresh();
  setInterval(refresh, REFRESH_MS);
}

start();
