/* pneucore page: vanilla JS, no build step. Talks to the REST API of app/ (SI units, absolute pressures).
 *
 * State lives in `S`: the current model and scenario as the API's JSON (every field the page
 * does not show is kept untouched), the effect catalog, the datasets, the last results and the
 * refinement session. Inputs carry `data-field` (the API's dotted path, e.g. model.jack.rod_a)
 * and `data-scale` (SI value = displayed value x scale), so 422 errors land next to their field.
 */
'use strict';

const $ = (sel, root = document) => root.querySelector(sel);
const $$ = (sel, root = document) => Array.from(root.querySelectorAll(sel));
const SESSION_KEY = 'pneucore.session';
const P_ATM_DEFAULT = 101300;
const BAR = 1e5;
const C_UNITS = {
  dm3: { label: 'dm³/(s bar)', scale: 1e-8 },   // 1 dm^3/(s bar) = 1e-3 m^3 / (s 1e5 Pa)
  si: { label: 'm³/(s Pa)', scale: 1 },
};
const EDGE_COLORS = { 'P-A': '#1f77b4', 'A-R': '#ff7f0e', 'P-B': '#2ca02c', 'B-R': '#d62728' };
const HEAT_COLORS = { isothermal: '#1f77b4', adiabatic: '#d62728', convective: '#2ca02c' };
const SIGNAL_LABELS = {
  p_a: 'p_a', p_b: 'p_b', x: 'x', v: 'v', T_a: 'T_a', T_b: 'T_b', overall: 'overall',
  F: 'F (rod force)', q_a: 'q_a (flow into A)', q_b: 'q_b (flow into B)', q_s: 'q_s (supply flow)', p_s: 'p_s (supply)',
};
// the friction coefficients with their labels; units come from GET /api/units (paramUnit)
const FRICTION_COEFFS = [
  ['fc0', 'Coulomb force fc0'],
  ['fc_a', 'Coulomb per gauge p_a, fc_a'],
  ['fc_b', 'Coulomb per gauge p_b, fc_b'],
  ['kv0', 'Viscous coefficient kv0'],
  ['kv_a', 'Viscous per gauge p_a, kv_a'],
  ['kv_b', 'Viscous per gauge p_b, kv_b'],
];
// the friction map is computed by the service (POST /api/friction/preview), asked once typing pauses
const FRICTION_DEBOUNCE_MS = 150;
const PLOT_CONFIG = { responsive: true, displaylogo: false, modeBarButtonsToRemove: ['lasso2d', 'select2d'] };

const S = {
  presets: { models: [], scenarios: [] },
  model: null,
  scenario: null,
  effects: [],
  units: null,            // GET /api/units (parameter units: paramUnit)
  datasets: [],
  experiments: [],        // [{dataset_id}] currently selected
  sim: null,
  heatRuns: null,
  compare: null,
  measured: {},           // dataset id -> measurement {t, u, p_a, ...} (SI)
  session: null,
  diag: null,
  cUnit: 'dm3',
  runs: 0,                // simulations plotted (exposed as #panel-plots[data-runs])
  study: {
    rows: [],             // [{path, custom, kind, f: {grid, min, max, mean, std, median, sigma} as typed}]
    list: [],             // GET /api/studies
    res: null,            // GET /api/studies/{id}/results of the study shown
    metric: null,         // metric shown in the histogram, scatter and ranking
    param: null,          // parameter on the scatter's x axis
    poll: 0,              // token of the study being followed (a newer one stops older loops)
    following: null,      // id of the study whose progress is being polled
  },
};

