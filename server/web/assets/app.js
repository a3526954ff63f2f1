// The live view of excite-server: polls the JSON API (/api/...) and draws the
// selected session on canvases. No libraries, nothing fetched from elsewhere.
'use strict';

const REFRESH_MS = 1500;
const GRID = 24;  // the std map is GRID x GRID predictions

const view = {
  token: sessionStorage.getItem('excite-token') || '',
  selected: '',
  session: null,
  archive: null,
  archiveKey: '',
  std: null,
  stdKey: '',
  objectives: new Map(),  // model_version of a plan -> its objective
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
  view.selected = id;
  view.session = null;
  view.archive = null;
  view.archiveKey = '';
  view.std = null;
  view.stdKey = '';
  view.objectives = new Map();
  view.fixedFor = '';
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

function fmt(v, digits = 3) {
  if (!isFinite(v)) return String(v);
  const a = Math.abs(v);
  return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(digits - 1) : v.toPrecision(digits);
}

function dimNames(config) {
  const names = [];
  for (let i = 0; i < config.state_dim; i++) names.push('x' + i);
  for (let i = 0; i < config.input_dim; i++) names.push('u' + i);
  return names;
}

function fillSelect(select, names, fallback) {
  if (select.options.length === names.length) return;
  select.innerHTML = '';
  names.forEach((n, i) => select.add(new Option(n, String(i))));
  select.value = String(Math.min(fallback, names.length - 1));
}

// --- drawing -------------------------------------------------------------------

function range(values) {
  let lo = Infinity, hi = -Infinity;
  for (const v of values) if (isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!isFinite(lo)) return [0, 1];
  if (hi - lo < 1e-12) { const d = Math.abs(lo) * 0.1 || 1; return [lo - d, hi + d]; }
  const pad = (hi - lo) * 0.08;
  return [lo - pad, hi + pad];
}

// Clears `canvas`, draws axes for x in xr and y in yr, returns the mapping.
function frame(canvas, xr, yr, xlabel, ylabel) {
  const ctx = canvas.getContext('2d');
  const W = canvas.width, H = canvas.height, L = 58, R = 10, T = 10, B = 36;
  ctx.clearRect(0, 0, W, H);
  const sx = (x) => L + (x - xr[0]) / (xr[1] - xr[0]) * (W - L - R);
  const sy = (y) => H - B - (y - yr[0]) / (yr[1] - yr[0]) * (H - T - B);
  ctx.strokeStyle = '#888';
  ctx.fillStyle = '#333';
  ctx.font = '11px sans-serif';
  ctx.strokeRect(L, T, W - L - R, H - T - B);
  ctx.textAlign = 'center';
  for (let i = 0; i <= 4; i++) {
    const x = xr[0] + (xr[1] - xr[0]) * i / 4;
    ctx.fillText(fmt(x), sx(x), H - B + 14);
  }
  ctx.fillText(xlabel, L + (W - L - R) / 2, H - 4);
  ctx.textAlign = 'right';
  for (let i = 0; i <= 4; i++) {
    const y = yr[0] + (yr[1] - yr[0]) * i / 4;
    ctx.fillText(fmt(y), L - 4, sy(y) + 4);
  }
  ctx.save();
  ctx.translate(12, T + (H - T - B) / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textAlign = 'center';
  ctx.fillText(ylabel, 0, 0);
  ctx.restore();
  return {ctx, sx, sy, L, T, W: W - L - R, H: H - T - B};
}

function message(canvas, text) {
  const ctx = canvas.getContext('2d');
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  ctx.fillStyle = '#666';
  ctx.font = '13px sans-serif';
  ctx.textAlign = 'center';
  ctx.fillText(text, canvas.width / 2, canvas.height / 2);
}

function zOf(t) { return t.state.concat(t.input); }

function drawSamples(samples) {
  const canvas = $('plot-samples');
  if (!samples.length) return message(canvas, 'no samples yet');
  const t0 = samples[0].timestamp_s;
  const timed = samples.every((s, i) => s.timestamp_s > 0 && (i === 0 || s.timestamp_s >= samples[i - 1].timestamp_s));
  const xs = samples.map((s, i) => timed ? s.timestamp_s - t0 : i);
  const f = frame(canvas, range(xs), [0, samples.length * 1.05], timed ? 'seconds since the first sample' : 'sample', 'samples stored');
  f.ctx.strokeStyle = '#1f5fbf';
  f.ctx.lineWidth = 2;
  f.ctx.beginPath();
  xs.forEach((x, i) => (i ? f.ctx.lineTo : f.ctx.moveTo).call(f.ctx, f.sx(x), f.sy(i + 1)));
  f.ctx.stroke();
  f.ctx.lineWidth = 1;
}

function statesRange(samples, plan, dx, dy, stateDim) {
  const xs = samples.map((s) => zOf(s)[dx]);
  const ys = samples.map((s) => zOf(s)[dy]);
  for (const p of planPoints(plan, dx, dy, stateDim)) { xs.push(p[0]); ys.push(p[1]); }
  return [range(xs), range(ys)];
}

// The plan's predicted states in (dx, dy) if both are state coordinates.
function planPoints(plan, dx, dy, stateDim) {
  if (!plan || !plan.predicted_states || !plan.predicted_states.length) return [];
  if (dx >= stateDim || dy >= stateDim) return [];
  const points = [];
  for (let k = 0; k * stateDim < plan.predicted_states.length; k++) {
    points.push([plan.predicted_states[k * stateDim + dx], plan.predicted_states[k * stateDim + dy]]);
  }
  return points;
}

function drawStates(samples, plan, dx, dy, names, stateDim) {
  const canvas = $('plot-states');
  if (!samples.length) return message(canvas, 'no samples yet');
  const [xr, yr] = statesRange(samples, plan, dx, dy, stateDim);
  const f = frame(canvas, xr, yr, names[dx], names[dy]);
  const n = samples.length;
  samples.forEach((s, i) => {
    const z = zOf(s);
    const shade = Math.round(200 - 170 * (n > 1 ? i / (n - 1) : 1));
    f.ctx.fillStyle = `rgb(${shade},${shade},${Math.min(255, shade + 60)})`;
    f.ctx.fillRect(f.sx(z[dx]) - 2, f.sy(z[dy]) - 2, 4, 4);
  });
  const points = planPoints(plan, dx, dy, stateDim);
  if (points.length) {
    f.ctx.strokeStyle = '#d62728';
    f.ctx.fillStyle = '#d62728';
    f.ctx.lineWidth = 2;
    f.ctx.beginPath();
    points.forEach((p, i) => (i ? f.ctx.lineTo : f.ctx.moveTo).call(f.ctx, f.sx(p[0]), f.sy(p[1])));
    f.ctx.stroke();
    points.forEach((p) => { f.ctx.beginPath(); f.ctx.arc(f.sx(p[0]), f.sy(p[1]), 3, 0, 2 * Math.PI); f.ctx.fill(); });
    f.ctx.lineWidth = 1;
  }
}

// Dark blue (low) to yellow (high).
function colour(t) {
  const stops = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  const x = Math.max(0, Math.min(1, t)) * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(x)), u = x - i;
  const c = stops[i].map((v, k) => Math.round(v + (stops[i + 1][k] - v) * u));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

function drawStd(std, samples, names) {
  const canvas = $('plot-std');
  if (!std) return message(canvas, 'waiting for the model');
  const f = frame(canvas, std.xr, std.yr, names[std.dx], names[std.dy]);
  const vmin = Math.min(...std.values), vmax = Math.max(...std.values);
  const cw = f.W / GRID, ch = f.H / GRID;
  for (let j = 0; j < GRID; j++) {
    for (let i = 0; i < GRID; i++) {
      const v = std.values[j * GRID + i];
      f.ctx.fillStyle = colour(vmax > vmin ? (v - vmin) / (vmax - vmin) : 0.5);
      f.ctx.fillRect(f.L + i * cw, f.T + (GRID - 1 - j) * ch, cw + 0.5, ch + 0.5);
    }
  }
  f.ctx.fillStyle = 'rgba(255,255,255,0.8)';
  for (const s of samples) {
    const z = zOf(s);
    const x = f.sx(z[std.dx]), y = f.sy(z[std.dy]);
    if (x >= f.L && x <= f.L + f.W && y >= f.T && y <= f.T + f.H) f.ctx.fillRect(x - 1, y - 1, 2, 2);
  }
  $('std-range').textContent = `${fmt(vmin)} (dark) to ${fmt(vmax)} (yellow); white: samples`;
}

function drawObjectives(objectives) {
  const canvas = $('plot-objective');
  const points = [...objectives.entries()].sort((a, b) => a[0] - b[0]);
  if (!points.length) return message(canvas, 'no plan yet');
  const f = frame(canvas, range(points.map((p) => p[0])), range(points.map((p) => p[1])), 'model version', 'objective');
  f.ctx.strokeStyle = '#2a7f2a';
  f.ctx.fillStyle = '#2a7f2a';
  f.ctx.beginPath();
  points.forEach((p, i) => (i ? f.ctx.lineTo : f.ctx.moveTo).call(f.ctx, f.sx(p[0]), f.sy(p[1])));
  f.ctx.stroke();
  points.forEach((p) => f.ctx.fillRect(f.sx(p[0]) - 2, f.sy(p[1]) - 2, 4, 4));
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
    facts.textContent = `${s.config.strategy.replace('STRATEGY_', '').toLowerCase()}, ${num(s.sample_count)} samples` + (labels ? `; ${labels}` : '');
    li.append(title, facts);
    li.onclick = () => select(id);
    list.append(li);
  }
}

function renderSession(s) {
  const c = s.config;
  $('session').hidden = false;
  $('session-title').textContent = s.display_name ? `${s.display_name} (${s.name})` : s.name;
  $('session-facts').textContent = `strategy ${c.strategy.replace('STRATEGY_', '').toLowerCase()}, state_dim ${c.state_dim}, input_dim ${c.input_dim}, horizon ${c.horizon}, model version ${num(s.model_version)}` + (s.create_time ? `, created ${s.create_time}` : '');
  $('sample-count').textContent = String(num(s.sample_count));
  const names = dimNames(c);
  fillSelect($('dim-x'), names, 0);
  fillSelect($('dim-y'), names, 1);
  fillSelect($('output'), names.slice(0, c.state_dim), 0);

  const body = $('hyperparameters').tBodies[0];
  body.innerHTML = '';
  (s.outputs || []).forEach((o, i) => {
    const h = o.hyperparameters || {};
    const row = body.insertRow();
    for (const text of [names[i], fmt(h.signal_variance), fmt(h.noise_variance),
                        (h.lengthscales || []).map((l) => fmt(l)).join(', '),
                        o.log_marginal_likelihood ? fmt(o.log_marginal_likelihood, 5) : '-']) {
      row.insertCell().textContent = text;
    }
  });

  const plan = s.last_plan;
  if (plan) {
    view.objectives.set(num(plan.model_version), plan.objective);
    $('plan-objective').textContent = `latest ${fmt(plan.objective, 5)}`;
    $('plan-facts').textContent = `objective ${fmt(plan.objective, 5)}, ${plan.horizon} inputs (apply ${plan.apply_count}), ` +
      `${plan.solver_status.replace('SOLVER_STATUS_', '').toLowerCase()}, ${plan.iterations} iterations, ` +
      `${fmt(plan.wall_time_ms)} ms, model version ${num(plan.model_version)}; first input ` +
      plan.inputs.slice(0, c.input_dim).map((u) => fmt(u)).join(', ');
  }
}

function fixedPoint(samples, width) {
  const typed = $('fixed').value.split(',').map((v) => Number(v.trim()));
  if (typed.length === width && typed.every(isFinite) && $('fixed').value.trim()) return typed;
  return samples.length ? zOf(samples[samples.length - 1]) : new Array(width).fill(0);
}

async function refreshStd(s, samples) {
  const c = s.config, width = c.state_dim + c.input_dim;
  const dx = Number($('dim-x').value), dy = Number($('dim-y').value), out = Number($('output').value);
  if (!samples.length || !(s.outputs || []).length) { view.std = null; return; }
  if (view.fixedFor !== s.name && samples.length) {
    $('fixed').value = zOf(samples[samples.length - 1]).map((v) => fmt(v, 4)).join(', ');
    view.fixedFor = s.name;
  }
  const fixed = fixedPoint(samples, width);
  const [xr, yr] = statesRange(samples, null, dx, dy, c.state_dim);
  const key = [s.model_version, dx, dy, out, fixed.join(','), xr.join(','), yr.join(',')].join('|');
  if (key === view.stdKey) return;
  const inputs = [];
  for (let j = 0; j < GRID; j++) {
    for (let i = 0; i < GRID; i++) {
      const z = fixed.slice();
      z[dx] = xr[0] + (xr[1] - xr[0]) * (i + 0.5) / GRID;
      z[dy] = yr[0] + (yr[1] - yr[0]) * (j + 0.5) / GRID;
      inputs.push(...z);
    }
  }
  const id = s.name.slice('sessions/'.length);
  const reply = await api(`/api/sessions/${id}/predict`, {inputs});
  const values = [];
  for (let p = 0; p < GRID * GRID; p++) values.push(Math.sqrt(Math.max(0, reply.variance[p * c.state_dim + out])));
  view.std = {dx, dy, xr, yr, values};
  view.stdKey = key;
}

let busy = false;  // one refresh at a time: a slow one is not overtaken

async function refresh() {
  if (busy) return;
  busy = true;
  try {
    const filter = $('filter').value.trim();
    const list = await api('/api/sessions' + (filter ? '?filter=' + encodeURIComponent(filter) : ''));
    renderSessions(list.sessions || []);
    if (view.selected) {
      const id = view.selected;
      const s = await api('/api/sessions/' + id);
      if (id !== view.selected) return;
      view.session = s;
      renderSession(s);
      const key = s.sample_count + '|' + s.model_version;
      if (key !== view.archiveKey) {
        view.archive = await api(`/api/sessions/${id}/archive`);
        view.archiveKey = key;
      }
      const samples = (view.archive && view.archive.samples) || [];
      await refreshStd(s, samples);
      const names = dimNames(s.config);
      const dx = Number($('dim-x').value), dy = Number($('dim-y').value);
      drawSamples(samples);
      drawStates(samples, s.last_plan, dx, dy, names, s.config.state_dim);
      drawStd(view.std, samples, names);
      drawObjectives(view.objectives);
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
  refresh();
  setInterval(refresh, REFRESH_MS);
}

start();
