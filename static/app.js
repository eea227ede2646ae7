/* pneucore page: vanilla JS, no build step. Talks to the REST API of app/ (SI units, absolute pressures).
 *
 * State lives in `S`: the current model and scenario as the API's JSON (every field the page
 * does not show is kept untouched), the effect catalog, the datasets, the last results and the
 * refinement session. Inputs carry `data-field` (the API's dotted path, e.g. model.jack.rod_a)
 * and `data-scale` (SI value = displayed value x scale), so 422 errors land next to their field.
 *
 * This file holds the shared state, the helpers (status and errors, api, plots, units) and the
 * wiring; each view's code is its own classic script (model.js, simulation.js, datasets.js,
 * compare.js, history.js, diagnosis.js, study.js), loaded before this one because init() below
 * runs at once and wires their functions; they use these helpers only when called.
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
    // an answer for a model the user has since changed: its model errors are about values no
    // longer there (a rod typed wider than the bore, then corrected while the request ran), so
    // they flag no field and the status says the model has changed since
    const stale = modelChangedSince(err);
    let dropped = 0;
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
      if (stale && /^model(\.|\[|$)/.test(field)) { dropped += 1; continue; }
      fieldError(field, msg);
    }
    const n = detail.length;
    setStatus(`${what} refused (HTTP ${err.status}): ${n} error${n === 1 ? '' : 's'}: ` +
      detail.map((e) => e.msg).join('; ') +
      (dropped ? ` (for the model as it was when sent; it has changed since: run it again)` : ''), 'error');
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
/** The page's model as JSON now ('' before one is loaded). */
function pageModelJson() {
  return typeof S === 'object' && S && S.model ? JSON.stringify(S.model) : '';
}
async function api(method, path, body) {
  const opts = { method, headers: {} };
  // the page's model when the request went out: an answer's model errors are stale once it has changed
  const modelAtSend = pageModelJson();
  if (body instanceof FormData) opts.body = body;
  else if (body !== undefined) { opts.headers['content-type'] = 'application/json'; opts.body = JSON.stringify(body); }
  let r;
  try { r = await fetch(path, opts); } catch (e) { throw new Error(`network error: ${e.message}`); }
  const text = await r.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch (e) { data = text; }
  if (!r.ok) {
    const err = new ApiError(r.status, data && data.detail !== undefined ? data.detail : (data || r.statusText));
    err.modelAtSend = modelAtSend;
    throw err;
  }
  return data;
}
/** True when the page's model changed (an edit, or a preset loaded) while the request that
 * ``err`` answers ran. */
function modelChangedSince(err) {
  return !!(err && typeof err.modelAtSend === 'string' && err.modelAtSend !== pageModelJson());
}
/** GET /api/units, asked once per page load (units.js and paramUnit share it). */
let UNITS_REQUEST = null;
function fetchUnits() { return UNITS_REQUEST || (UNITS_REQUEST = api('GET', '/api/units')); }
/** GET /openapi.json, asked once per page load: the API's own defaults and choices (the one
 * source of a field's default; the page keeps no copy of the numbers). A failed request is
 * asked again next time. */
let OPENAPI_REQUEST = null;
function fetchOpenApi() {
  return OPENAPI_REQUEST || (OPENAPI_REQUEST = api('GET', '/openapi.json').catch((e) => { OPENAPI_REQUEST = null; throw e; }));
}
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

/* ------------------------------------------------------------------ units on the plots */
// metrics come in SI; lengths, pressures and temperatures shown in the header's unit system
// (plotUnit); `diff` converts spreads (std)
function prettyUnit(u) { return String(u || '').replace(/\^3/g, '³').replace(/\^2/g, '²'); }
/** How every plot shows a quantity in SI unit `si`: the header's unit switch (units.js).
 *  `val` converts a series, `diff` a difference (a residual, a spread: no gauge offset). */
function plotUnit(si) {
  const d = typeof unitShow === 'function' ? unitShow(si) : { unit: si, scale: 1, offset: 0 };
  const conv = (off) => (a) => a.map((v) => (v == null ? null : (v - off) / d.scale));
  return { label: prettyUnit(d.unit), val: conv(d.offset || 0), diff: conv(0) };
}
function metricDisplay(unit) {
  // every unit the chosen system shows otherwise (m, Pa, K, m/s, kg/s, m^3/(s Pa), ...)
  if (unit && typeof unitShow === 'function' && unitShow(unit).unit !== unit) {
    const u = plotUnit(unit);
    return { label: u.label, val: (v) => u.val([v])[0], diff: (v) => u.diff([v])[0] };
  }
  return { label: unit || '-', val: (v) => v, diff: (v) => v };
}
/** SI unit of the model parameter at `path` (GET /api/units, from pneucore.description.paths); '' when unknown. */
function paramUnit(path) {
  const units = (S.units && S.units.parameters) || {};
  const p = String(path || '');
  // a valve scale factor has the same unit on every edge: the service lists it under '*'
  return units[p] || units[p.replace(/^valve\.ports\.[^.]+\./, 'valve.ports.*.')] || '';
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
    // numbers and names as typed (a name typed and the page reloaded before the field is left is kept: static/draft.js)
    if (ev.target.type === 'number' || ev.target.dataset.text) onModelInput(ev);
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