/* ------------------------------------------------------------------ helpers */
function clone(x) { return x == null ? x : JSON.parse(JSON.stringify(x)); }
function esc(s) {
  return String(s).replace(/[&<>"']/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' }[c]));
}
function num(x, digits = 4) {
  // always digits or '–', never the given text: the result goes into HTML unescaped
  if (typeof x !== 'number') x = (typeof x === 'string' && x.trim() !== '') ? Number(x) : NaN;
  if (x === null || x === undefined || Number.isNaN(x)) return '–';
  if (x === 0) return '0';
  const a = Math.abs(x);
  if (a >= 1e5 || a < 1e-3) return x.toExponential(Math.max(digits - 1, 1)).replace('e+', 'e');
  return String(+x.toPrecision(digits));
}
function pct(x, digits = 2) {
  if (x === null || x === undefined || Number.isNaN(x)) return '–';
  return (x * 100).toFixed(digits);
}
function pval(p) {
  if (p === null || p === undefined) return '–';
  if (p === 0) return '< 1e-16';
  return p < 1e-3 ? p.toExponential(1) : p.toFixed(3);
}
function displayValue(si, scale) {
  if (si === null || si === undefined || si === '') return '';
  if (typeof si !== 'number') return String(si);
  return String(+(si / scale).toPrecision(8));
}
function parsePath(path) {
  // "model.valve.ports.P-A.C[2]" -> ["model","valve","ports","P-A","C",2]
  const out = [];
  for (const part of String(path).split('.')) {
    const m = part.match(/^([^\[\]]*)((?:\[\d+\])*)$/);
    if (!m) { out.push(part); continue; }
    if (m[1]) out.push(m[1]);
    for (const i of m[2].matchAll(/\[(\d+)\]/g)) out.push(Number(i[1]));
  }
  return out;
}
function normField(path) { return parsePath(path).join('.'); }
function getPath(root, parts) {
  let o = root;
  for (const p of parts) { if (o == null) return undefined; o = o[p]; }
  return o;
}
function setPath(root, parts, value) {
  let o = root;
  for (let i = 0; i < parts.length - 1; i++) {
    if (o[parts[i]] == null || typeof o[parts[i]] !== 'object') o[parts[i]] = typeof parts[i + 1] === 'number' ? [] : {};
    o = o[parts[i]];
  }
  o[parts[parts.length - 1]] = value;
}
function pAtm() { return (S.model && S.model.ambient && S.model.ambient.pressure) || P_ATM_DEFAULT; }

/* ------------------------------------------------------------------ status and errors */
function setStatus(msg, kind = 'info') {
  const box = $('#status');
  box.className = `status ${kind}`;
  $('#status-msg').textContent = msg;
}
function clearErrors() {
  $$('.field-error').forEach((e) => { e.textContent = ''; e.removeAttribute('data-error-for'); });
  $$('.invalid').forEach((e) => { e.classList.remove('invalid'); e.removeAttribute('aria-invalid'); });
  $('#status-errors').innerHTML = '';
}
function fieldElement(field) {
  const map = new Map();
  for (const el of $$('[data-field]')) {
    const k = normField(el.dataset.field);
    if (!map.has(k)) map.set(k, el);
  }
  const parts = parsePath(field).map(String);
  while (parts.length) {
    const el = map.get(parts.join('.'));
    if (el) return el;
    parts.pop();
  }
  return null;
}
function errorSlot(el) {
  const holder = el.closest('.field');
  let slot = holder ? $(':scope > .field-error', holder) : null;
  if (!slot) {
    slot = el.nextElementSibling && el.nextElementSibling.classList.contains('field-error') ? el.nextElementSibling : null;
  }
  if (!slot) {
    slot = document.createElement('span');
    slot.className = 'field-error';
    slot.setAttribute('role', 'alert');
    el.insertAdjacentElement('afterend', slot);
  }
  return slot;
}
/** Show one error next to the field whose data-field matches `field` (or its closest parent path),
 * or next to `target` when given (client-side checks that know the element). */
function fieldError(field, msg, target) {
  const el = target || fieldElement(field);
  if (el) {
    const slot = errorSlot(el);
    slot.textContent = slot.textContent ? `${slot.textContent}; ${msg}` : msg;
    if (!slot.dataset.errorFor) slot.dataset.errorFor = field;
    if (/^(INPUT|SELECT|TEXTAREA)$/.test(el.tagName)) { el.classList.add('invalid'); el.setAttribute('aria-invalid', 'true'); }
    if (el.closest('details')) el.closest('details').open = true;
  }
  const li = document.createElement('li');
  li.innerHTML = `<code>${esc(field || 'request')}</code>: ${esc(msg)}`;
  if (el) { li.classList.add('link'); li.addEventListener('click', () => { if (window.revealElement) revealElement(el); el.scrollIntoView({ block: 'center' }); if (el.focus) el.focus(); }); }
  $('#status-errors').appendChild(li);
  return el;
}
/** Turn an API error (422 detail list, or a detail string) into field errors + status. */
function showApiError(err, what, fieldMap) {
  if (!(err instanceof ApiError)) {
    setStatus(`${what} failed: ${err.message || err}`, 'error');
    return;
  }
  const detail = err.detail;
  if (Array.isArray(detail)) {
    for (const e of detail) {
      let field = e.field;
      if (field == null) {
        const loc = Array.isArray(e.loc) ? e.loc.slice(e.loc[0] === 'body' ? 1 : 0) : [];
        field = loc.map((p) => (typeof p === 'number' ? `[${p}]` : p)).join('.').replace(/\.\[/g, '[');
      }
      if (fieldMap) field = fieldMap(field, e);
      let msg = e.msg || JSON.stringify(e);
      if (e.type === 'measurement_error' && e.row != null) msg += ` (row ${e.row})`;
      const bp = /^scenario\.command\[(\d+)\]/.exec(field);
      if (bp) msg += ` (breakpoint ${Number(bp[1]) + 1})`;
      fieldError(field, msg);
    }
    const n = detail.length;
    setStatus(`${what} refused (HTTP ${err.status}): ${n} error${n === 1 ? '' : 's'}: ` +
      detail.map((e) => e.msg).join('; '), 'error');
  } else {
    setStatus(`${what} failed (HTTP ${err.status}): ${typeof detail === 'string' ? detail : JSON.stringify(detail)}`, 'error');
  }
}

/* ------------------------------------------------------------------ API */
class ApiError extends Error {
  constructor(status, detail) {
    super(typeof detail === 'string' ? detail : `HTTP ${status}`);
    this.status = status;
    this.detail = detail;
  }
}
async function api(method, path, body) {
  const opts = { method, headers: {} };
  if (body instanceof FormData) opts.body = body;
  else if (body !== undefined) { opts.headers['content-type'] = 'application/json'; opts.body = JSON.stringify(body); }
  let r;
  try { r = await fetch(path, opts); } catch (e) { throw new Error(`network error: ${e.message}`); }
  const text = await r.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch (e) { data = text; }
  if (!r.ok) throw new ApiError(r.status, data && data.detail !== undefined ? data.detail : (data || r.statusText));
  return data;
}
/** GET /api/units, asked once per page load (units.js and paramUnit share it). */
let UNITS_REQUEST = null;
function fetchUnits() { return UNITS_REQUEST || (UNITS_REQUEST = api('GET', '/api/units')); }
async function busy(btn, fn) {
  const buttons = btn ? [btn] : [];
  buttons.forEach((b) => { b.disabled = true; b.classList.add('busy'); });
  try { return await fn(); } finally {
    buttons.forEach((b) => { b.disabled = b.dataset.keepDisabled === 'true'; b.classList.remove('busy'); });
  }
}

/* ------------------------------------------------------------------ plots */
function baseLayout(extra = {}) {
  return Object.assign({
    margin: { l: 64, r: 64, t: 34, b: 46 },
    height: 270,
    font: { family: 'system-ui, -apple-system, Segoe UI, Roboto, sans-serif', size: 12 },
    legend: { orientation: 'h', x: 0, y: 1.02, yanchor: 'bottom', font: { size: 11 }, bgcolor: 'rgba(255,255,255,0)' },
    hovermode: 'x',
    paper_bgcolor: '#fff',
    plot_bgcolor: '#fff',
    modebar: { bgcolor: 'rgba(255,255,255,0)', color: '#9aa5b1', activecolor: '#1f6fb2' },
  }, extra);
}
function axis(title, extra = {}) {
  return Object.assign({ title: { text: title, standoff: 6 }, zeroline: false, gridcolor: '#e8ecf1', linecolor: '#9aa5b1', mirror: true, ticks: 'outside' }, extra);
}
function plot(id, traces, layout) {
  const el = document.getElementById(id);
  if (!window.Plotly) { el.textContent = 'Plotly failed to load (/static/plotly.min.js).'; return; }
  Plotly.react(el, traces, layout, PLOT_CONFIG);
}
function emptyNote(text) {
  return [{ text, xref: 'paper', yref: 'paper', x: 0.5, y: 0.5, showarrow: false, font: { color: '#8a94a0', size: 13 } }];
}
function eventShapes(events, yref = 'paper') {
  const colors = { command: '#8a94a0', slip: '#2ca02c', stick: '#9467bd', stop: '#d62728', reverse: '#ff7f0e' };
  return (events || []).map((e) => ({
    type: 'line', xref: 'x', yref, x0: e.t, x1: e.t, y0: 0, y1: 1,
    line: { color: colors[e.kind] || '#999', width: 1, dash: e.kind === 'command' ? 'dot' : 'dash' }, opacity: 0.6,
  }));
}
function eventMarkers(events, yFn) {
  if (!events || !events.length) return [];
  return [{
    x: events.map((e) => e.t), y: events.map(yFn), mode: 'markers', type: 'scatter', name: 'events',
    marker: { symbol: 'triangle-down', size: 8, color: '#555' },
    text: events.map((e) => `${e.kind} → ${e.mode}`), hovertemplate: 't = %{x:.4f} s<br>%{text}<extra>event</extra>',
  }];
}

/* ------------------------------------------------------------------ model panel */
function fieldInputs(prefix) { return $$(`[data-field^="${prefix}"]`).filter((e) => /^(INPUT|SELECT|TEXTAREA)$/.test(e.tagName)); }

function renderModel() {
  const m = S.model;
  if (!m) return;
  $('#model-name').textContent = m.name ? `${m.name}${m.description ? ' — ' + m.description : ''}` : '';
  for (const el of fieldInputs('model.')) {
    if (el.closest('#valve-tables') || el.closest('#effects-list') || el.closest('#friction-rows')) continue;
    writeInput(el, getPath({ model: m }, parsePath(el.dataset.field)));
  }
  $('#valve-kind').textContent = (m.valve && m.valve.kind) || '?';
  renderValveTables();
  renderFriction();
  renderEffects();
  plotValve();
  plotFriction();
}
function writeInput(el, v) {
  if (el.type === 'checkbox') el.checked = !!v;
  else if (el.tagName === 'SELECT') el.value = v == null ? '' : String(v);
  else el.value = displayValue(typeof v === 'number' ? v - Number(el.dataset.offset || 0) : v, Number(el.dataset.scale || 1));
}
function readInput(el) {
  if (el.type === 'checkbox') return el.checked;
  if (el.dataset.text) return el.value;   // a name or a description: text, even when it looks like a number
  if (el.tagName === 'SELECT') return el.value;
  const raw = el.value.trim();
  if (raw === '') return null;
  const v = Number(raw);
  if (!Number.isFinite(v)) return raw;  // let the API name the problem next to the field
  const scale = Number(el.dataset.scale || 1);
  const offset = Number(el.dataset.offset || 0);   // gauge display (static/units.js)
  return (scale === 1 ? v : +(v * scale).toPrecision(12)) + offset;
}
function onModelInput(ev) {
  const el = ev.target;
  if (!el.dataset || !el.dataset.field || !el.dataset.field.startsWith('model.')) return;
  const parts = parsePath(el.dataset.field).slice(1);
  setPath(S.model, parts, readInput(el));
  clearFieldError(el);
  plotValve();
  plotFriction();
  markStaleComparison();
  if (typeof refreshCircuit === 'function') refreshCircuit();   // static/circuit.js: fields and schematic
}
/** A comparison on screen that was made with another model says so (it is kept for reference,
 * not silently taken for the current model's). */
function markStaleComparison() {
  const box = $('#compare-summary');
  if (!box || !S.compare || !S.compare.model) return;
  const stale = S.compare.model !== JSON.stringify(S.model);
  box.classList.toggle('stale', stale);
  let note = $('#compare-stale');
  if (stale && !note) {
    note = document.createElement('p');
    note.id = 'compare-stale';
    note.className = 'stale-note';
    note.textContent = 'The model changed since this comparison: these errors and plots are the previous model\'s. Compare again.';
    box.prepend(note);
  } else if (!stale && note) note.remove();
}
function clearFieldError(el) {
  el.classList.remove('invalid');
  el.removeAttribute('aria-invalid');
  const holder = el.closest('.field');
  const slot = holder && $(':scope > .field-error', holder);
  if (slot && !$$('.invalid', holder).length) { slot.textContent = ''; slot.removeAttribute('data-error-for'); }
}

function renderValveTables() {
  const box = $('#valve-tables');
  const ports = (S.model.valve && S.model.valve.ports) || {};
  const cu = C_UNITS[S.cUnit];
  box.innerHTML = '';
  for (const [edge, t] of Object.entries(ports)) {
    const div = document.createElement('div');
    div.className = 'edge field';
    div.dataset.field = `model.valve.ports.${edge}`;
    div.id = `edge-${edge}`;
    const e = esc(edge);   // a port name comes from the user's model JSON
    const rows = (t.opening || []).map((_, i) => {
      const cell = (col, scale, unit) => {
        const id = `edge-${e}-${col}-${i}`;
        const v = t[col] ? t[col][i] : null;
        return `<td><label class="sr-only" for="${id}">${e} ${col} row ${i + 1} [${unit}]</label>` +
          `<input id="${id}" type="number" step="any" data-field="model.valve.ports.${e}.${col}[${i}]" data-scale="${scale}" value="${esc(displayValue(v, scale))}"></td>`;
      };
      return `<tr>${cell('opening', 1, '-')}${cell('C', cu.scale, cu.label)}${cell('b', 1, '-')}` +
        `<td><button type="button" class="icon del-row" data-edge="${e}" data-row="${i}" title="Remove row ${i + 1}" aria-label="Remove row ${i + 1} of ${e}">×</button></td></tr>`;
    }).join('');
    div.innerHTML = `<div class="edge-head"><span class="swatch" style="background:${EDGE_COLORS[edge] || '#555'}"></span><b>${esc(edge)}</b>` +
      `<button type="button" class="icon add-row" data-edge="${e}" title="Add a row" aria-label="Add a row to ${e}">+ row</button></div>` +
      `<table class="edge-table"><thead><tr><th>opening [-]</th><th>C [${cu.label}]</th><th>b [-]</th><th></th></tr></thead><tbody>${rows}</tbody></table>` +
      '<span class="field-error" role="alert"></span>';
    box.appendChild(div);
  }
}
function editValveRows(ev) {
  const btn = ev.target.closest('button');
  if (!btn) return;
  const t = S.model.valve.ports[btn.dataset.edge];
  if (!t) return;
  const cols = ['opening', 'C', 'b', 'm'].filter((c) => Array.isArray(t[c]));
  if (btn.classList.contains('add-row')) {
    const n = t.opening.length;
    const last = n ? t.opening[n - 1] : 0;
    for (const c of cols) t[c].push(n ? t[c][n - 1] : (c === 'b' ? 0.3 : c === 'm' ? 0.5 : 0));
    t.opening[n] = n ? +Math.min(last + 0.05, last < 0 ? 0 : 1.5).toFixed(4) : 0;
  } else if (btn.classList.contains('del-row')) {
    const i = Number(btn.dataset.row);
    for (const c of cols) t[c].splice(i, 1);
  } else return;
  renderValveTables();
  plotValve();
}
function plotValve() {
  const ports = (S.model && S.model.valve && S.model.valve.ports) || {};
  const cu = C_UNITS[S.cUnit];
  const traces = [];
  for (const [edge, t] of Object.entries(ports)) {
    const color = EDGE_COLORS[edge] || '#555';
    const op = (t.opening || []).map(Number);
    traces.push({ x: op, y: (t.C || []).map((c) => Number(c) / cu.scale), name: `C ${edge}`, mode: 'lines+markers', line: { color }, marker: { size: 5 } });
    traces.push({ x: op, y: (t.b || []).map(Number), name: `b ${edge}`, yaxis: 'y2', mode: 'lines+markers', line: { color, dash: 'dot' }, marker: { size: 4, symbol: 'square' } });
  }
  plot('valve-plot', traces, baseLayout({
    height: 260, title: { text: 'Edge conductance C and critical ratio b vs opening', font: { size: 12 }, x: 0.01, y: 0.98 },
    margin: { l: 64, r: 56, t: 58, b: 44 }, legend: { orientation: 'h', y: 1.03, yanchor: 'bottom', x: 0, font: { size: 10 }, bgcolor: 'rgba(255,255,255,0)' },
    xaxis: axis('spool opening u [-]'), yaxis: axis(`C [${cu.label}]`, { rangemode: 'tozero' }),
    yaxis2: axis('b [-]', { overlaying: 'y', side: 'right', range: [0, 1], tickmode: 'linear', dtick: 0.2, showgrid: false, mirror: false }),
    hovermode: 'closest',
  }));
}

function renderFriction() {
  const f = S.model.friction || (S.model.friction = {});
  f.extend = f.extend || {};
  const same = f.retract == null;
  $('#fric-retract-same').checked = same;
  const body = $('#friction-rows');
  body.innerHTML = FRICTION_COEFFS.map(([k, label]) => {
    const unit = paramUnit(`friction.extend.${k}`) || '?';
    const cell = (set) => {
      const id = `fric-${set}-${k}`;
      const src = set === 'retract' && same ? f.extend : f[set];
      const v = src ? src[k] : null;
      return `<td><div class="field"><label class="sr-only" for="${id}">${set} ${k} [${unit}]</label>` +
        `<input id="${id}" type="number" step="any" data-field="model.friction.${set}.${k}" value="${esc(displayValue(v, 1))}"` +
        `${set === 'retract' && same ? ' disabled' : ''}><span class="field-error" role="alert"></span></div></td>`;
    };
    return `<tr><th scope="row">${esc(label)} [${esc(unit)}]</th>${cell('extend')}${cell('retract')}</tr>`;
  }).join('');
}
function parseFrictionPressures() {
  const raw = $('#friction-pressures').value;
  const out = [];
  for (const tok of raw.split(/[,;]+/).map((s) => s.trim()).filter(Boolean)) {
    const [a, b] = tok.split('/').map((s) => Number(s.trim()));
    if (!Number.isFinite(a) || (tok.includes('/') && !Number.isFinite(b))) return { error: `"${tok}" is not a pressure in bar` };
    out.push([a, tok.includes('/') ? b : a]);
  }
  return { pairs: out.length ? out : [[1.013, 1.013]] };
}
const FRICTION = { timer: null, seq: 0, waiters: [] };
/** Redraw the friction map once typing pauses; the promise settles when the map is drawn
 *  (or refused). Every call in the pause shares the one request. */
function plotFriction() {
  clearTimeout(FRICTION.timer);
  const done = new Promise((resolve) => FRICTION.waiters.push(resolve));
  FRICTION.timer = setTimeout(async () => {
    const waiters = FRICTION.waiters.splice(0);
    try { await drawFriction(); } finally { waiters.forEach((w) => w()); }
  }, FRICTION_DEBOUNCE_MS);
  return done;
}
/** The friction force map from the service: the model's own law (Eq. 18-20 with the Stribeck,
 *  pressure and quadrant effects it has); at v = 0 the stick band between the static limits. */
async function drawFriction() {
  if (!S.model) return;
  const parsed = parseFrictionPressures();
  const slot = $('#friction-pressures').closest('.field').querySelector('.field-error');
  slot.textContent = parsed.error || '';
  if (parsed.error) return;
  const seq = ++FRICTION.seq;
  let res;
  try {
    res = await api('POST', '/api/friction/preview', {
      model: S.model, pressures: parsed.pairs.map(([a, b]) => ({ p_a: a * BAR, p_b: b * BAR })),
    });
  } catch (e) {
    if (seq !== FRICTION.seq) return;
    const d = e instanceof ApiError && Array.isArray(e.detail) && e.detail[0];
    slot.textContent = `friction map not drawn: ${d ? `${d.field || 'request'}: ${d.msg}` : (e.message || e)}`;
    return;
  }
  if (seq !== FRICTION.seq) return;   // a newer request is on its way
  const palette = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2'];
  const traces = res.curves.map((c, k) => {
    const [a, b] = parsed.pairs[k];
    const x = []; const y = [];
    res.velocities.forEach((v, i) => {
      if (v === 0 || c.force[i] == null) { x.push(0, 0); y.push(-c.static_retract, c.static_extend); return; }
      x.push(v); y.push(c.force[i]);
    });
    return { x, y, mode: 'lines', name: a === b ? `p = ${a} bar` : `p_a ${a} / p_b ${b} bar`, line: { color: palette[k % palette.length] } };
  });
  plot('friction-plot', traces, baseLayout({
    height: 260, title: { text: 'Friction force map (paper Fig. 4)', font: { size: 12 }, x: 0.01, y: 0.98 },
    margin: { l: 64, r: 20, t: 58, b: 44 }, legend: { orientation: 'h', y: 1.03, yanchor: 'bottom', x: 0, font: { size: 10 }, bgcolor: 'rgba(255,255,255,0)' },
    xaxis: axis('piston velocity v [m/s]', { zeroline: true, zerolinecolor: '#bbb' }), yaxis: axis('friction force F [N]', { zeroline: true, zerolinecolor: '#bbb' }),
    hovermode: 'closest',
  }));
}
function onRetractSame() {
  const f = S.model.friction || (S.model.friction = {});
  if ($('#fric-retract-same').checked) f.retract = null;
  else f.retract = clone(f.extend || {});
  renderFriction();
  plotFriction();
}

function catalog(name) { return S.effects.find((e) => e.name === name); }
function renderEffects() {
  const list = $('#effects-list');
  const effs = S.model.effects || (S.model.effects = {});
  const names = Object.keys(effs);
  list.innerHTML = names.length ? '' : '<p class="muted small">No extra effect: the paper\'s sixth-order model.</p>';
  for (const name of names) {
    const cat = catalog(name);
    const div = document.createElement('div');
    div.className = 'effect field';
    div.dataset.field = `model.effects.${name}`;
    div.id = `effect-${name}`;
    const params = Object.keys(effs[name]);
    const inputs = params.map((p) => {
      const meta = cat ? cat.parameters.find((q) => q.name === p) : null;
      const unit = meta ? meta.unit : '?';
      const id = esc(`eff-${name}-${p}`);
      return `<div class="field"><label for="${id}" title="${esc(meta ? meta.description : '')}">${esc(p)} [${esc(unit)}]</label>` +
        `<input id="${id}" type="number" step="any" data-field="model.effects.${esc(name)}.${esc(p)}" value="${esc(displayValue(effs[name][p], 1))}">` +
        '<span class="field-error" role="alert"></span></div>';
    }).join('');
    div.innerHTML = `<div class="effect-head"><b>${esc(name)}</b> <span class="muted small">${esc(cat ? cat.description : 'not in the catalog')}</span>` +
      `<button type="button" class="icon remove-effect" id="remove-${esc(name)}" data-effect="${esc(name)}" aria-label="Remove ${esc(name)}">Remove</button></div>` +
      `<div class="grid">${inputs}</div><span class="field-error" role="alert"></span>`;
    list.appendChild(div);
  }
  const sel = $('#effect-add-select');
  const keep = sel.value;
  sel.innerHTML = S.effects.filter((e) => !(e.name in effs))
    .map((e) => `<option value="${esc(e.name)}">${esc(e.name)}${e.observable_in && !e.observable_in.includes('locked') ? ' (free piston only)' : ''}</option>`).join('');
  if ([...sel.options].some((o) => o.value === keep)) sel.value = keep;
  describeEffect();
  refreshStudyHints();
  if (typeof refreshCircuit === 'function') refreshCircuit();   // static/circuit.js: fields and schematic
}
function describeEffect() {
  const e = catalog($('#effect-add-select').value);
  $('#effect-desc').textContent = e ? `${e.description}. Signature: ${e.signature}. Parameters: ` +
    e.parameters.map((p) => `${p.name} [${p.unit}] (default ${num(p.default)})`).join(', ') : '';
}
function addEffect() {
  const e = catalog($('#effect-add-select').value);
  if (!e) return;
  const params = {};
  for (const p of e.parameters) params[p.name] = p.default;
  S.model.effects = S.model.effects || {};
  S.model.effects[e.name] = params;
  renderEffects();
  plotFriction();   // a friction effect (Stribeck, pressure, quadrant) changes the map
  setStatus(`Effect ${e.name} added with its default parameters; simulate or compare to see it.`, 'ok');
}
function removeEffect(ev) {
  const btn = ev.target.closest('.remove-effect');
  if (!btn) return;
  delete S.model.effects[btn.dataset.effect];
  renderEffects();
  plotFriction();
  setStatus(`Effect ${btn.dataset.effect} removed.`, 'info');
}

/** A model brought in as JSON (a file or pasted text): the model itself, or an export that
 * holds one under "model" (a fitted model, a refine or diagnosis answer); checked by the service
 * (POST /api/calibrate/parameters parses it with the API's own rules) before it replaces the
 * page's model, so a bad file names its field and leaves the current model alone. */
async function useModelJson(text, source) {
  clearErrors();
  let m;
  try { m = JSON.parse(text); } catch (e) {
    fieldError('model.json', `not valid JSON: ${e.message}`);
    setStatus(`${source}: not valid JSON (${e.message}).`, 'error');
    return false;
  }
  if (m && typeof m === 'object' && !m.jack && m.model && typeof m.model === 'object') m = m.model;
  if (!m || typeof m !== 'object' || Array.isArray(m)) {
    fieldError('model.json', 'a JSON object (a model) is expected');
    setStatus(`${source}: a JSON object (a model) is expected.`, 'error');
    return false;
  }
  try {
    await api('POST', '/api/calibrate/parameters', { model: m });
  } catch (e) {
    showApiError(e, `${source}: the model`);
    return false;
  }
  S.model = m;
  renderModel();
  renderEffects();
  markStaleComparison();
  setStatus(`Model ${m.name || '(unnamed)'} loaded from ${source}.`, 'ok');
  return true;
}
function downloadModel() {
  const name = (S.model.name || 'model').replace(/[^\w.-]+/g, '_');
  const url = URL.createObjectURL(new Blob([JSON.stringify(S.model, null, 1)], { type: 'application/json' }));
  const a = document.createElement('a');
  a.href = url;
  a.download = `${name}.json`;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

async function loadModelPreset(name) {
  const m = await api('GET', `/api/presets/${encodeURIComponent(name)}`);
  S.model = m;
  $('#model-preset').value = name;
  clearErrors();
  renderModel();
  markStaleComparison();
  return m;
}

/* ------------------------------------------------------------------ scenario panel */
function renderScenario() {
  const s = S.scenario;
  if (!s) return;
  for (const el of fieldInputs('scenario.')) {
    if (el.id === 'scn-command') continue;
    writeInput(el, getPath({ scenario: s }, parsePath(el.dataset.field)));
  }
  $('#scn-command').value = (s.command || []).map(([t, u]) => `${num(t, 8)}, ${num(u, 8)}`).join('\n');
  $('#scenario-desc').textContent = s.description || s.name || '';
}
function parseCommand(text) {
  const out = [];
  const lines = text.split(/\r?\n/);
  for (let i = 0; i < lines.length; i++) {
    const line = lines[i].replace(/#.*/, '').trim();
    if (!line) continue;
    const parts = line.split(/[\s,;]+/).filter(Boolean);
    const t = Number(parts[0]); const u = Number(parts[1]);
    if (parts.length !== 2 || !Number.isFinite(t) || !Number.isFinite(u)) {
      return { error: `line ${i + 1} ("${line}"): expected "t, u" with two numbers` };
    }
    out.push([t, u]);
  }
  return { command: out };
}
function onScenarioInput(ev) {
  const el = ev.target;
  if (!el.dataset || !el.dataset.field || !el.dataset.field.startsWith('scenario.')) return;
  clearFieldError(el);
  if (el.id === 'scn-command') return;  // parsed on use
  setPath(S.scenario, parsePath(el.dataset.field).slice(1), readInput(el));
}
/** The scenario to send, or null (with the error shown) when the command text does not parse. */
function scenarioForRequest() {
  const p = parseCommand($('#scn-command').value);
  if (p.error) { fieldError('scenario.command', p.error); setStatus(`Scenario: ${p.error}`, 'error'); return null; }
  S.scenario.command = p.command.length ? p.command : null;
  const s = clone(S.scenario);
  for (const k of ['duration', 'sample_period', 'x0']) if (s[k] === null) delete s[k];
  if (s.command == null) delete s.command;
  return s;
}
function addStep() {
  const t = Number($('#step-time').value);
  const u = Number($('#step-opening').value);
  if (!Number.isFinite(t) || !Number.isFinite(u)) { setStatus('Step builder: time and opening must be numbers.', 'error'); return; }
  const p = parseCommand($('#scn-command').value);
  if (p.error) { clearErrors(); fieldError('scenario.command', p.error); return; }
  const cmd = p.command.filter(([tt]) => Math.abs(tt - t) > 1e-12);
  if (!cmd.length || cmd[0][0] > 0) { if (t > 0 && !cmd.some(([tt]) => tt === 0)) cmd.push([0, 0]); }
  cmd.push([t, u]);
  cmd.sort((a, b) => a[0] - b[0]);
  S.scenario.command = cmd;
  $('#scn-command').value = cmd.map(([a, b]) => `${num(a, 8)}, ${num(b, 8)}`).join('\n');
  const next = +(t + 0.1).toFixed(6);
  $('#step-time').value = next;
}
function clearCommand() {
  S.scenario.command = [[0, 0]];
  $('#scn-command').value = '0, 0';
}
async function loadScenarioPreset(name, btn) {
  clearErrors();
  let note = '';
  await busy(btn, async () => {
    const s = await api('GET', `/api/presets/${encodeURIComponent(name)}`);
    // Fig. 9 is the single-effect (3/2 valve) test; the others use the 4/2 spool valve.
    const wantKind = name === 'paper-fig9-switching' ? '3/2' : '4/2';
    if (S.model && S.model.valve && S.model.valve.kind !== wantKind) {
      const preset = wantKind === '3/2' ? 'paper-3way' : 'paper-4way';
      await loadModelPreset(preset);
      note = `The ${wantKind} valve is needed: model switched to the ${preset} preset. `;
    }
    S.scenario = s;
    renderScenario();
    setStatus(`Scenario ${name} loaded. ${note}`, 'info');
  });
  await simulate(btn, `${name}: ${note}`);
}

/* ------------------------------------------------------------------ simulation */
async function simulate(btn, note = '') {
  clearErrors();
  const scenario = scenarioForRequest();
  if (!scenario) return;
  setStatus('Simulating…', 'busy');
  await busy(btn || $('#btn-simulate'), async () => {
    try {
      const t0 = performance.now();
      const res = await api('POST', '/api/simulate', { model: S.model, scenario });
      S.sim = res;
      S.heatRuns = null;
      plotSimulation();
      $('#panel-plots').dataset.runs = String(++S.runs);
      const st = res.stats || {};
      const msg = `${res.series.t.length} samples, ${st.steps ?? '?'} steps, ${(res.events || []).length} events, ` +
        `${((performance.now() - t0) / 1000).toFixed(2)} s round trip (${st.method || ''})`;
      $('#sim-summary').textContent = msg + strokeSummary(st.stroke);
      setStatus(`${note}Simulation done: ${msg}.${res.status ? ' Solver: ' + res.message : ''}`, res.status ? 'error' : 'ok');
    } catch (e) { showApiError(e, 'Simulation'); }
  });
}
/** The stroke metrics of a simulation in words (pneucore/analysis/strokes.py, SMC's definitions), '' if none. */
function strokeSummary(sm) {
  if (!sm) return '';
  const f = (v, unit, digits = 3) => (typeof v === 'number' ? `${v.toPrecision(digits)} ${unit}` : null);
  const parts = [
    ['full stroke extending', f(sm.full_stroke_time_extend, 's')],
    ['full stroke retracting', f(sm.full_stroke_time_retract, 's')],
    ['stroke end speed', f(sm.end_speed_max, 'm/s')],
    ['impact energy', f(sm.end_energy_max, 'J')],
    ['air per cycle', f(sm.air_per_cycle_NL, 'NL')],
  ].filter(([, v]) => v !== null).map(([k, v]) => `${k} ${v}`);
  return parts.length ? ` · ${parts.join(', ')}` : '';
}
function plotSimulation() {
  const r = S.sim;
  if (typeof renderStrokeTable === 'function') renderStrokeTable(r && r.stats ? r.stats.stroke : null);   // static/strokes.js
  if (!r) { plotEmptySimulation(); return; }
  const s = r.series;
  const t = s.t;
  const ev = r.events || [];
  const shapes = eventShapes(ev);
  const P = plotUnit('Pa'), X = plotUnit('m'), V = plotUnit('m/s'), Q = plotUnit('kg/s');
  const bar = P.val;
  const pTraces = [];
  if (S.heatRuns) {
    for (const [hm, run] of Object.entries(S.heatRuns)) {
      pTraces.push({ x: run.series.t, y: bar(run.series.p_a), name: `p_a (${hm})`, line: { color: HEAT_COLORS[hm], width: 1.6 } });
      pTraces.push({ x: run.series.t, y: bar(run.series.p_b), name: `p_b (${hm})`, line: { color: HEAT_COLORS[hm], width: 1.6, dash: 'dash' } });
    }
  } else {
    pTraces.push({ x: t, y: bar(s.p_a), name: 'p_a', line: { color: '#1f77b4', width: 1.8 } });
    pTraces.push({ x: t, y: bar(s.p_b), name: 'p_b', line: { color: '#d62728', width: 1.8 } });
  }
  pTraces.push({ x: t, y: s.u, name: 'command u', yaxis: 'y2', line: { color: '#8a94a0', width: 1, shape: 'hv' } });
  const pmax = Math.max(...bar(s.p_a).concat(bar(s.p_b)).filter((v) => v != null));
  pTraces.push(...eventMarkers(ev, () => pmax * 1.04));
  plot('plot-pressure', pTraces, baseLayout({
    title: { text: S.heatRuns ? 'Chamber pressures under three heat models' : 'Chamber pressures', font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.995 },
    xaxis: axis('time t [s]'), yaxis: axis(`pressure [${P.label}]`),
    yaxis2: axis('command u [-]', { overlaying: 'y', side: 'right', showgrid: false, mirror: false, range: [-1.1, 1.1], tickmode: 'array', tickvals: [-1, -0.5, 0, 0.5, 1] }),
    shapes, margin: { l: 64, r: 64, t: 48, b: 46 },
  }));
  plot('plot-position', [
    { x: t, y: X.val(s.x), name: 'x', line: { color: '#2ca02c', width: 1.8 } },
  ], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`position x [${X.label}]`), shapes, showlegend: true }));
  plot('plot-velocity', [
    { x: t, y: V.val(s.v), name: 'v', line: { color: '#9467bd', width: 1.8 } },
  ], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`velocity v [${V.label}]`), shapes, showlegend: true }));
  const TK = plotUnit('K'), C = TK.val;
  const tTraces = [];
  if (S.heatRuns) {
    for (const [hm, run] of Object.entries(S.heatRuns)) {
      tTraces.push({ x: run.series.t, y: C(run.series.T_a), name: `T_a (${hm})`, line: { color: HEAT_COLORS[hm], width: 1.6 } });
      tTraces.push({ x: run.series.t, y: C(run.series.T_b), name: `T_b (${hm})`, line: { color: HEAT_COLORS[hm], width: 1.6, dash: 'dash' } });
    }
  } else {
    tTraces.push({ x: t, y: C(s.T_a), name: 'T_a', line: { color: '#1f77b4', width: 1.8 } });
    tTraces.push({ x: t, y: C(s.T_b), name: 'T_b', line: { color: '#d62728', width: 1.8 } });
  }
  plot('plot-temperature', tTraces, baseLayout({
    title: { text: 'Gas temperatures (paper Fig. 11)', font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.995 },
    xaxis: axis('time t [s]'), yaxis: axis(`temperature [${TK.label}]`), shapes, margin: { l: 64, r: 64, t: 48, b: 46 },
  }));
  plot('plot-flow', [
    { x: t, y: Q.val(s.q_a), name: 'q_a (into A)', line: { color: '#1f77b4', width: 1.6 } },
    { x: t, y: Q.val(s.q_b), name: 'q_b (into B)', line: { color: '#d62728', width: 1.6 } },
  ], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`valve flow [${Q.label}]`), shapes }));
}
function plotEmptySimulation() {
  const specs = [
    ['plot-pressure', `pressure [${plotUnit('Pa').label}]`], ['plot-position', `position x [${plotUnit('m').label}]`],
    ['plot-velocity', `velocity v [${plotUnit('m/s').label}]`], ['plot-temperature', `temperature [${plotUnit('K').label}]`],
    ['plot-flow', `valve flow [${plotUnit('kg/s').label}]`],
  ];
  for (const [id, y] of specs) {
    plot(id, [], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(y), annotations: emptyNote('Run a simulation (Simulate or a paper scenario)') }));
  }
}
function plotEmptyCompare() {
  plot('compare-plot', [], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`pressure [${plotUnit('Pa').label}]`),
    yaxis2: axis(`position x [${plotUnit('m').label}]`, { overlaying: 'y', side: 'right', showgrid: false, mirror: false }), annotations: emptyNote('Pick a dataset, then Compare') }));
  plot('residual-plot', [], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`pressure residual [${diffLabel('Pa')}]`),
    yaxis2: axis(`position residual [${plotUnit('m').label}]`, { overlaying: 'y', side: 'right', showgrid: false, mirror: false }), annotations: emptyNote('Residuals appear after a comparison') }));
}
async function overlayHeatModels() {
  clearErrors();
  const scenario = scenarioForRequest();
  if (!scenario) return;
  setStatus('Simulating under the isothermal, adiabatic and convective heat models…', 'busy');
  await busy($('#btn-heat-overlay'), async () => {
    try {
      const res = await api('POST', '/api/simulate/heat-models', { model: S.model, scenario });
      S.heatRuns = res.runs;
      if (!S.sim) S.sim = res.runs.convective || Object.values(res.runs)[0];
      S.sim = res.runs[S.model.heat && S.model.heat.model] || S.sim;
      plotSimulation();
      $('#panel-plots').dataset.runs = String(++S.runs);
      const TK = plotUnit('K');
      const peaks = Object.entries(res.runs).map(([k, r]) => `${k}: T_a ${num(Math.max(...TK.val(r.series.T_a)), 3)} ${TK.label} max`).join(', ');
      setStatus(`Heat models overlaid on the pressure and temperature plots (${peaks}).`, 'ok');
    } catch (e) { showApiError(e, 'Heat-model overlay'); }
  });
}

/* ------------------------------------------------------------------ measurement */
async function loadDatasets(selectValue) {
  S.datasets = await api('GET', '/api/datasets');
  const sel = $('#dataset-select');
  const groups = new Map();
  for (const d of S.datasets) {
    const g = d.sample || '';
    if (!groups.has(g)) groups.set(g, []);
    groups.get(g).push(d);
  }
  let html = '';
  for (const [g, list] of groups) {
    if (g) {
      html += `<optgroup label="sample: ${esc(g)} — ${esc(list[0].description || '')}">`;
      html += `<option value="sample:${esc(g)}">${esc(g)}: use the whole sample (${list.length} experiments)</option>`;
    } else html += '<optgroup label="uploaded">';
    for (const d of list) {
      html += `<option value="ds:${esc(d.id)}">${esc(d.name)} (${esc(d.signals.join(', '))}; ${d.scenario && d.scenario.locked ? 'locked' : 'free'})</option>`;
    }
    html += '</optgroup>';
  }
  sel.innerHTML = html;
  if (selectValue && [...sel.options].some((o) => o.value === selectValue)) sel.value = selectValue;
  onDatasetSelect();
}
/** The datasets of the picker's selected options, in order, each once: whole samples,
 * single datasets and the session's experiments may be combined (the method depends on
 * diagnosing a rig's tests together: a locked test identifies no friction and no mass). */
function selectedDatasets() {
  const out = [];
  const add = (d) => { if (d && !out.includes(d)) out.push(d); };
  for (const o of $('#dataset-select').selectedOptions) {
    const v = o.value || '';
    if (v.startsWith('sample:')) S.datasets.filter((d) => d.sample === v.slice(7)).forEach(add);
    else if (v.startsWith('ds:')) add(S.datasets.find((d) => d.id === v.slice(3)));
    else if (v === 'session' && S.session) S.session.experiments.forEach((e) => add(S.datasets.find((d) => d.id === e.dataset_id)));
  }
  return out;
}
function onDatasetSelect() {
  const list = selectedDatasets();
  // a session's experiments keep the context they were stored with (locked, x0, time offset)
  const kept = new Map((S.session ? S.session.experiments : []).concat(S.experiments || [])
    .filter((e) => e.dataset_id).map((e) => [e.dataset_id, e]));
  S.experiments = list.map((d) => {
    const k = kept.get(d.id);
    const e = { dataset_id: d.id };
    if (k && k.scenario) e.scenario = clone(k.scenario);
    if (k && k.time_offset != null) e.time_offset = k.time_offset;
    return e;
  });
  // a record without a command: the command proposed or entered (static/rigdata.js), plotted
  if (typeof showDatasetData === 'function') { applyCommands(); showDatasetData(list); }
  $('#dataset-info').innerHTML = list.map((d) => {
    const sc = d.scenario || {};
    return `<div><b>${esc(d.name)}</b>: ${d.n_samples} samples, signals ${esc(d.signals.join(', '))}, ` +
      `stored as ${sc.locked ? 'piston locked' : 'piston free'}${sc.x0 != null ? `, x0 = ${num(1e3 * sc.x0)} mm` : ''}</div>`;
  }).join('') + (list.length > 1 ? `<div>${list.length} experiments compared, calibrated and diagnosed together; each one's context below.</div>` : '') ||
    'No dataset selected.';
  renderExperimentSet(list);
  clearFieldError($('#dataset-select'));
}
/** One row per selected experiment: its own context (piston locked, x0 [mm], time offset [s]),
 * starting from what the dataset was stored with; an edit changes this request's scenario only. */
function renderExperimentSet(list) {
  if (!list.length) { $('#experiment-set').innerHTML = ''; return; }
  let h = '<table id="experiment-set-table" class="data"><thead><tr><th scope="col">experiment</th><th scope="col">samples</th>' +
    '<th scope="col">signals</th><th scope="col">locked</th><th scope="col">x0 [mm]</th><th scope="col">time offset [s]</th></tr></thead><tbody>';
  list.forEach((d, i) => {
    const e = S.experiments[i];
    const sc = e.scenario || d.scenario || {};
    h += `<tr data-index="${i}"><th scope="row">${esc(d.name)}</th><td class="num">${d.n_samples}</td><td>${esc(d.signals.join(', '))}</td>` +
      `<td><input type="checkbox" data-key="locked" aria-label="${esc(d.name)}: piston locked"${sc.locked ? ' checked' : ''}></td>` +
      `<td><input type="number" step="any" data-key="x0" aria-label="${esc(d.name)}: x0 [mm]" value="${sc.x0 != null ? num(1e3 * sc.x0) : ''}"></td>` +
      `<td><input type="number" step="any" data-key="time_offset" aria-label="${esc(d.name)}: time offset [s]" value="${e.time_offset != null ? num(e.time_offset) : ''}"></td></tr>`;
  });
  $('#experiment-set').innerHTML = h + '</tbody></table>';
  for (const input of $('#experiment-set').querySelectorAll('input')) {
    input.addEventListener('change', () => {
      const i = Number(input.closest('tr').dataset.index);
      const d = list[i], e = S.experiments[i];
      const sc = e.scenario || clone(d.scenario || {});
      if (input.dataset.key === 'locked') sc.locked = input.checked;
      else if (input.dataset.key === 'x0') sc.x0 = input.value === '' ? (d.scenario || {}).x0 : Number(input.value) / 1e3;
      else if (input.value === '') delete e.time_offset;
      else e.time_offset = Number(input.value);
      if (input.dataset.key !== 'time_offset') e.scenario = sc;
    });
  }
}
function selectExperiments(exps) {
  // choose the option of the dataset picker that matches a list of experiments
  const ids = exps.map((e) => e.dataset_id);
  const sel = $('#dataset-select');
  const bySample = new Map();
  for (const d of S.datasets) if (d.sample) { if (!bySample.has(d.sample)) bySample.set(d.sample, []); bySample.get(d.sample).push(d.id); }
  for (const [g, list] of bySample) if (JSON.stringify(list) === JSON.stringify(ids)) { sel.value = `sample:${g}`; onDatasetSelect(); return; }
  if (ids.length && ids.every((id) => S.datasets.some((d) => d.id === id))) {
    // several stored datasets: select each of them (the session's contexts are kept)
    for (const o of sel.options) o.selected = ids.includes(o.value.slice(3)) && o.value.startsWith('ds:');
    onDatasetSelect();
    return;
  }
  if (ids.length) {
    const opt = document.createElement('option');
    opt.value = 'session';
    opt.textContent = `session experiments (${ids.join(', ')})`;
    sel.prepend(opt);
    sel.value = 'session';
    onDatasetSelect();
  }
}
async function uploadDataset() {
  clearErrors();
  const file = $('#upload-file').files[0];
  if (!file) { fieldError('upload.file', 'choose a CSV file first'); setStatus('Upload: choose a CSV file first.', 'error'); return; }
  const fd = new FormData();
  fd.append('file', file);
  if ($('#upload-name').value.trim()) fd.append('name', $('#upload-name').value.trim());
  fd.append('locked', $('#upload-locked').checked ? 'true' : 'false');
  if ($('#upload-x0').value.trim() !== '') fd.append('x0', String(readInput($('#upload-x0'))));
  fd.append('ambient_pressure', String(pAtm()));   // the rig's ambient for gauge units (static/importer.js)
  const mapping = typeof importMapping === 'function' ? importMapping() : null;
  if (mapping) fd.append('columns', JSON.stringify(mapping));
  setStatus(`Uploading ${file.name}…`, 'busy');
  await busy($('#btn-upload'), async () => {
    try {
      const info = await api('POST', '/api/datasets', fd);
      await loadDatasets(`ds:${info.id}`);
      if (typeof showImportReport === 'function') showImportReport(info.import);
      const warn = info.import && info.import.warnings && info.import.warnings.length ? ` ${info.import.warnings.length} warning(s): see the import report.` : '';
      setStatus(`Dataset ${info.name} stored (${info.n_samples} samples, signals ${info.signals.join(', ')}).${warn}`, warn ? 'error' : 'ok');
    } catch (e) {
      showApiError(e, 'Upload', (field, err) => {
        if (field.startsWith('measurement.columns') || field === 'columns') return 'upload.columns';
        if (err.type === 'measurement_error' || field.startsWith('measurement') || field === 'file' || field === '') return 'upload.file';
        return `upload.${field}`;
      });
    }
  });
}
async function measured(id) {
  if (!S.measured[id]) S.measured[id] = (await api('GET', `/api/datasets/${encodeURIComponent(id)}`)).measurement;
  return S.measured[id];
}
function sameExperiments(a, b) {
  return JSON.stringify((a || []).map((e) => e.dataset_id)) === JSON.stringify((b || []).map((e) => e.dataset_id));
}
async function runCompare(opts = {}) {
  if (!opts.keepErrors) clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); setStatus('Compare: no dataset selected.', 'error'); return null; }
  setStatus('Comparing the model with the measurement…', 'busy');
  return busy($('#btn-compare'), async () => {
    try {
      const exps = clone(S.experiments);
      const res = await api('POST', '/api/compare', { model: S.model, experiments: exps, heat_models: false });
      S.compare = { result: res, experiments: exps, model: JSON.stringify(S.model) };
      await Promise.all(exps.map((e) => measured(e.dataset_id)));
      renderCompare();
      setStatus(`Comparison done: overall error ${pct(res.overall)} % (noise floor about ${pct(floorOf(res.noise_floor))} %).`, 'ok');
      if (!opts.noSession) await ensureSession();
      return res;
    } catch (e) { showApiError(e, 'Comparison', (f) => (f.startsWith('experiments') ? 'experiments' : f)); return null; }
  });
}
/** The overall noise floor from the per-signal ones: the RMS, as the service forms the overall
 * error and the diagnosis its floor (one figure on the page, the one the messages quote). */
function floorOf(o) { const v = Object.values(o || {}).filter((x) => typeof x === 'number'); return v.length ? Math.sqrt(v.reduce((a, b) => a + b * b, 0) / v.length) : null; }
function renderCompare() {
  const { result: c, experiments: exps } = S.compare;
  const signals = Object.keys(c.errors);
  // error per signal: all experiments, then each experiment, then the noise floor
  let h = '<table id="error-table-data" class="data"><thead><tr><th scope="col">signal</th><th scope="col">all experiments</th>';
  h += c.experiments.map((e) => `<th scope="col">${esc(e.name)}</th>`).join('') + '<th scope="col">noise floor</th></tr></thead><tbody>';
  for (const s of signals) {
    h += `<tr><th scope="row">${esc(s)}</th><td class="num" data-signal="${esc(s)}">${pct(c.errors[s])}</td>`;
    h += c.experiments.map((e) => `<td class="num">${e.errors && e.errors[s] != null ? pct(e.errors[s]) : '–'}</td>`).join('');
    h += `<td class="num muted">${pct(c.noise_floor && c.noise_floor[s])}</td></tr>`;
  }
  h += `<tr class="total"><th scope="row">overall</th><td class="num" data-signal="overall">${pct(c.overall)}</td>`;
  h += c.experiments.map((e) => `<td class="num">${pct(e.overall)}</td>`).join('') + `<td class="num muted">${pct(floorOf(c.noise_floor))}</td></tr></tbody></table>`;
  $('#error-table').innerHTML = h;
  // per phase (Table 2 layout: phases as rows, signals as columns)
  const phaseRows = [...Object.entries(c.phases || {}), ...Object.entries(c.piston_phases || {})];
  let p = '<table id="phase-table-data" class="data"><thead><tr><th scope="col">phase</th>' +
    signals.map((s) => `<th scope="col">${esc(s)}</th>`).join('') + '<th scope="col">overall</th></tr></thead><tbody>';
  for (const [name, row] of phaseRows) {
    p += `<tr><th scope="row">${esc(name)}</th>` + signals.map((s) => `<td class="num">${pct(row[s])}</td>`).join('') +
      `<td class="num"><b>${pct(row.overall)}</b></td></tr>`;
  }
  $('#phase-table').innerHTML = p + '</tbody></table>';
  $('#compare-summary').innerHTML = `Overall error <b id="compare-overall">${pct(c.overall)} %</b> over ${c.experiments.length} experiment(s); ` +
    `model <i>${esc(S.model.name || 'custom')}</i>${Object.keys(S.model.effects || {}).length ? ' + ' + esc(Object.keys(S.model.effects).join(' + ')) : ''}.` +
    (c.hints || []).map((h) => `<p class="context-hint warn" data-kind="${esc(h.kind)}">Check the context: ${esc(h.message)}</p>`).join('');
  // worst windows
  $('#failure-windows').innerHTML = (c.failure_windows || []).map((w, i) =>
    `<li><span class="win-tag">#${i + 1}</span> ${esc(w.description || `${w.experiment}: ${w.signal} ${w.t_start}-${w.t_end} s`)}` +
    `${w.share != null ? ` <span class="muted">(${pct(w.share, 0)} % of the residual energy)</span>` : ''}</li>`).join('') ||
    '<li class="muted">No window stands out.</li>';
  plotCompare(c, exps);
  plotResiduals(c);
  if (typeof plotCompareBench === 'function') plotCompareBench(c, exps);   // F and q (static/identify.js)
  markStaleComparison();
}
/** A stacked layout with one row per experiment, each with a left and an overlaying right axis. */
function stackedLayout(n, left, right, titles, extra = {}) {
  const layout = baseLayout(Object.assign({ height: Math.max(300, 250 * n + 70), hovermode: 'x', margin: { l: 64, r: 64, t: 50, b: 86 } }, extra));
  // the legend goes under the plot: above it, it covered the first subplot's title
  layout.legend = Object.assign({}, layout.legend, { y: 0, yref: 'container', yanchor: 'bottom', x: 0, xanchor: 'left' });
  const gap = 0.12;
  const h = (1 - gap * (n - 1)) / n;
  const rows = [];
  layout.annotations = [];
  for (let i = 0; i < n; i++) {
    const top = 1 - i * (h + gap);
    const dom = [Math.max(0, top - h), top];
    const xi = i === 0 ? '' : String(i + 1);
    const yi = i === 0 ? '' : String(2 * i + 1);
    const y2i = String(2 * i + 2);
    layout[`xaxis${xi}`] = axis('time t [s]', { anchor: `y${yi}`, domain: [0, 1], matches: i ? 'x' : undefined });
    layout[`yaxis${yi}`] = axis(left, { domain: dom, anchor: `x${xi}` });
    layout[`yaxis${y2i}`] = axis(right, { overlaying: `y${yi}`, side: 'right', anchor: `x${xi}`, showgrid: false, mirror: false, tickmode: 'auto', nticks: 6 });
    layout.annotations.push({ text: `<b>${esc(titles[i])}</b>`, xref: 'paper', yref: 'paper', x: 0, y: top, yanchor: 'bottom', xanchor: 'left', showarrow: false, font: { size: 11 }, yshift: 2 });
    rows.push({ x: `x${xi}`, y: `y${yi}`, y2: `y${y2i}`, domain: dom });
  }
  return { layout, rows };
}
const SIG_COLORS = { p_a: '#1f77b4', p_b: '#d62728', x: '#2ca02c', v: '#9467bd', T_a: '#17becf', T_b: '#e377c2' };
const SIG_SI = { p_a: 'Pa', p_b: 'Pa', p_s: 'Pa', x: 'm', v: 'm/s' };
/** Signals the comparison's two axes hold (pressures; position, velocity, temperatures): the rod
 * force F [N] and the flows q_a, q_b, q_s [kg/s] have a plot of their own (identify.js) */
const onCompareAxes = (sig) => sig in SIG_SI || sig.startsWith('T');
/** A measured or simulated signal as the plots show it; `diff` for residuals (no gauge offset). */
function toDisplay(sig, arr, diff = false) {
  if (sig.startsWith('T')) return diff ? plotUnit('K').diff(arr) : plotUnit('K').val(arr);
  if (!SIG_SI[sig]) return arr;
  const u = plotUnit(SIG_SI[sig]);
  return diff ? u.diff(arr) : u.val(arr);
}
/** The unit of a difference of pressures: a gauge offset cancels, so 'bar g' reads 'bar'. */
function diffLabel(si) { return plotUnit(si).label.replace(/ (abs|g)$/, ''); }
function plotCompare(c, exps) {
  const n = c.experiments.length;
  const { layout, rows } = stackedLayout(n, `pressure [${plotUnit('Pa').label}]`, `position x [${plotUnit('m').label}]`, c.experiments.map((e) => e.name),
    { legend: { orientation: 'h', x: 0, y: 1.0, yanchor: 'bottom', yref: 'container' } });
  layout.legend = { orientation: 'h', x: 0.5, xanchor: 'center', y: 1, yanchor: 'top', yref: 'container', font: { size: 11 } };
  layout.margin.t = 56;
  const traces = [];
  const seen = new Set();
  const first = (g) => (seen.has(g) ? false : (seen.add(g), true));
  c.experiments.forEach((e, i) => {
    const meas = S.measured[exps[i] && exps[i].dataset_id] || {};
    for (const sig of Object.keys(e.simulated || {}).filter(onCompareAxes)) {
      const axisRef = sig.startsWith('p') ? rows[i].y : rows[i].y2;
      const color = SIG_COLORS[sig] || '#555';
      if (meas[sig]) {
        traces.push({ x: meas.t, y: toDisplay(sig, meas[sig]), xaxis: rows[i].x, yaxis: axisRef, mode: 'markers', name: `${sig} measured`,
          legendgroup: `${sig}m`, showlegend: first(`${sig}m`), marker: { size: 3.5, color, opacity: 0.35 } });
      }
      traces.push({ x: e.t, y: toDisplay(sig, e.simulated[sig]), xaxis: rows[i].x, yaxis: axisRef, mode: 'lines', name: `${sig} simulated`,
        legendgroup: `${sig}s`, showlegend: first(`${sig}s`), line: { color, width: 1.4 } });
    }
  });
  plot('compare-plot', traces, layout);
}
function plotResiduals(c, windows) {
  windows = windows || c.failure_windows || [];
  const n = c.experiments.length;
  const { layout, rows } = stackedLayout(n, `pressure residual [${diffLabel('Pa')}]`, `position residual [${plotUnit('m').label}]`, c.experiments.map((e) => e.name));
  layout.legend = { orientation: 'h', x: 0.5, xanchor: 'center', y: 1, yanchor: 'top', yref: 'container', font: { size: 11 } };
  layout.margin.t = 56;
  const traces = [];
  const seen = new Set();
  layout.shapes = [];
  c.experiments.forEach((e, i) => {
    for (const [sig, arr] of Object.entries(e.residuals || {}).filter(([sig]) => onCompareAxes(sig))) {
      traces.push({ x: e.t, y: toDisplay(sig, arr, true), xaxis: rows[i].x, yaxis: sig.startsWith('p') ? rows[i].y : rows[i].y2, mode: 'lines',
        name: `${sig} residual`, legendgroup: sig, showlegend: !seen.has(sig) && !!seen.add(sig), line: { color: SIG_COLORS[sig] || '#555', width: 1.2 } });
    }
    windows.forEach((w, k) => {
      if (w.experiment && w.experiment !== e.name) return;
      layout.shapes.push({ type: 'rect', xref: rows[i].x, yref: 'paper', x0: w.t_start, x1: w.t_end, y0: rows[i].domain[0], y1: rows[i].domain[1],
        fillcolor: '#ff9f1c', opacity: 0.22, line: { width: 0 }, layer: 'below' });
      layout.annotations.push({ text: `#${k + 1} ${esc(w.signal)}`, xref: rows[i].x, yref: 'paper', x: (w.t_start + w.t_end) / 2, y: rows[i].domain[1],
        yanchor: 'top', yshift: -12 * (k % 2), showarrow: false, font: { size: 10, color: '#a35a00' }, bgcolor: 'rgba(255,255,255,0.7)' });
    });
  });
  plot('residual-plot', traces, layout);
}

/* ------------------------------------------------------------------ sessions and history */
async function ensureSession() {
  if (S.session && sameExperiments(S.session.experiments, S.experiments)) return S.session;
  if (S.session) {
    // the data changed: the same session goes on (a new one only from "New session"), with a
    // version of the current model on the new experiments; the history marks the change
    const names = S.experiments.map((e) => e.dataset_id || e.name || 'inline').join(', ');
    try {
      const s = await api('POST', `/api/sessions/${encodeURIComponent(S.session.id)}/versions`,
        { model: S.model, experiments: clone(S.experiments), note: `experiments changed to ${names}` });
      setSession(s);
      return s;
    } catch (e) {
      if (!(e instanceof ApiError && e.status === 404)) throw e;   // deleted meanwhile: start one
    }
  }
  const name = $('#dataset-select').selectedOptions[0] ? $('#dataset-select').selectedOptions[0].textContent.split(':')[0] : 'session';
  const s = await api('POST', '/api/sessions', { name, model: S.model, experiments: clone(S.experiments) });
  setSession(s);
  return s;
}
function setSession(s) {
  S.session = s;
  if (s) localStorage.setItem(SESSION_KEY, s.id); else localStorage.removeItem(SESSION_KEY);
  renderHistory();
}
async function recordVersion(added, params) {
  await ensureSession();
  const s = await api('POST', `/api/sessions/${S.session.id}/versions`, { model: S.model, added: added || null, params: params || {} });
  setSession(s);
  return s;
}
/** Whether version `i` was compared on other experiments than version i - 1 (sessions stored
 * before versions recorded their experiments say nothing: null). */
function dataChangedAt(v, i) {
  if (i === 0 || !v[i].experiments || !v[i - 1].experiments) return false;
  return !sameExperiments(v[i].experiments, v[i - 1].experiments);
}
function renderHistory() {
  const s = S.session;
  if (!s) {
    $('#session-info').textContent = 'No session yet: the first comparison or diagnosis starts one.';
    plot('history-plot', [], baseLayout({ xaxis: axis('model version [-]'), yaxis: axis('overall error [%]'), annotations: emptyNote('No model version yet') }));
    $('#history-table').innerHTML = '';
    return;
  }
  $('#session-info').innerHTML = `Session <code id="session-id">${esc(s.id)}</code> “${esc(s.name)}”, ${s.versions.length} version(s), ` +
    `experiments: ${esc(s.experiments.map((e) => e.dataset_id || e.name || 'inline').join(', '))}`;
  const v = s.versions;
  plot('history-plot', [{
    x: v.map((q) => q.version), y: v.map((q) => (q.overall == null ? null : q.overall * 100)), mode: 'lines+markers+text', name: 'overall error',
    text: v.map((q) => (q.overall == null ? '' : `${pct(q.overall)} %`)), textposition: 'top right', line: { color: '#1f77b4', width: 2 }, marker: { size: 9 },
    customdata: v.map((q) => q.label), hovertemplate: '%{customdata}: %{y:.3f} %<extra></extra>',
  }], baseLayout({
    title: { text: 'Overall error per model version', font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.995 },
    xaxis: axis('model version [-]', { tickvals: v.map((q) => q.version), ticktext: v.map((q) => q.label), range: [-0.4, Math.max(v.length - 1, 1) + 0.6] }),
    yaxis: axis('overall error [%]', { range: [0, 1.22 * Math.max(1e-9, ...v.map((q) => (q.overall || 0) * 100))] }),
    showlegend: false, hovermode: 'closest', margin: { l: 64, r: 30, t: 40, b: 56 },
    // a dashed line where the experiments changed: errors either side are on other data
    shapes: v.map((q, i) => (dataChangedAt(v, i) ? { type: 'line', xref: 'x', yref: 'paper', x0: q.version - 0.5, x1: q.version - 0.5,
      y0: 0, y1: 1, line: { color: '#a35a00', width: 1.5, dash: 'dash' } } : null)).filter(Boolean),
  }));
  const sigs = [...new Set(v.flatMap((q) => Object.keys(q.errors || {})))];
  $('#history-table').innerHTML = '<table class="data"><thead><tr><th scope="col">version</th><th scope="col">change</th>' +
    sigs.map((q) => `<th scope="col">${esc(q)} [%]</th>`).join('') + '<th scope="col">overall [%]</th></tr></thead><tbody>' +
    v.map((q, i) => `<tr data-version="${q.version}"><td class="num">${q.version}${i > 0 && q.model && v[i - 1].model ? ` <button type="button" class="icon version-diff" data-index="${i}" title="What changed from version ${v[i - 1].version}">diff</button>` : ''}</td><td>${esc(q.label)}` +
      (dataChangedAt(v, i) ? ` <span class="badge data-changed" title="${esc(q.note || 'the experiments changed')}: the errors from here on are on other data">data changed</span>` : '') + `${q.params && Object.keys(q.params).length ? ` <span class="muted small">(${esc(Object.entries(q.params).map(([k, x]) => `${k} = ${num(typeof x === 'object' && x ? x.value : x)}`).join(', '))})</span>` : ''}</td>` +
      sigs.map((g) => `<td class="num">${pct(q.errors && q.errors[g])}</td>`).join('') + `<td class="num"><b>${pct(q.overall)}</b></td></tr>`).join('') +
    '</tbody></table>';
}
/** Open a stored session: its last version's model, its experiments (with their contexts)
 * and its history; it becomes the page's session (kept across reloads). */
async function openSession(id, verb = 'Opened') {
  const s = await api('GET', `/api/sessions/${encodeURIComponent(id)}`);
  const last = s.versions[s.versions.length - 1];
  S.session = s;
  localStorage.setItem(SESSION_KEY, s.id);
  if (last && last.model) { S.model = last.model; renderModel(); }
  selectExperiments(s.experiments);
  renderHistory();
  setStatus(`${verb} session ${s.id} “${s.name}” (${s.versions.length} version(s), last: ${last ? last.label : '?'}).`, 'ok');
  return s;
}
/** The changes from the previous version to this one (POST /api/models/diff), under the table. */
async function showVersionDiff(ev) {
  const btn = ev.target.closest('.version-diff');
  if (!btn || !S.session) return;
  const v = S.session.versions;
  const i = Number(btn.dataset.index);
  await busy(btn, async () => {
    try {
      const changes = await api('POST', '/api/models/diff', { before: v[i - 1].model, after: v[i].model });
      let box = $('#version-diff');
      if (!box) { box = document.createElement('div'); box.id = 'version-diff'; $('#history-table').after(box); }
      box.innerHTML = `<h3>Version ${v[i - 1].version} → ${v[i].version} (${esc(v[i].label)})</h3>` +
        (changes.length ? changesTable(changes, `${changes.length} value(s) changed`, true) : '<p class="muted small">The two models are the same.</p>');
    } catch (e) { showApiError(e, 'Comparing the versions'); }
  });
}
async function resumeSession() {
  const id = localStorage.getItem(SESSION_KEY);
  if (!id) { renderHistory(); return false; }
  try {
    await openSession(id, 'Resumed');
    return true;
  } catch (e) {
    localStorage.removeItem(SESSION_KEY);
    renderHistory();
    return false;
  }
}
async function newSession() {
  clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); setStatus('New session: no dataset selected.', 'error'); return; }
  await busy($('#btn-new-session'), async () => {
    try {
      S.session = null;
      await ensureSession();
      setStatus(`New session ${S.session.id} started with the current model as version 0.`, 'ok');
    } catch (e) { showApiError(e, 'New session', (f) => (f.startsWith('experiments') ? 'experiments' : f)); }
  });
}
async function recordCurrent() {
  clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); return; }
  await busy($('#btn-record-version'), async () => {
    try {
      const s = await recordVersion(null, {});
      const last = s.versions[s.versions.length - 1];
      setStatus(`Recorded ${last.label}: overall error ${pct(last.overall)} %.`, 'ok');
    } catch (e) { showApiError(e, 'Recording the version'); }
  });
}

/* ------------------------------------------------------------------ diagnosis */
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function runDiagnosis() {
  clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); setStatus('Diagnosis: no dataset selected.', 'error'); return; }
  const prog = $('#diag-progress');
  await busy($('#btn-diagnose'), async () => {
    try {
      prog.value = 0;
      prog.removeAttribute('data-done');
      $('#diag-step').textContent = 'submitting';
      setStatus('Diagnosis running…', 'busy');
      // the residual plot and the error tables show what the diagnosis starts from
      if (!S.compare || !sameExperiments(S.compare.experiments, S.experiments)) {
        if (!(await runCompare({ keepErrors: true }))) return;
      }
      await ensureSession();
      setStatus('Diagnosis running…', 'busy');
      $('#diag-step').textContent = 'submitting';
      const exps = clone(S.experiments);
      const known = typeof knownPaths === 'function' ? knownPaths() : [];
      const job = await api('POST', '/api/jobs/diagnose', { model: S.model, experiments: exps, known });
      let j = job;
      while (j.status === 'queued' || j.status === 'running') {
        prog.value = j.progress || 0;
        $('#diag-step').textContent = `${j.step} (${Math.round((j.progress || 0) * 100)} %)`;
        await sleep(300);
        j = await api('GET', `/api/jobs/${j.id}`);
      }
      if (j.status !== 'done') {
        $('#diag-step').textContent = `failed: ${j.error || j.status}`;
        setStatus(`Diagnosis failed: ${j.error || j.status}`, 'error');
        return;
      }
      prog.value = 1;
      prog.dataset.done = 'true';
      $('#diag-step').textContent = 'done (100 %)';
      S.diag = { result: j.result, experiments: exps, model: clone(S.model) };
      renderDiagnosis();
      setStatus(`Diagnosis done: ${j.result.message}`, 'ok');
    } catch (e) {
      $('#diag-step').textContent = 'refused';
      showApiError(e, 'Diagnosis', (f) => (f.startsWith('experiments') ? 'experiments' : f));
    }
  });
}
function renderDiagnosis() {
  const d = S.diag.result;
  const before = d.error_before ? d.error_before.overall : null;
  const verdict = d.verdict ? esc(d.verdict) : 'none (no catalog effect explains the residual)';
  $('#diag-verdict').innerHTML = `<div class="verdict-name">Verdict: <b id="diag-verdict-name">${verdict}</b></div><div>${esc(d.message)}</div>` +
    `<div class="muted small">Error before: ${pct(before)} % · noise floor ${pct(d.remaining && d.remaining.noise_floor != null ? d.remaining.noise_floor : floorOf(d.noise_floor))} %</div>` +
    `<div class="small" id="diag-error-explained">${esc(explainErrorBefore(d))}</div>`;
  $('#diag-residual-summary').textContent = d.residual_tests && d.residual_tests.summary ? `Residual tests: ${d.residual_tests.summary}` : '';
  const score = d.score_pass || [];
  $('#diag-score').innerHTML = score.length ? '<h3>Score test of every candidate (before refitting)</h3>' +
    '<table class="data"><thead><tr><th scope="col">rank</th><th scope="col">effect</th><th scope="col">LM statistic [-]</th>' +
    '<th scope="col">dof [-]</th><th scope="col">p-value [-]</th></tr></thead><tbody>' +
    score.map((q) => `<tr><td class="num">${q.rank ?? ''}</td><td>${esc(q.effect)}</td>` + (q.skipped
      ? `<td colspan="3" class="muted small">skipped: ${esc(q.skipped)}</td></tr>`
      : `<td class="num">${num(q.lm)}</td><td class="num">${q.dof ?? ''}</td><td class="num">${pval(q.p_value)}</td></tr>`)).join('') +
    '</tbody></table>' : '';
  const cards = $('#diag-cards');
  cards.innerHTML = '';
  (d.ranking || []).forEach((r, i) => {
    const card = document.createElement('article');
    card.className = `card${r.effect === d.verdict ? ' top' : ''}`;
    card.id = `card-${r.effect}`;
    card.dataset.effect = r.effect;
    const badges = ['significant', 'strong', 'material'].filter((k) => r[k]).map((k) => `<span class="badge">${k}</span>`).join(' ');
    const params = Object.entries(r.params || {}).map(([k, p]) => {
      // shown in the page's unit system (static/units.js)
      const u = typeof unitShow === 'function' ? unitShow(p.unit) : { unit: p.unit, scale: 1, offset: 0 };
      const v = (x) => (typeof x === 'number' ? (x - u.offset) / u.scale : x);
      return `<tr><th scope="row">${esc(k)}</th><td class="num">${num(v(p.value))} ± ${num(p.stderr / u.scale, 2)} ${esc(prettyUnit(u.unit || ''))}</td>` +
        `<td class="num">${p.ci95 ? `[${num(v(p.ci95[0]))}, ${num(v(p.ci95[1]))}]` : '–'}</td>${p.at_bound ? '<td class="warn">at bound</td>' : '<td></td>'}</tr>`;
    }).join('');
    card.innerHTML = `<header><span class="rank">#${i + 1}</span> <b>${esc(r.effect)}</b> ${badges}</header>` +
      `<p class="small muted">${esc(r.description || '')}</p>` +
      '<dl class="evidence">' +
      `<dt>Overall error</dt><dd><span class="err-before">${pct(r.error_before != null ? r.error_before : before)} %</span> → <b class="err-after">${pct(r.error_after_overall)} %</b></dd>` +
      `<dt>ΔBIC</dt><dd>${num(r.delta_bic, 4)}</dd><dt>p-value (LR test)</dt><dd>${pval(r.p_value)}</dd>` +
      (r.effective_samples != null && r.n_samples ? `<dt title="Samples counted by the LR test and BIC: each residual series weighs n / tau, tau its integrated autocorrelation time (coloured noise carries less information than white)">effective samples</dt>` +
        `<dd class="eff-samples">${Math.round(r.effective_samples)} of ${r.n_samples}</dd>` : '') + '</dl>' +
      (params ? `<table class="data params"><thead><tr><th scope="col">parameter</th><th scope="col">value ± std. error</th><th scope="col">95 % CI</th><th></th></tr></thead><tbody>${params}</tbody></table>` : '') +
      `<p class="explanation">${esc(r.explanation || '')}</p>` + changesTable(r.changes, `Adding ${r.effect} changes ${(r.changes || []).length} value(s) of the model`) +
      `<button type="button" class="${r.effect === d.verdict ? 'primary ' : ''}add-effect-btn" id="add-${esc(r.effect)}" data-effect="${esc(r.effect)}"` +
      `${r.model ? '' : ' disabled'} title="Take the refitted model (current model + ${esc(r.effect)}) as the new current model">Add ${esc(r.effect)} to the model</button>`;
    cards.appendChild(card);
  });
}
/** Why the diagnosis's "error before" is not the comparison's error: the diagnosis first refits
 * the uncertain base parameters (the null model), and every candidate is weighed against that.
 * The line names the refitted values that moved, and says they come with whatever is added. */
function explainErrorBefore(d) {
  const start = d.error_start ? d.error_start.overall : null;
  const before = d.error_before ? d.error_before.overall : null;
  if (start == null || before == null) return '';
  const moved = (d.refitted || []).filter((q) => typeof q.before === 'number' && typeof q.after === 'number' &&
    Math.abs(q.after - q.before) > (q.stderr || 0) && q.after !== q.before);
  if (!moved.length || Math.abs(start - before) <= 1e-4 * Math.max(start, 1e-12)) {
    return `Error before is your model's own error (${pct(start)} %): no base parameter was refitted.`;
  }
  const show = (q) => {
    const u = typeof unitShow === 'function' ? unitShow(q.unit) : { unit: q.unit, scale: 1, offset: 0 };
    const v = (x) => num((x - u.offset) / u.scale);
    return `${q.label || q.path} ${v(q.before)} → ${v(q.after)}${u.unit && u.unit !== '-' ? ` ${prettyUnit(u.unit)}` : ''}`;
  };
  return `Your model as given: ${pct(start)} % (the comparison's error). The diagnosis first refits the base parameters ` +
    `you left uncertain (${moved.map(show).join('; ')}), which alone gives ${pct(before)} %: that is "error before", ` +
    'against which each effect is weighed. Adding a finding takes these refitted values with it (listed in its changes)' +
    ((d.recalibrate || []).length ? '; "Apply the recalibration" takes them alone.' : '.');
}
/** Every parameter taking a candidate would change, before it is taken: the effect's own and
 * the base parameters recalibrated with it (before → after, in the page's units). */
function changesTable(changes, summary, open = false) {
  if (!changes || !changes.length) return '';
  const show = (x, u) => {
    if (typeof x !== 'number') return x == null ? '–' : esc(String(x));
    return num((x - u.offset) / u.scale);
  };
  const rows = changes.map((c) => {
    const u = c.kind === 'scaled' ? { unit: '× (scale)', scale: 1, offset: 0 }
      : (typeof unitShow === 'function' ? unitShow(c.unit) : { unit: c.unit, scale: 1, offset: 0 });
    return `<tr data-path="${esc(c.path)}"><th scope="row">${esc(c.path)}</th><td class="num">${show(c.before, u)}</td>` +
      `<td class="num">${show(c.after, u)}</td><td>${esc(prettyUnit(u.unit || ''))}</td></tr>`;
  }).join('');
  return `<details class="changes"${open ? ' open' : ''}><summary>${esc(summary)}</summary>` +
    '<table class="data"><thead><tr><th scope="col">parameter</th><th scope="col">now</th><th scope="col">after</th><th scope="col">unit</th></tr></thead>' +
    `<tbody>${rows}</tbody></table></details>`;
}
async function adoptEffect(ev) {
  const btn = ev.target.closest('.add-effect-btn');
  if (!btn || !S.diag) return;
  const r = (S.diag.result.ranking || []).find((q) => q.effect === btn.dataset.effect);
  if (!r || !r.model) return;
  clearErrors();
  await busy(btn, async () => {
    try {
      S.model = clone(r.model);
      renderModel();
      const params = {};
      for (const [k, p] of Object.entries(r.params || {})) params[k] = p.value;
      setStatus(`Adding ${r.effect} and recording a new model version…`, 'busy');
      const s = await recordVersion(r.effect, params);
      await runCompare({ keepErrors: true, noSession: true });
      const v = s.versions;
      const last = v[v.length - 1];
      const prev = v[v.length - 2];
      setStatus(`${r.effect} added (version ${last.version}): overall error ${pct(prev && prev.overall)} % → ${pct(last.overall)} %.`, 'ok');
      // the other cards were refitted on the previous model: adding one now would drop this effect
      S.diag.stale = true;
      $$('.add-effect-btn').forEach((b) => { b.disabled = true; b.dataset.keepDisabled = 'true'; });
      btn.textContent = `${r.effect} added`;
      const note = document.createElement('div');
      note.className = 'stale-note';
      note.textContent = `The model changed (+ ${r.effect}): run Diagnose again to rank the remaining effects on the new model.`;
      $('#diag-verdict').appendChild(note);
    } catch (e) { showApiError(e, `Adding ${r.effect}`); }
  });
}

/* ------------------------------------------------------------------ robustness study */
// Paths offered in the parameter picker (any other model path can be typed; see pneucore.spec.paths).
const STUDY_PATHS = [
  ['friction.extend.fc0', 'Coulomb force, extension'],
  ['friction.retract.fc0', 'Coulomb force, retraction'],
  ['friction.extend.kv0', 'viscous coefficient, extension'],
  ['supply.pressure', 'supply pressure (abs)'],
  ['jack.moving_mass', 'moving mass'],
  ['jack.load_force', 'load force'],
  ['heat.coefficient', 'convection coefficient h'],
  ['jack.dead_volume_a', 'dead volume A'],
  ['valve.ports.*.C', 'conductance C of every edge (scale)'],
];
const STUDY_CUSTOM = '__custom__';
const STUDY_KINDS = [['grid', 'grid (full factorial)'], ['uniform', 'uniform'], ['normal', 'normal'], ['lognormal', 'lognormal']];
// kind -> [key, label, required, unit override]; the API's field names (parameters.<path>.<key>)
const STUDY_FIELDS = {
  grid: [['grid', 'values', true]],
  uniform: [['min', 'min', true], ['max', 'max', true]],
  normal: [['mean', 'mean', true], ['std', 'std', true], ['min', 'min', false], ['max', 'max', false]],
  lognormal: [['median', 'median', true], ['sigma', 'sigma of ln x', true, '-'], ['min', 'min', false], ['max', 'max', false]],
};
// metrics come in SI; lengths, pressures and temperatures shown in the header's unit system
// (plotUnit); `diff` converts spreads (std)
const METHOD_NAMES = {
  prcc: 'partial rank correlation (PRCC) with Spearman',
  factorial_variance: 'variance decomposition of the full factorial (S_i, S_Ti)',
};
const DESIGN_NAMES = { monte_carlo: 'Monte Carlo', factorial: 'full factorial', mixed: 'grid × Monte Carlo' };

function prettyUnit(u) { return String(u || '').replace(/\^3/g, '³').replace(/\^2/g, '²'); }
/** How every plot shows a quantity in SI unit `si`: the header's unit switch (units.js).
 *  `val` converts a series, `diff` a difference (a residual, a spread: no gauge offset). */
function plotUnit(si) {
  const d = typeof unitShow === 'function' ? unitShow(si) : { unit: si, scale: 1, offset: 0 };
  const conv = (off) => (a) => a.map((v) => (v == null ? null : (v - off) / d.scale));
  return { label: prettyUnit(d.unit), val: conv(d.offset || 0), diff: conv(0) };
}
function metricDisplay(unit) {
  if (unit === 'm' || unit === 'Pa' || unit === 'K') {
    const u = plotUnit(unit);
    return { label: u.label, val: (v) => u.val([v])[0], diff: (v) => u.diff([v])[0] };
  }
  return { label: unit || '-', val: (v) => v, diff: (v) => v };
}
/** SI unit of the model parameter at `path` (GET /api/units, from pneucore.spec.paths); '' when unknown. */
function paramUnit(path) {
  const units = (S.units && S.units.parameters) || {};
  const p = String(path || '');
  // a valve scale factor has the same unit on every edge: the service lists it under '*'
  return units[p] || units[p.replace(/^valve\.ports\.[^.]+\./, 'valve.ports.*.')] || '';
}
/** Value of `path` in the current model (1 for valve scale factors), or null. */
function studyNominal(path) {
  if (!S.model || !path) return null;
  const parts = path.split('.');
  if (parts[0] === 'valve') return 1;
  if (parts[0] === 'effects' && parts.length === 3) {
    const have = S.model.effects && S.model.effects[parts[1]];
    if (have && typeof have[parts[2]] === 'number') return have[parts[2]];
    const e = catalog(parts[1]);
    const p = e && e.parameters.find((q) => q.name === parts[2]);
    return p ? p.default : null;
  }
  let v = getPath(S.model, parts);
  if (v == null && parts[0] === 'friction' && parts[1] === 'retract') v = getPath(S.model, ['friction', 'extend', parts[2]]);
  return typeof v === 'number' ? v : null;
}
function studyPathOptions() {
  const opts = STUDY_PATHS.slice();
  for (const [name, params] of Object.entries((S.model && S.model.effects) || {})) {
    for (const p of Object.keys(params)) opts.push([`effects.${name}.${p}`, `${name}: ${p}`]);
  }
  return opts;
}
/** Starting values of a row from the parameter's value in the current model (±20 %, 5 % std). */
function studyDefaults(path, kind) {
  const v = studyNominal(path);
  if (v == null) return {};
  const r = (x) => String(+x.toPrecision(6));
  const a = Math.abs(v) || 1;
  if (kind === 'grid') return { grid: [v - 0.2 * a, v, v + 0.2 * a].map(r).join(', ') };
  if (kind === 'uniform') return { min: r(v - 0.2 * a), max: r(v + 0.2 * a) };
  if (kind === 'normal') return { mean: r(v), std: r(0.05 * a) };
  return { median: r(v > 0 ? v : 1), sigma: '0.1' };
}
function nominalText(path) {
  if (String(path).startsWith('valve.')) return 'scale factor on the table: 1 = as given';
  const v = studyNominal(path);
  return v == null ? (path ? 'not in the current model' : '') : `current model: ${+v.toPrecision(6)} ${prettyUnit(paramUnit(path))}`;
}

function addStudyRow(path, kind = 'uniform', values) {
  const used = new Set(S.study.rows.map((r) => r.path));
  if (typeof path !== 'string') path = (STUDY_PATHS.find(([p]) => !used.has(p)) || STUDY_PATHS[0])[0];
  S.study.rows.push({ path, custom: !studyPathOptions().some(([p]) => p === path), kind, f: values || studyDefaults(path, kind) });
  renderStudyRows();
}
function renderStudyRows() {
  const box = $('#study-param-rows');
  box.innerHTML = S.study.rows.length ? S.study.rows.map(studyRowHtml).join('')
    : '<p class="muted small">No parameter yet: add one.</p>';
  updateRunCount();
}
function studyRowHtml(r, i) {
  const opts = studyPathOptions();
  const custom = r.custom || !opts.some(([p]) => p === r.path);
  const unit = prettyUnit(paramUnit(r.path)) || 'SI unit';
  const id = (k) => `sp-${i}-${k}`;
  const pathSel = opts.map(([p, d]) => `<option value="${esc(p)}"${!custom && p === r.path ? ' selected' : ''}>${esc(p)} — ${esc(d)}</option>`).join('') +
    `<option value="${STUDY_CUSTOM}"${custom ? ' selected' : ''}>other path (type it)…</option>`;
  const kindSel = STUDY_KINDS.map(([k, d]) => `<option value="${k}"${k === r.kind ? ' selected' : ''}>${esc(d)}</option>`).join('');
  const fields = STUDY_FIELDS[r.kind].map(([k, label, req, u]) => {
    const grid = k === 'grid';
    return `<div class="field${grid ? ' sp-wide' : ''}"><label for="${id(k)}">${esc(label)} [${esc(u || unit)}]` +
      `${grid ? ', comma-separated' : ''}${req ? '' : ' <span class="muted">(optional)</span>'}</label>` +
      `<input id="${id(k)}" type="${grid ? 'text' : 'number'}" step="any" data-key="${k}" data-field="parameters.${esc(r.path)}.${k}"` +
      ` value="${esc(r.f[k] ?? '')}"${req ? '' : ' placeholder="none"'}${grid ? ' spellcheck="false"' : ''}><span class="field-error" role="alert"></span></div>`;
  }).join('');
  return `<div class="study-param field" id="study-param-${i}" data-row="${i}" data-field="parameters.${esc(r.path)}">` +
    '<div class="sp-head">' +
    `<span class="sp-num" title="parameter ${i + 1}">${i + 1}</span>` +
    `<div class="field"><label for="${id('path')}">Parameter path [-]</label><select id="${id('path')}" class="sp-path">${pathSel}</select>` +
    (custom ? `<label class="sr-only" for="${id('custom')}">Custom parameter path [-]</label>` +
      `<input id="${id('custom')}" class="sp-custom" type="text" value="${esc(r.path)}" placeholder="e.g. jack.bore or effects.piston_leakage.conductance" spellcheck="false">` : '') +
    '</div>' +
    `<div class="field"><label for="${id('kind')}">Kind [-]</label><select id="${id('kind')}" class="sp-kind" data-field="parameters.${esc(r.path)}.distribution">${kindSel}</select></div>` +
    `<button type="button" class="icon sp-remove" id="${id('remove')}" aria-label="Remove parameter ${i + 1}" title="Remove this parameter">×</button>` +
    '</div>' +
    `<div class="sp-values">${fields}</div>` +
    `<div class="sp-nominal muted">${esc(nominalText(r.path))}</div>` +
    '<span class="field-error" role="alert"></span></div>';
}
/** The path changed while typing: move the row's data-field attributes along (errors must find them). */
function retargetStudyRow(i) {
  const row = $(`#study-param-${i}`);
  const path = S.study.rows[i].path;
  row.dataset.field = `parameters.${path}`;
  $$('[data-key]', row).forEach((el) => { el.dataset.field = `parameters.${path}.${el.dataset.key}`; });
  $('.sp-kind', row).dataset.field = `parameters.${path}.distribution`;
}
function refreshStudyHints() {
  // the picker lists the current model's effects: redraw the rows when they changed
  const key = studyPathOptions().map(([p]) => p).join('|');
  if (S.study.optionsKey !== undefined && key !== S.study.optionsKey) { S.study.optionsKey = key; renderStudyRows(); return; }
  S.study.optionsKey = key;
  S.study.rows.forEach((r, i) => {
    const el = $(`#study-param-${i} .sp-nominal`);
    if (el) el.textContent = nominalText(r.path);
  });
}
function studyRowOf(el) {
  const row = el.closest('.study-param');
  return row ? Number(row.dataset.row) : -1;
}
function onStudyRowChange(ev) {
  const el = ev.target;
  const i = studyRowOf(el);
  if (i < 0) return;
  const r = S.study.rows[i];
  if (el.classList.contains('sp-path')) {
    if (el.value === STUDY_CUSTOM) {
      r.custom = true;
      renderStudyRows();
      $(`#sp-${i}-custom`).focus();
      return;
    }
    r.custom = false;
    r.path = el.value;
    r.f = studyDefaults(r.path, r.kind);
    renderStudyRows();
  } else if (el.classList.contains('sp-custom')) {
    r.path = el.value.trim();
    const filled = STUDY_FIELDS[r.kind].some(([k]) => String(r.f[k] ?? '').trim() !== '');
    if (!filled) r.f = studyDefaults(r.path, r.kind);
    renderStudyRows();
  } else if (el.classList.contains('sp-kind')) {
    r.kind = el.value;
    const d = studyDefaults(r.path, r.kind);
    for (const [k, , req] of STUDY_FIELDS[r.kind]) if (req && String(r.f[k] ?? '').trim() === '' && d[k] != null) r.f[k] = d[k];
    renderStudyRows();
  }
}
function onStudyRowInput(ev) {
  const el = ev.target;
  const i = studyRowOf(el);
  if (i < 0) return;
  const r = S.study.rows[i];
  if (el.classList.contains('sp-custom')) { r.path = el.value.trim(); retargetStudyRow(i); return; }
  if (el.dataset.key) {
    r.f[el.dataset.key] = el.value;
    clearFieldError(el);
    const slot = $(':scope > .field-error', el.closest('.study-param'));
    if (slot) { slot.textContent = ''; slot.removeAttribute('data-error-for'); }
    updateRunCount();
  }
}
function onStudyRowClick(ev) {
  const btn = ev.target.closest('.sp-remove');
  if (!btn) return;
  S.study.rows.splice(studyRowOf(btn), 1);
  renderStudyRows();
}
function parseGrid(text) {
  const toks = String(text || '').split(/[\s,;]+/).filter(Boolean);
  if (!toks.length) return { error: 'give at least one value' };
  const bad = toks.find((t) => !Number.isFinite(Number(t)));
  if (bad !== undefined) return { error: `"${bad}" is not a number` };
  return { values: toks.map(Number) };
}
function updateRunCount() {
  const rows = S.study.rows;
  let grid = 1;
  for (const r of rows.filter((q) => q.kind === 'grid')) { const g = parseGrid(r.f.grid); grid *= g.values ? g.values.length : NaN; }
  const random = rows.some((r) => r.kind !== 'grid');
  const samples = Number($('#study-samples').value);
  const n = random ? grid * samples : grid;
  $('#study-nruns').textContent = !rows.length ? '' : !Number.isFinite(n) ? '' :
    random ? `${grid > 1 ? `${grid} grid points × ` : ''}${samples} samples = ${n} runs` : `${n} runs (full factorial; samples not used)`;
}
function numOrRaw(text) {
  const raw = String(text ?? '').trim();
  if (raw === '') return null;
  const v = Number(raw);
  return Number.isFinite(v) ? v : raw;   // the API names a non-number next to its field
}
/** The POST /api/studies body, or null (errors shown next to the rows) when the form is incomplete. */
function studyRequest(scenario) {
  let bad = 0;
  const parameters = {};
  const seen = new Map();
  if (!S.study.rows.length) { fieldError('parameters', 'add at least one parameter to vary'); bad++; }
  S.study.rows.forEach((r, i) => {
    const row = $(`#study-param-${i}`);
    const path = (r.path || '').trim();
    if (!path) { fieldError(`parameters (row ${i + 1})`, 'type a parameter path', row); bad++; return; }
    if (seen.has(path)) {
      fieldError(`parameters.${path}`, `${path} is already varied by parameter ${seen.get(path) + 1}`, row); bad++; return;
    }
    seen.set(path, i);
    if (r.kind === 'grid') {
      const g = parseGrid(r.f.grid);
      if (g.error) { fieldError(`parameters.${path}.grid`, g.error, $(`#sp-${i}-grid`)); bad++; return; }
      parameters[path] = { grid: g.values };
      return;
    }
    const spec = { distribution: r.kind };
    for (const [k, , req] of STUDY_FIELDS[r.kind]) {
      const v = numOrRaw(r.f[k]);
      if (v !== null || req) spec[k] = v;   // a missing required value: the API says so next to it
    }
    parameters[path] = spec;
  });
  if (bad) { setStatus(`Study: ${bad} problem${bad > 1 ? 's' : ''} in the parameter table.`, 'error'); return null; }
  const random = S.study.rows.some((r) => r.kind !== 'grid');
  const body = { model: S.model, scenario, parameters, samples: random ? numOrRaw($('#study-samples').value) : null };
  const seed = numOrRaw($('#study-seed').value);
  if (seed !== null) body.seed = seed;
  body.scheduler = $('#study-scheduler').value.trim() || null;
  return body;
}
function setStudyProgress(stored, n, step) {
  const prog = $('#study-progress');
  prog.max = Math.max(n || 0, 1);
  prog.value = Math.min(stored || 0, prog.max);
  $('#study-progress-text').textContent = `${stored || 0}/${n || 0}`;
  if (step != null) $('#study-step').textContent = step;
}
async function runStudy() {
  clearErrors();
  const scenario = scenarioForRequest();
  if (!scenario) return;
  const body = studyRequest(scenario);
  if (!body) return;
  await busy($('#btn-study-run'), async () => {
    try {
      delete $('#study-progress').dataset.done;
      setStudyProgress(0, 0, 'submitting');
      setStatus('Starting the study…', 'busy');
      const r = await api('POST', '/api/studies', body);
      setStatus(`Study ${r.id}: ${r.n_runs} runs on ${body.scheduler ? `cluster “${body.scheduler}”` : 'the default cluster'}…`, 'busy');
      loadStudies();
      await followStudy(r.id, r.job_id, r.n_runs);
    } catch (e) {
      $('#study-step').textContent = 'refused';
      showApiError(e, 'Study');
    }
  });
}
/** Poll GET /api/studies/{id} every 300 ms until its job ends, then show the results. */
async function followStudy(id, jobId, nRuns) {
  const token = ++S.study.poll;
  S.study.following = id;
  try {
    return await pollStudy(id, jobId, nRuns, token);
  } finally {
    if (token === S.study.poll) S.study.following = null;
  }
}
async function pollStudy(id, jobId, nRuns, token) {
  const prog = $('#study-progress');
  delete prog.dataset.done;
  prog.dataset.study = id;
  setStudyProgress(0, nRuns || 0, 'queued');
  const stopped = () => token !== S.study.poll;
  for (;;) {
    if (stopped()) return false;
    let st;
    try {
      st = await api('GET', `/api/studies/${encodeURIComponent(id)}`);
    } catch (e) {
      // a service that writes the study row only when its job starts: meanwhile ask the job
      if (!(e instanceof ApiError && e.status === 404 && jobId)) throw e;
      const j = await api('GET', `/api/jobs/${encodeURIComponent(jobId)}`);
      if (stopped()) return false;
      if (j.status === 'error') { studyFailed(id, j.error); return false; }
      if (j.status === 'done') throw e;   // finished, yet no study: it was deleted
      setStudyProgress(0, nRuns || 0, `${j.status}: ${j.step}`);
      await sleep(300);
      continue;
    }
    if (stopped()) return false;
    const job = st.job;
    setStudyProgress(st.stored, st.n_runs, job ? `${job.step}` : st.status);
    if (job && (job.status === 'queued' || job.status === 'running')) {
      setStatus(`Study ${id} ${job.status}: ${st.stored}/${st.n_runs} runs stored${st.failed ? `, ${st.failed} failed` : ''}.`, 'busy');
      await sleep(300);
      continue;
    }
    if (job && job.status === 'error') { studyFailed(id, job.error, st); return false; }
    if (st.status !== 'done') {
      $('#study-step').textContent = st.status;
      setStatus(`Study ${id} is ${st.status} (${st.stored}/${st.n_runs} runs stored) and no job of this server runs it: ` +
        'resume it from the list of stored studies.', 'error');
      loadStudies();
      return false;
    }
    break;
  }
  prog.dataset.done = 'true';
  $('#study-step').textContent = `study ${id} done`;
  await loadStudyResults(id);
  if (stopped()) return false;
  await loadStudies();
  const r = S.study.res;
  setStatus(`Study ${id} done: ${r.stored}/${r.n_runs} runs stored, ${r.failed} failed.`, r.failed ? 'info' : 'ok');
  return true;
}
function studyFailed(id, error, st) {
  $('#study-step').textContent = `stopped: ${error || 'error'}`;
  setStatus(`Study ${id} stopped${st ? ` after ${st.stored}/${st.n_runs} runs` : ''}: ${error || 'error'}. ` +
    'The stored runs are kept; Resume it from the list of stored studies.', 'error');
  loadStudies();
}
async function loadStudies() {
  try {
    S.study.list = await api('GET', '/api/studies');
  } catch (e) {
    $('#study-list').innerHTML = `<p class="field-error">Could not list the studies: ${esc(e.message)}</p>`;
    return;
  }
  renderStudyList();
}
function renderStudyList() {
  const list = S.study.list.slice().sort((a, b) => b.created - a.created);
  const shown = S.study.res && S.study.res.id;
  if (!list.length) { $('#study-list').innerHTML = '<p class="muted small">No stored study yet.</p>'; return; }
  $('#study-list').innerHTML = '<table class="data" id="study-list-data"><thead><tr><th scope="col">study</th><th scope="col">created</th>' +
    '<th scope="col">status</th><th scope="col">runs stored [-]</th><th scope="col">failed [-]</th><th scope="col"></th></tr></thead><tbody>' +
    list.map((s) => {
      const sid = esc(s.id);
      const when = new Date(s.created * 1000);
      const actions = [
        `<button type="button" class="icon study-load" data-id="${sid}" id="study-load-${sid}"${s.stored ? '' : ' disabled'}` +
          ` title="Show the results of the stored runs">Load results</button>`,
        s.status === 'interrupted' ? `<button type="button" class="icon study-resume" data-id="${sid}" id="study-resume-${sid}"` +
          ' title="Compute the missing runs (stored runs are kept)">Resume</button>' : '',
        s.status === 'running' || s.status === 'queued' ? `<button type="button" class="icon study-follow" data-id="${sid}" id="study-follow-${sid}"` +
          ' title="Follow its progress">Follow</button>' : '',
      ].join(' ');
      return `<tr id="study-row-${sid}" data-status="${esc(s.status)}"${s.id === shown ? ' class="selected"' : ''}>` +
        `<td><code>${sid}</code>${s.name ? ` ${esc(s.name)}` : ''}</td>` +
        `<td class="small">${esc(when.toLocaleDateString())} ${esc(when.toLocaleTimeString())}</td>` +
        `<td><span class="st st-${esc(s.status)}">${esc(s.status)}</span></td>` +
        `<td class="num">${s.stored}/${s.n_runs}</td><td class="num">${s.failed}</td><td class="nowrap">${actions}</td></tr>`;
    }).join('') + '</tbody></table>';
}
async function onStudyListClick(ev) {
  const btn = ev.target.closest('button');
  if (!btn || !btn.dataset.id) return;
  const id = btn.dataset.id;
  clearErrors();
  setStatus(`Study ${id}: ${btn.textContent.toLowerCase()}…`, 'busy');
  await busy(btn, async () => {
    try {
      if (btn.classList.contains('study-load')) {
        await loadStudyResults(id);
        const r = S.study.res;
        if (!S.study.following) {   // the bar shows the study on screen unless another one is running
          setStudyProgress(r.stored, r.n_runs, `study ${id} loaded (${r.status})`);
          $('#study-progress').dataset.study = id;
        }
        setStatus(`Study ${id} loaded: ${r.stored}/${r.n_runs} runs stored, ${r.failed} failed (status ${r.status}).`, 'ok');
        renderStudyList();
      } else if (btn.classList.contains('study-resume')) {
        let r;
        try {
          r = await api('POST', `/api/studies/${encodeURIComponent(id)}/resume`);
        } catch (e) {
          if (!(e instanceof ApiError && e.status === 409)) throw e;
          await followStudy(id);   // already queued or running: follow it instead
          return;
        }
        setStatus(`Study ${id} resumed: computing the missing runs…`, 'busy');
        loadStudies();
        await followStudy(id, r.job_id);
      } else if (btn.classList.contains('study-follow')) {
        await followStudy(id);
      }
    } catch (e) { showApiError(e, `Study ${id}`); }
  });
}
async function loadStudyResults(id) {
  const res = await api('GET', `/api/studies/${encodeURIComponent(id)}/results`);
  S.study.res = res;
  const names = Object.keys(res.metrics);
  if (!names.includes(S.study.metric) || !res.metrics[S.study.metric].count) {
    // t95 first; a metric no run defines (t95 of a locked piston) gives way to one that varies
    const varies = (k) => res.metrics[k].count > 0 && res.metrics[k].std > 0;
    S.study.metric = [S.study.metric, 't95'].find((k) => names.includes(k) && varies(k)) ||
      names.find(varies) || names.find((k) => res.metrics[k].count > 0) || names[0];
  }
  const paths = res.parameters.map((p) => p.path);
  if (!paths.includes(S.study.param)) {
    const rk = res.sensitivity.ranking[S.study.metric];
    S.study.param = rk && rk.entries.length ? rk.entries[0].parameter : paths[0];
  }
  renderStudyResults();
  return res;
}
/** A typed-in value written back compactly: 600000 -> 6e5, 0.25 -> 0.25. */
function short(v) {
  if (typeof v !== 'number') return String(v);
  const t = +v.toPrecision(4);
  const a = Math.abs(t);
  return a !== 0 && (a >= 1e5 || a < 1e-3) ? t.toExponential().replace('e+', 'e') : String(t);
}
function specText(spec, unit) {
  const num = short;   // the summary echoes the definition as typed
  const u = unit && unit !== '-' ? ` ${prettyUnit(unit)}` : '';
  const b = (s) => (s.min != null || s.max != null ? ` in [${s.min != null ? num(s.min) : '−∞'}, ${s.max != null ? num(s.max) : '∞'}]${u}` : '');
  if (spec.grid) return `grid {${spec.grid.map((v) => num(v)).join(', ')}}${u}`;
  if (spec.distribution === 'uniform') return `uniform [${num(spec.min)}, ${num(spec.max)}]${u}`;
  if (spec.distribution === 'normal') return `normal (mean ${num(spec.mean)}, std ${num(spec.std)})${u}${b(spec)}`;
  if (spec.distribution === 'lognormal') return `lognormal (median ${num(spec.median)}${u}, sigma of ln x ${num(spec.sigma)})${b(spec)}`;
  return JSON.stringify(spec);
}
function renderStudyResults() {
  const res = S.study.res;
  if (!res) return;
  const def = res.definition || {};
  const m = def.model || {};
  const sc = def.scenario || {};
  $('#study-results').dataset.studyId = res.id;
  $('#study-title').innerHTML = `Results of study <code id="study-id">${esc(res.id)}</code>${res.name ? ` “${esc(res.name)}”` : ''}`;
  $('#study-summary').innerHTML = `${esc(DESIGN_NAMES[res.design] || res.design)}: <b>${res.stored}/${res.n_runs}</b> runs stored, ` +
    `<b>${res.failed}</b> failed, status ${esc(res.status)}${res.missing ? ` (${res.missing} missing: resume it)` : ''}. ` +
    `Model <i>${esc(m.name || 'custom')}${Object.keys(m.effects || {}).length ? ` + ${esc(Object.keys(m.effects).join(' + '))}` : ''}</i>, scenario <i>${esc(sc.name || 'custom')}</i> (${num(sc.duration)} s), seed ${esc(def.seed ?? 0)}. ` +
    'Parameters: ' + res.parameters.map((p) => `<code>${esc(p.path)}</code> ${esc(specText(p.spec, p.unit))}`).join('; ') + '.' +
    ` <a id="study-csv" href="${esc(`/api/studies/${encodeURIComponent(res.id)}/runs.csv`)}" download>Download the runs (CSV, units in the headers)</a>` +
    ` · <a id="study-npz" href="${esc(`/api/studies/${encodeURIComponent(res.id)}/runs.npz`)}" download title="NumPy archive: params and metrics matrices with their names and units; numpy.load reads it">(.npz)</a>`;
  $('#study-metric').innerHTML = Object.entries(res.metrics).map(([k, d]) =>
    `<option value="${esc(k)}"${k === S.study.metric ? ' selected' : ''}>${esc(k)} [${esc(metricDisplay(d.unit).label)}]</option>`).join('');
  $('#study-xparam').innerHTML = res.parameters.map((p) =>
    `<option value="${esc(p.path)}"${p.path === S.study.param ? ' selected' : ''}>${esc(p.path)} [${esc(prettyUnit(p.unit) || '-')}]</option>`).join('');
  $('#study-metric').disabled = false;
  $('#study-xparam').disabled = false;
  renderStudyTable();
  renderStudyMetric();
  const errs = res.errors || [];
  $('#study-errors').innerHTML = errs.length ? `<h3>Failed runs (${res.failed})</h3><ul class="study-errlist">` +
    errs.map((e) => `<li><b>${e.count}×</b> ${esc(e.message)} <span class="muted small">(runs ${esc(e.runs.join(', '))}${e.count > e.runs.length ? ', …' : ''})</span></li>`).join('') + '</ul>' : '';
}
function renderStudyMetric() {
  const res = S.study.res;
  const d = res.metrics[S.study.metric];
  $('#study-metric-def').innerHTML = d ? `<b>${esc(S.study.metric)}</b>: ${esc(d.definition)} (SI unit ${esc(d.unit)})` : '';
  $$('#study-table-data tbody tr').forEach((tr) => tr.classList.toggle('selected', tr.dataset.metric === S.study.metric));
  plotStudyHist();
  plotStudyScatter();
  renderStudyRanking();
}
function plotEmptyStudy() {
  plot('study-hist', [], baseLayout({ height: 320, xaxis: axis('metric [unit]'), yaxis: axis('runs [-]'), annotations: emptyNote('Run a study or load a stored one') }));
  plot('study-scatter', [], baseLayout({ height: 320, xaxis: axis('parameter [unit]'), yaxis: axis('metric [unit]'), annotations: emptyNote('Metric against a varied parameter') }));
}
function plotStudyHist() {
  const res = S.study.res;
  const m = S.study.metric;
  const info = res.metrics[m];
  const dsp = metricDisplay(info.unit);
  const vals = res.runs.metrics[m].filter((v) => v != null).map(dsp.val);
  const title = `${m} [${dsp.label}]`;
  const lost = [info.failed ? `${info.failed} failed` : '', info.undefined ? `${info.undefined} undefined` : ''].filter(Boolean).join(', ');
  const shapes = [];
  const annotations = [];
  if (vals.length) {
    [['5', '5 %'], ['50', 'median'], ['95', '95 %']].forEach(([q, label]) => {
      const x = info.percentiles[q];
      if (x == null) return;
      shapes.push({ type: 'line', xref: 'x', yref: 'paper', x0: dsp.val(x), x1: dsp.val(x), y0: 0, y1: 1, line: { color: q === '50' ? '#d62728' : '#ff7f0e', width: 1.4, dash: q === '50' ? 'solid' : 'dash' } });
      annotations.push({ text: label, x: dsp.val(x), xref: 'x', y: 1, yref: 'paper', yanchor: 'bottom', showarrow: false, font: { size: 10, color: '#a35a00' } });
    });
  } else annotations.push(...emptyNote(`No run defines ${m}`));
  plot('study-hist', vals.length ? [{
    type: 'histogram', x: vals, name: m, nbinsx: Math.max(6, Math.min(40, Math.round(2 * Math.sqrt(vals.length)))),
    marker: { color: '#1f77b4', line: { color: '#fff', width: 1 } }, hovertemplate: `${esc(m)} %{x}<br>%{y} runs<extra></extra>`,
  }] : [], baseLayout({
    height: 320, title: { text: `Distribution of ${m}: n = ${vals.length} of ${res.stored} runs${lost ? ` (${lost})` : ''}`, font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.98 },
    xaxis: axis(title), yaxis: axis('runs [-]'), bargap: 0.04, showlegend: false, hovermode: 'closest', shapes, annotations,
    margin: { l: 64, r: 24, t: 52, b: 50 },
  }));
  $('#study-hist').dataset.count = String(vals.length);
}
function plotStudyScatter() {
  const res = S.study.res;
  const m = S.study.metric;
  const p = res.parameters.find((q) => q.path === S.study.param) || res.parameters[0];
  const dsp = metricDisplay(res.metrics[m].unit);
  const xs = res.runs.params[p.path];
  const ys = res.runs.metrics[m];
  const x = [], y = [], idx = [];
  ys.forEach((v, k) => { if (v != null && xs[k] != null) { x.push(xs[k]); y.push(dsp.val(v)); idx.push(res.runs.index[k]); } });
  const e = ((res.sensitivity.ranking[m] || {}).entries || []).find((q) => q.parameter === p.path);
  const corr = e && e.prcc != null ? `: PRCC ${num(e.prcc, 3)}, Spearman ${num(e.spearman, 3)}` : '';
  const pu = prettyUnit(p.unit) || '-';
  plot('study-scatter', x.length ? [{
    type: 'scatter', mode: 'markers', x, y, customdata: idx, name: m,
    marker: { size: 7, color: '#2ca02c', opacity: 0.75, line: { color: '#1b6e1b', width: 0.5 } },
    hovertemplate: `run %{customdata}<br>${esc(p.path)} = %{x} ${esc(pu)}<br>${esc(m)} = %{y} ${esc(dsp.label)}<extra></extra>`,
  }] : [], baseLayout({
    height: 320, title: { text: `${m} against ${p.path}${corr}`, font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.98 },
    xaxis: axis(`${p.path} [${pu}]`), yaxis: axis(`${m} [${dsp.label}]`), showlegend: false, hovermode: 'closest',
    margin: { l: 64, r: 24, t: 52, b: 50 }, annotations: x.length ? [] : emptyNote(`No run defines ${m}`),
  }));
}
function renderStudyRanking() {
  const res = S.study.res;
  const m = S.study.metric;
  const rk = res.sensitivity.ranking[m];
  if (!rk) { $('#study-ranking').innerHTML = '<p class="muted small">No ranking for this metric.</p>'; return; }
  const anova = rk.method === 'factorial_variance';
  const units = Object.fromEntries(res.parameters.map((p) => [p.path, prettyUnit(p.unit) || '-']));
  const bar = (v) => (v == null ? '' : `<span class="sbar-wrap" aria-hidden="true"><span class="sbar ${v < 0 ? 'neg' : 'pos'}" style="${v < 0
    ? `right:50%;width:${(50 * Math.min(1, -v)).toFixed(1)}%` : `left:50%;width:${(50 * Math.min(1, v)).toFixed(1)}%`}"></span></span>`);
  const sbar = (v) => (v == null ? '' : `<span class="sbar-wrap" aria-hidden="true"><span class="sbar tot" style="left:0;width:${(100 * Math.max(0, Math.min(1, v))).toFixed(1)}%"></span></span>`);
  const undefinedNote = rk.entries.every((e) => e.prcc == null && e.spearman == null)
    ? `<p class="muted small">${esc(m)} does not vary (or too few runs define it): no correlation can be computed.</p>` : '';
  $('#study-ranking').innerHTML =
    `<p class="study-method" id="study-method" data-method="${esc(rk.method)}">Which parameters move <b>${esc(m)}</b>? ` +
    `<b>Method: ${esc(METHOD_NAMES[rk.method] || rk.method)}</b>, over n = ${rk.n} runs. ${esc(res.sensitivity.methods[rk.method] || '')}</p>${undefinedNote}` +
    '<table class="data" id="study-ranking-data"><thead><tr><th scope="col">rank</th><th scope="col">parameter</th>' +
    (anova ? '<th scope="col">total index S_Ti [-]</th><th scope="col">first order S_i [-]</th>' : '') +
    '<th scope="col">PRCC [-]</th><th scope="col">p-value</th><th scope="col">Spearman ρ [-]</th><th scope="col">p-value</th></tr></thead><tbody>' +
    rk.entries.map((e) => `<tr data-parameter="${esc(e.parameter)}"${e.parameter === S.study.param ? ' class="selected"' : ''} title="Plot ${esc(m)} against ${esc(e.parameter)}">` +
      `<td class="num">${e.rank}</td><th scope="row">${esc(e.parameter)} <span class="muted small">[${esc(units[e.parameter] || '-')}]</span></th>` +
      (anova ? `<td class="num">${sbar(e.total)} ${num(e.total, 3)}</td><td class="num">${num(e.first_order, 3)}</td>` : '') +
      `<td class="num">${anova ? '' : bar(e.prcc)} ${num(e.prcc, 3)}</td><td class="num">${pval(e.prcc_p)}</td>` +
      `<td class="num">${num(e.spearman, 3)}</td><td class="num">${pval(e.spearman_p)}</td></tr>`).join('') +
    '</tbody></table>';
}
function renderStudyTable() {
  const res = S.study.res;
  const qs = ['5', '25', '50', '75', '95'];
  $('#study-table').innerHTML = '<table class="data" id="study-table-data"><thead><tr><th scope="col">metric</th><th scope="col">unit</th>' +
    '<th scope="col">mean</th><th scope="col">std</th><th scope="col">min</th>' + qs.map((q) => `<th scope="col">${q} %</th>`).join('') +
    '<th scope="col">max</th><th scope="col">runs [-]</th></tr></thead><tbody>' +
    Object.entries(res.metrics).map(([k, d]) => {
      const dsp = metricDisplay(d.unit);
      const v = (x) => (x == null ? '–' : num(dsp.val(x)));
      const lost = [d.failed ? `${d.failed} failed` : '', d.undefined ? `${d.undefined} undefined` : ''].filter(Boolean).join(', ');
      return `<tr data-metric="${esc(k)}"${k === S.study.metric ? ' class="selected"' : ''} title="${esc(d.definition)}">` +
        `<th scope="row">${esc(k)}</th><td class="unit">${esc(dsp.label)}</td>` +
        `<td class="num">${v(d.mean)}</td><td class="num">${d.std == null ? '–' : num(dsp.diff(d.std))}</td><td class="num">${v(d.min)}</td>` +
        qs.map((q) => `<td class="num">${v(d.percentiles[q])}</td>`).join('') +
        `<td class="num">${v(d.max)}</td><td class="num"${lost ? ` title="${esc(lost)}"` : ''}>${d.count}${lost ? '*' : ''}</td></tr>`;
    }).join('') + '</tbody></table>';
}
function selectStudyMetric(name) {
  if (!S.study.res || !(name in S.study.res.metrics)) return;
  S.study.metric = name;
  $('#study-metric').value = name;
  renderStudyMetric();
}
function selectStudyParam(path) {
  if (!S.study.res || !S.study.res.parameters.some((p) => p.path === path)) return;
  S.study.param = path;
  $('#study-xparam').value = path;
  plotStudyScatter();
  $$('#study-ranking-data tbody tr').forEach((tr) => tr.classList.toggle('selected', tr.dataset.parameter === path));
}
function wireStudy() {
  $('#btn-study-add').addEventListener('click', () => addStudyRow());
  const rows = $('#study-param-rows');
  rows.addEventListener('change', onStudyRowChange);
  rows.addEventListener('input', onStudyRowInput);
  rows.addEventListener('click', onStudyRowClick);
  for (const id of ['#study-samples', '#study-seed', '#study-scheduler']) {
    $(id).addEventListener('input', (ev) => { clearFieldError(ev.target); updateRunCount(); });
  }
  $('#btn-study-run').addEventListener('click', runStudy);
  $('#btn-study-refresh').addEventListener('click', loadStudies);
  $('#study-list').addEventListener('click', onStudyListClick);
  $('#study-metric').addEventListener('change', (ev) => selectStudyMetric(ev.target.value));
  $('#study-xparam').addEventListener('change', (ev) => selectStudyParam(ev.target.value));
  $('#study-table').addEventListener('click', (ev) => { const tr = ev.target.closest('tr[data-metric]'); if (tr) selectStudyMetric(tr.dataset.metric); });
  $('#study-ranking').addEventListener('click', (ev) => { const tr = ev.target.closest('tr[data-parameter]'); if (tr) selectStudyParam(tr.dataset.parameter); });
}
function initStudyForm() {
  // a small Monte Carlo on friction and supply pressure to start from
  addStudyRow('friction.extend.fc0', 'uniform');
  addStudyRow('supply.pressure', 'normal');
}

/* ------------------------------------------------------------------ wiring */
function wire() {
  const mp = $('#panel-model');
  mp.addEventListener('change', (ev) => {
    if (ev.target.id === 'fric-retract-same') { onRetractSame(); return; }
    if (ev.target.id === 'friction-pressures') { plotFriction(); return; }
    if (ev.target.id === 'effect-add-select') { describeEffect(); return; }
    if (ev.target.id === 'valve-c-unit') { S.cUnit = ev.target.value; renderValveTables(); plotValve(); return; }
    if (ev.target.id === 'model-preset' || ev.target.id === 'model-file' || ev.target.id === 'model-json') return;
    onModelInput(ev);
    if (ev.target.dataset.text) $('#model-name').textContent = S.model.name ? `${S.model.name}${S.model.description ? ' — ' + S.model.description : ''}` : '';
  });
  mp.addEventListener('input', (ev) => {
    if (ev.target.id === 'friction-pressures') { plotFriction(); return; }
    if (ev.target.type === 'number') onModelInput(ev);
  });
  $('#valve-tables').addEventListener('click', editValveRows);
  $('#effects-list').addEventListener('click', removeEffect);
  $('#btn-add-effect').addEventListener('click', addEffect);
  $('#btn-model-download').addEventListener('click', downloadModel);
  $('#history-table').addEventListener('click', showVersionDiff);
  $('#btn-model-json').addEventListener('click', (ev) => busy(ev.target, () => useModelJson($('#model-json').value, 'the pasted JSON')));
  $('#model-file').addEventListener('change', async (ev) => {
    const f = ev.target.files[0];
    if (f) await useModelJson(await f.text(), f.name);
  });
  $('#btn-load-preset').addEventListener('click', async (ev) => {
    await busy(ev.target, async () => {
      try { await loadModelPreset($('#model-preset').value); setStatus(`Model preset ${$('#model-preset').value} loaded.`, 'ok'); } catch (e) { showApiError(e, 'Loading the preset'); }
    });
  });
  const sp = $('#panel-scenario');
  sp.addEventListener('change', onScenarioInput);
  sp.addEventListener('input', onScenarioInput);
  for (const b of $$('[data-preset]', sp)) {
    b.addEventListener('click', async () => {
      try { await loadScenarioPreset(b.dataset.preset, b); } catch (e) { showApiError(e, 'Loading the scenario'); }
    });
  }
  $('#btn-add-step').addEventListener('click', addStep);
  $('#btn-clear-command').addEventListener('click', clearCommand);
  $('#btn-simulate').addEventListener('click', () => simulate($('#btn-simulate')));
  $('#btn-heat-overlay').addEventListener('click', overlayHeatModels);
  $('#dataset-select').addEventListener('change', onDatasetSelect);
  $('#btn-upload').addEventListener('click', uploadDataset);
  $('#btn-compare').addEventListener('click', () => runCompare());
  $('#btn-diagnose').addEventListener('click', runDiagnosis);
  $('#diag-cards').addEventListener('click', adoptEffect);
  $('#btn-new-session').addEventListener('click', newSession);
  $('#btn-record-version').addEventListener('click', recordCurrent);
  $('#panel-measure').addEventListener('input', (ev) => { if (ev.target.dataset && ev.target.dataset.field) clearFieldError(ev.target); });
  wireStudy();
}

async function init() {
  wire();
  plotEmptySimulation();
  plotEmptyCompare();
  plotEmptyStudy();
  try {
    const [presets, effects, units] = await Promise.all([api('GET', '/api/presets'), api('GET', '/api/effects'), fetchUnits()]);
    S.presets = presets;
    S.effects = effects;
    S.units = units;
    $('#model-preset').innerHTML = presets.models.map((m) => `<option value="${esc(m.name)}" title="${esc(m.description)}">${esc(m.name)}</option>`).join('');
    await Promise.all([
      loadModelPreset(presets.models.some((m) => m.name === 'paper-4way') ? 'paper-4way' : presets.models[0].name),
      api('GET', '/api/presets/paper-fig10-pulses').then((s) => { S.scenario = s; renderScenario(); }),
      loadDatasets(),
      loadStudies(),
    ]);
    initStudyForm();
    await plotFriction();   // the first friction map is drawn before the page says it is ready
    const resumed = await resumeSession();
    if (!resumed) setStatus('Ready. Pick a paper scenario or edit the model, then Simulate.', 'info');
    document.body.dataset.ready = 'true';
  } catch (e) {
    showApiError(e, 'Loading the page data');
    document.body.dataset.ready = 'error';
  }
}

// a bug in this page should show up where the user looks, not only in the console
window.addEventListener('error', (ev) => setStatus(`Page error: ${ev.message}`, 'error'));
window.addEventListener('unhandledrejection', (ev) => setStatus(`Page error: ${ev.reason && ev.reason.message ? ev.reason.message : ev.reason}`, 'error'));

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', init); else init();
