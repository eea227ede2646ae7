/* pneucore page: the Control view (issue 42; loaded after app.js; uses its S, api, busy, plot,
 * baseLayout, axis, num, setStatus, showApiError helpers).
 *
 * - a controller (kind from GET /api/controllers, its gains with their units and defaults), a
 *   setpoint ([[t [s], x [m]], ...] or a shape as JSON), the sample period and the scenario's
 *   duration and start: POST /api/simulate with scenario.controller on the model panel's model;
 *   position and reference, and the valve command, plotted; the loop's metrics in a table;
 * - "Linearise": POST /api/linearize at the setpoint's first position: natural frequency,
 *   damping, and the closed form of the pneumatic spring.
 * - the sensors the controller reads (model.effects.sensor_lag: position resolution, lag and
 *   noise, pressure noise and resolution), the noise's seed (scenario.controller.seed) and the
 *   velocity estimator's filter (scenario.controller.rate_filter), sent with the run;
 *   the sensed position x_sensed plotted beside the true one when the answer has it;
 * - robustness: uncertain ranges (Coulomb friction factor, moving mass, supply pressure, valve
 *   C factor), drawn uniformly over N runs by POST /api/jobs/control-study with a specification
 *   (settling time, overshoot, steady-state band): a histogram of a chosen metric with the
 *   bound marked and the share of runs meeting it (the last study and tuning shown again after a
 *   reload, from their job records: ctlRestore); "Tune": POST /api/jobs/tune-controller over
 *   values per gain, the sets ranked, the best taken into the gain fields.
 * Positions (the start, the setpoint's table, a gain in m or m/s, sensor resolution and noise,
 * the band) and pressures are typed and shown in the page's unit system (units.js unitShow: mm
 * and bar in engineering) and sent in SI; a 422 is shown next to the field it names.
 * All text from the server or the user goes through textContent (or esc()).
 */
'use strict';

const CTL = { kinds: [], byKind: {}, filled: false, robust: null, tune: null, linear: null };
/** The sensor_lag parameters the Control view sets (SI: m, s, m, Pa, Pa) */
const CTL_SENSORS = ['position_resolution', 'position_time_constant', 'position_noise', 'pressure_noise',
  'pressure_resolution'];
/** Metrics a study records (pneucore.control.robustness.STUDY_METRICS) with their labels */
const CTL_METRICS = [['settling_time', 'settling time (2 %)'], ['overshoot', 'overshoot'],
  ['steady_state_error', 'steady-state error'], ['rise_time', 'rise time (10-90 %)'], ['rms_error', 'RMS tracking error'],
  ['hunting_amplitude', 'hunting amplitude'], ['hunting_frequency', 'hunting frequency'], ['switchings', 'valve switchings'],
  ['air_per_move', 'air per move']];
/** The specification's fields: metric, input, how its shown value becomes SI */
const CTL_SPEC = [['settling_time', 'control-spec-settling'], ['overshoot', 'control-spec-overshoot'],
  ['steady_state_error', 'control-spec-band']];

/** How a quantity in SI unit ``si`` ('m', 'm/s', 'Pa') is shown on this page: {unit, scale,
 * offset}; ``diff``: a difference (a noise, a band), shown without a gauge offset or "abs". */
function ctlShown(si, diff) {
  const d = typeof unitShow === 'function' ? unitShow(si) : { unit: si, scale: 1, offset: 0 };
  let unit = String(d.unit);
  if (diff) unit = unit.replace(/ (abs|g)$/, '');
  return { unit: typeof prettyUnit === 'function' ? prettyUnit(unit) : unit, scale: Number(d.scale) || 1,
    offset: diff ? 0 : Number(d.offset) || 0 };
}
/** The value of a number input in SI (its shown value times its dataset.scale plus its offset). */
function ctlSI(input) {
  return Number(input.value) * Number(input.dataset.scale || 1) + Number(input.dataset.offset || 0);
}
/** An input's SI value set (shown with its dataset's scale and offset). */
function ctlSetSI(input, si) {
  input.value = String(+((si - Number(input.dataset.offset || 0)) / Number(input.dataset.scale || 1)).toPrecision(10));
}
/** Show ``input`` (holding a value shown with its dataset.scale and offset) with ``d`` instead. */
function ctlRescale(input, d) {
  const prev = Number(input.dataset.scale || 1);
  const prevOff = Number(input.dataset.offset || 0);
  const v = Number(input.value);
  if (input.value.trim() !== '' && Number.isFinite(v) && (prev !== d.scale || prevOff !== d.offset)) {
    input.value = String(+((v * prev + prevOff - d.offset) / d.scale).toPrecision(12));
  }
  input.dataset.scale = String(d.scale);
  input.dataset.offset = String(d.offset);
}
/** A comma-separated list of values (a tuning's gain values) shown with ``d.scale`` instead. */
function ctlRescaleList(input, d) {
  const prev = Number(input.dataset.scale || 1);
  input.dataset.scale = String(d.scale);
  input.dataset.offset = '0';
  if (prev === d.scale || !input.value.trim()) return;
  const parts = input.value.split(/[,;\s]+/).filter(Boolean);
  if (parts.every((p) => Number.isFinite(Number(p)))) input.value = parts.map((p) => +(Number(p) * prev / d.scale).toPrecision(12)).join(', ');
}
/** A setpoint table's positions shown with ``scale`` (a shape, an object, is in SI and kept). */
function ctlRescaleSetpoint(area, scale) {
  const prev = Number(area.dataset.scale || 1);
  area.dataset.scale = String(scale);
  if (prev === scale) return;
  try {
    const sp = JSON.parse(area.value);
    if (Array.isArray(sp)) area.value = JSON.stringify(sp.map(([t, x]) => [t, +(x * prev / scale).toPrecision(12)]));
  } catch (e) { /* not JSON yet: left as typed */ }
}
/** The Control view's lengths and pressures in the chosen unit system (called by units.js applyUnits). */
function applyControlUnits() {
  const x0 = document.getElementById('control-x0');
  if (!x0) return;
  ctlDefaults();
  const len = ctlShown('m');
  ctlRescale(x0, len);
  document.querySelector('label[for="control-x0"]').textContent = `Start position x0 [${len.unit}]`;
  const area = document.getElementById('control-setpoint');
  ctlRescaleSetpoint(area, len.scale);
  document.querySelector('label[for="control-setpoint"]').textContent =
    `Setpoint: [[t [s], x [${len.unit}]], ...], or a shape {"kind": "step|multi_step|ramp|sine|jerk_limited|recorded", ...} in SI units`;
  // every input with an SI unit: the gains, the sensors, the ranges, the band, the tuning's values
  for (const input of document.querySelectorAll('#panel-control input[data-si]')) {
    const shown = ctlShown(input.dataset.si, input.dataset.diff === '1');
    if (input.dataset.list === '1') ctlRescaleList(input, shown); else ctlRescale(input, shown);
    const label = document.querySelector(`label[for="${CSS.escape(input.id)}"]`);
    if (label) label.textContent = `${input.dataset.label} [${shown.unit}]`;
  }
  if (CTL.run) { ctlPlotRun(); ctlTable(CTL.run.stats.control); }
  if (CTL.linear) ctlLinearText();
  if (CTL.robust) ctlPlotHist();
  if (CTL.tune) ctlTuneTable();
}

/** The robustness ranges and the sensors filled from the model once it is there. */
function ctlDefaults() {
  if (typeof S === 'undefined' || !S.model || CTL.filled) return;
  CTL.filled = true;
  const m = S.model;
  const mass = m.jack && Number(m.jack.moving_mass);
  const ps = m.supply && Number(m.supply.pressure);
  const fill = (id, si) => {
    const el = document.getElementById(id);
    if (el.value.trim() === '' && Number.isFinite(si)) { el.dataset.scale = '1'; el.dataset.offset = '0'; el.value = String(+si.toPrecision(6)); }
  };
  if (mass > 0) { fill('control-rob-mass-min', 0.8 * mass); fill('control-rob-mass-max', 1.2 * mass); }
  if (ps > 0) { fill('control-rob-ps-min', 0.9 * ps); fill('control-rob-ps-max', 1.1 * ps); }
  const sl = (m.effects || {}).sensor_lag;
  if (sl) {
    for (const k of CTL_SENSORS) {
      const el = document.getElementById(`control-sensor-${k}`);
      if (sl[k] != null) { el.dataset.scale = '1'; el.dataset.offset = '0'; el.value = String(sl[k]); }
    }
  }
}

function ctlField(box, id, label, value, title) {
  const div = document.createElement('div');
  div.className = 'field';
  const l = document.createElement('label');
  l.htmlFor = id;
  l.textContent = label;
  if (title) l.title = title;
  const input = document.createElement('input');
  input.id = id;
  input.value = value == null ? '' : String(value);
  const err = document.createElement('span');
  err.className = 'field-error';
  err.setAttribute('role', 'alert');
  div.append(l, input, err);
  box.append(div);
  return input;
}

function ctlRenderGains() {
  const box = document.getElementById('control-gains');
  const kind = CTL.byKind[document.getElementById('control-kind').value];
  box.textContent = '';
  if (!kind) return;
  document.getElementById('control-desc').textContent = `${kind.description} (valves: ${kind.valves.join(', ')})`;
  for (const [name, g] of Object.entries(kind.gains)) {
    const shown = ctlShown(g.unit);
    const value = g.default == null ? null : +(g.default / shown.scale).toPrecision(12);
    const input = ctlField(box, `control-gain-${name}`, `${name} [${shown.unit}]`, value, g.description || '');
    input.type = 'number';
    input.step = 'any';
    input.dataset.gain = name;
    input.dataset.si = g.unit;
    input.dataset.label = name;
    input.dataset.scale = String(shown.scale);
  }
  const tune = document.getElementById('control-tune-gains');
  tune.textContent = '';
  for (const [name, g] of Object.entries(kind.gains)) {
    const shown = ctlShown(g.unit);
    const input = ctlField(tune, `control-tune-${name}`, `${name}: values [${shown.unit}]`, '', `values of ${name} to try, comma-separated`);
    input.dataset.gain = name;
    input.dataset.si = g.unit;
    input.dataset.list = '1';
    input.dataset.label = `${name}: values`;
    input.dataset.scale = String(shown.scale);
    input.placeholder = 'e.g. 10, 15, 20';
  }
}

async function ctlInit() {
  const sel = document.getElementById('control-kind');
  if (!sel || CTL.kinds.length) return;
  try {
    CTL.kinds = (await api('GET', '/api/controllers')).controllers;
  } catch (e) { showApiError(e, 'Controllers'); return; }
  for (const k of CTL.kinds) {
    CTL.byKind[k.kind] = k;
    const o = document.createElement('option');
    o.value = k.kind;
    o.textContent = k.kind;
    sel.append(o);
  }
  sel.addEventListener('change', ctlRenderGains);
  for (const id of ['control-rob-metric', 'control-tune-objective']) {
    const m = document.getElementById(id);
    for (const [k, label] of CTL_METRICS) {
      const o = document.createElement('option');
      o.value = k;
      o.textContent = label;
      m.append(o);
    }
  }
  document.getElementById('control-rob-metric').value = 'settling_time';
  document.getElementById('control-tune-objective').value = 'settling_time';
  ctlRenderGains();
  applyControlUnits();
  await ctlRestore();
}

/** A client-side error next to the element ``id``, naming ``field``; returns an Error to throw. */
function ctlFail(field, id, msg) {
  fieldError(field, msg, document.getElementById(id));
  const e = new Error(`${field}: ${msg}`);
  e.shown = true;
  return e;
}

/** The model sent: the model panel's, with the sensors of this view (SI) in effects.sensor_lag. */
function ctlModel() {
  const m = clone(S.model);
  const vals = {};
  for (const k of CTL_SENSORS) {
    const input = document.getElementById(`control-sensor-${k}`);
    const v = input.value.trim() === '' ? 0 : ctlSI(input);
    if (!Number.isFinite(v)) throw ctlFail(`model.effects.sensor_lag.${k}`, input.id, 'must be a number');
    vals[k] = v;
  }
  const effects = m.effects || {};
  if (effects.sensor_lag || Object.values(vals).some((v) => v !== 0)) {
    // a model without the effect keeps ideal pressure transducers (no lag) under a position sensor
    m.effects = Object.assign({}, effects, { sensor_lag: Object.assign({ time_constant: 0 }, effects.sensor_lag || {}, vals) });
  }
  return m;
}

function ctlRequest() {
  const gains = {};
  for (const input of document.querySelectorAll('#control-gains input')) {
    if (input.value.trim() !== '') gains[input.dataset.gain] = ctlSI(input);
  }
  let setpoint;
  const x0 = ctlSI(document.getElementById('control-x0'));
  const area = document.getElementById('control-setpoint');
  const text = area.value.trim();
  const scale = Number(area.dataset.scale || 1);
  // an empty field: a 20 mm step from the start position at 50 ms
  try { setpoint = text ? JSON.parse(text) : [[0, x0], [0.05, x0 + 0.02]]; } catch (e) {
    throw ctlFail('scenario.controller.setpoint', 'control-setpoint',
      `not valid JSON ([[t [s], x [${ctlShown('m').unit}]], ...] or {"kind": ...})`);
  }
  if (text && Array.isArray(setpoint)) setpoint = setpoint.map((row) => (Array.isArray(row) ? [row[0], row[1] * scale] : row));
  const seedText = document.getElementById('control-seed').value.trim();
  const controller = { kind: document.getElementById('control-kind').value, gains, setpoint,
    sample_period: Number(document.getElementById('control-ts').value) };
  if (seedText !== '') controller.seed = Number(seedText);
  const rate = document.getElementById('control-rate-filter');
  if (rate.value.trim() !== '') controller.rate_filter = ctlSI(rate);
  return {
    model: ctlModel(),
    scenario: {
      duration: Number(document.getElementById('control-duration').value),
      sample_period: 1e-3, x0, controller,
    },
  };
}

/** The element of this view a 422's field names (``study.`` prefixes dropped), or null. */
function ctlTarget(field) {
  const f = String(field || '').replace(/^study\./, '');
  const id = (x) => document.getElementById(x);
  let m;
  if ((m = /^gains\.([^.[]+)/.exec(f))) return id(`control-tune-${m[1]}`);
  if ((m = /^scenario\.controller\.gains\.([^.[]+)/.exec(f))) return id(`control-gain-${m[1]}`) || id('control-kind');
  if (f.startsWith('scenario.controller.gains')) return document.querySelector('#control-gains input') || id('control-kind');
  if (f.startsWith('scenario.controller.setpoint')) return id('control-setpoint');
  if (f.startsWith('scenario.controller.sample_period')) return id('control-ts');
  if (f.startsWith('scenario.controller.seed')) return id('control-seed');
  if (f.startsWith('scenario.controller.rate_filter')) return id('control-rate-filter');
  if (f.startsWith('scenario.controller')) return id('control-kind');
  if (f.startsWith('scenario.duration') || f.startsWith('scenario.sample_period')) return id('control-duration');
  if (f.startsWith('scenario.x0') || f.startsWith('scenario.initial')) return id('control-x0');
  if ((m = /^model\.effects\.sensor_lag\.([^.[]+)/.exec(f))) return id(`control-sensor-${m[1]}`);
  if ((m = /^parameters\.(.+?)(\.(min|max|distribution|grid))?$/.exec(f))) {
    const path = m[1];
    const end = m[3] === 'max' ? 'max' : 'min';
    if (path.startsWith('friction.')) return id(`control-rob-fc-${end}`);
    if (path === 'jack.moving_mass') return id(`control-rob-mass-${end}`);
    if (path === 'supply.pressure') return id(`control-rob-ps-${end}`);
    if (path.startsWith('valve.')) return id(`control-rob-valve-${end}`);
    return id('control-rob-fc-min');
  }
  if (f === 'parameters') return id('control-rob-fc-on');
  if (f.startsWith('samples') || f.startsWith('n_runs')) return id('control-rob-runs');
  if ((m = /^specification\.(\w+)/.exec(f))) {
    const spec = CTL_SPEC.find(([k]) => k === m[1]);
    return spec ? id(spec[1]) : id('control-spec-settling');
  }
  if (f.startsWith('objective')) return id('control-tune-objective');
  return null;
}

/** An API error: each 422 next to the field of this view it names (else where the page has it). */
function ctlApiError(e, what) {
  if (e && e.shown) { setStatus(`${what}: ${e.message}`, 'error'); return; }
  if (!(e instanceof ApiError) || !Array.isArray(e.detail)) { showApiError(e, what); return; }
  for (const d of e.detail) {
    let field = d.field;
    if (field == null) {
      const loc = Array.isArray(d.loc) ? d.loc.slice(d.loc[0] === 'body' ? 1 : 0) : [];
      field = loc.map((p) => (typeof p === 'number' ? `[${p}]` : p)).join('.').replace(/\.\[/g, '[');
    }
    const el = ctlTarget(field);
    fieldError(field, d.msg || JSON.stringify(d), el || undefined);
  }
  setStatus(`${what} refused (HTTP ${e.status}): ${e.detail.map((d) => d.msg).join('; ')}`, 'error');
}

/** The closed loop's metrics in the table's order (labels from CTL_METRICS). */
const CTL_TABLE = ['rise_time', 'settling_time', 'overshoot', 'steady_state_error', 'rms_error',
  'hunting_amplitude', 'hunting_frequency', 'switchings', 'air_per_move'];

/** The closed loop's metrics tabled in the page's unit system (ctlMetricShown: lengths as the
 * system shows them, times in s, overshoot in %); redrawn when the system changes. */
function ctlTable(c) {
  const labels = Object.fromEntries(CTL_METRICS);
  const table = document.createElement('table');
  table.className = 'data';
  const body = table.createTBody();
  for (const k of CTL_TABLE) {
    const d = ctlMetricShown(k);
    const v = c[k];
    const tr = body.insertRow();
    const th = document.createElement('th');
    th.scope = 'row';
    th.textContent = `${labels[k] || k.replace(/_/g, ' ')} [${d.label}]`;
    tr.append(th);
    const td = tr.insertCell();
    td.dataset.metric = k;
    td.textContent = v == null ? '—' : num(d.val(v), 4);
  }
  const box = document.getElementById('control-table');
  box.textContent = '';
  box.append(table);
}

async function ctlRun() {
  if (!S.model) return;
  clearErrors();
  let body;
  try { body = ctlRequest(); } catch (e) { ctlApiError(e, 'Closed loop'); return; }
  setStatus('Running the closed loop…', 'busy');
  await busy(document.getElementById('btn-control-run'), async () => {
    try {
      const res = await api('POST', '/api/simulate', body);
      CTL.run = res;
      ctlPlotRun();
      ctlTable(res.stats.control);
      document.getElementById('panel-control').dataset.ran = '1';
      setStatus(`Closed loop run: ${res.stats.control.kind} at ${num(1 / res.stats.control.sample_period, 4)} Hz.`, 'ok');
    } catch (e) { ctlApiError(e, 'Closed loop'); }
  });
}

/** The last closed loop's position (the true one, the reference, and the sensed one when the
 * model has a position sensor) and valve command, in the page's unit system. */
function ctlPlotRun() {
  const res = CTL.run;
  if (!res) return;
  const s = res.series;
  const u = plotUnit('m');
  const traces = [
    { x: s.t, y: u.val(s.x_ref), name: 'x_ref', mode: 'lines', line: { dash: 'dot', color: '#555' } },
    { x: s.t, y: u.val(s.x), name: 'x', mode: 'lines', line: { color: '#1f77b4' } }];
  if (Array.isArray(s.x_sensed)) {
    traces.push({ x: s.t, y: u.val(s.x_sensed), name: 'x_sensed', mode: 'lines', line: { color: '#ff7f0e', shape: 'hv', width: 1 } });
  }
  plot('control-plot-x', traces, baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`position [${u.label}]`) }));
  plot('control-plot-u', [{ x: s.t, y: s.u, name: 'u', mode: 'lines', line: { color: '#d62728' } }],
    baseLayout({ xaxis: axis('time t [s]'), yaxis: axis('valve command u [-]') }));
}

async function ctlLinearize() {
  if (!S.model) return;
  const x = ctlSI(document.getElementById('control-x0'));
  await busy(document.getElementById('btn-control-linearize'), async () => {
    try {
      CTL.linear = await api('POST', '/api/linearize', { model: S.model, operating_point: { x } });
      ctlLinearText();
    } catch (e) { showApiError(e, 'Linearisation'); }
  });
}

/** The linearisation's answer in words, its position and pressure in the page's unit system. */
function ctlLinearText() {
  const r = CTL.linear;
  const len = ctlShown('m');
  const pr = ctlShown('Pa');
  document.getElementById('control-linear').textContent =
    `At x = ${num((r.operating_point.x - len.offset) / len.scale, 4)} ${len.unit}, p_a = ` +
    `${num((r.operating_point.p_a - pr.offset) / pr.scale, 4)} ${pr.unit}: natural frequency ` +
    `${num(r.natural_frequency, 4)} Hz, damping ${num(r.damping, 3)} (closed chambers, no friction: ` +
    `${num(r.closed_form.isothermal, 4)} Hz isothermal, ${num(r.closed_form.adiabatic, 4)} Hz adiabatic).`;
}

/* ------------------------------------------------------------------ robustness and tuning */
const ctlSleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** A range row's [min, max] in SI, checked (numbers, min below max), or null when not ticked. */
function ctlRange(key, field) {
  if (!document.getElementById(`control-rob-${key}-on`).checked) return null;
  const lo = document.getElementById(`control-rob-${key}-min`);
  const hi = document.getElementById(`control-rob-${key}-max`);
  const name = lo.dataset.range;
  for (const el of [lo, hi]) {
    if (el.value.trim() === '' || !Number.isFinite(Number(el.value))) {
      throw ctlFail(`${field}.${el === lo ? 'min' : 'max'}`, el.id, `${name}: give a number`);
    }
  }
  const a = ctlSI(lo);
  const b = ctlSI(hi);
  if (!(a < b)) throw ctlFail(`${field}.min`, lo.id, `${name}: the range's min must be below its max`);
  if (key !== 'ps' && a < 0) throw ctlFail(`${field}.min`, lo.id, `${name}: must be >= 0`);
  return [a, b];
}

/** The study's parameters (model paths, each uniform over its range, SI) from the ticked rows. */
function ctlParameters() {
  const params = {};
  const uni = (lo, hi) => ({ distribution: 'uniform', min: lo, max: hi });
  const note = document.getElementById('control-rob-fc-note');
  note.textContent = '';
  const fc = ctlRange('fc', 'parameters.friction.*.fc0');
  if (fc) {
    const fr = S.model.friction || {};
    const ext = Number(((fr.extend || {}).fc0) ?? 10);
    const ret = fr.retract ? Number(fr.retract.fc0 ?? 10) : ext;
    if (!(ext > 0) && !(ret > 0)) {
      throw ctlFail('parameters.friction.*.fc0', 'control-rob-fc-min', 'Coulomb friction factor: the model\'s Coulomb level fc0 is 0 N: a factor on it changes nothing');
    }
    if (ext === ret) {
      params['friction.*.fc0'] = uni(fc[0] * ext, fc[1] * ext);
      note.textContent = `fc0 from ${num(fc[0] * ext, 4)} to ${num(fc[1] * ext, 4)} N, both directions`;
    } else {
      // the levels differ: each direction drawn in its own range (independently)
      if (ext > 0) params['friction.extend.fc0'] = uni(fc[0] * ext, fc[1] * ext);
      if (ret > 0) params['friction.retract.fc0'] = uni(fc[0] * ret, fc[1] * ret);
      note.textContent = 'extend and retract levels differ: each drawn in its own range, independently';
    }
  }
  const mass = ctlRange('mass', 'parameters.jack.moving_mass');
  if (mass) params['jack.moving_mass'] = uni(...mass);
  const ps = ctlRange('ps', 'parameters.supply.pressure');
  if (ps) params['supply.pressure'] = uni(...ps);
  const valve = ctlRange('valve', 'parameters.valve.ports.*.C');
  if (valve) params['valve.ports.*.C'] = uni(...valve);
  if (!Object.keys(params).length) throw ctlFail('parameters', 'control-rob-fc-on', 'tick at least one uncertain parameter');
  return params;
}

/** The specification {metric: largest |value|} in SI from the filled fields (null: none). */
function ctlSpec() {
  const spec = {};
  for (const [k, id] of CTL_SPEC) {
    const el = document.getElementById(id);
    if (el.value.trim() === '') continue;
    let v = Number(el.value);
    if (!Number.isFinite(v) || v < 0) throw ctlFail(`specification.${k}`, id, 'must be a number >= 0');
    v = k === 'overshoot' ? v / 100 : ctlSI(el);
    spec[k] = v;
  }
  return Object.keys(spec).length ? spec : null;
}

/** The closed-loop study: the view's loop on ``runs`` draws of the ticked parameters. */
function ctlStudy() {
  const req = ctlRequest();
  const runsEl = document.getElementById('control-rob-runs');
  const runs = Number(runsEl.value);
  if (!Number.isInteger(runs) || runs < 1) throw ctlFail('samples', runsEl.id, 'a whole number of runs >= 1');
  return { model: req.model, scenario: req.scenario, parameters: ctlParameters(), samples: runs, seed: 1 };
}

/** Where the page keeps the id of its last robustness study's and tuning's job (localStorage):
 * their answers stay on the server as job records, so a reload shows them again
 * (ctlRestore), said to be for the model and ranges they were run on. */
const CTL_KEEP = { robust: 'pneucore.control.robust-job', tune: 'pneucore.control.tune-job' };
function ctlKept(which, id) {
  try {
    if (id === undefined) return localStorage.getItem(CTL_KEEP[which]);
    if (id) localStorage.setItem(CTL_KEEP[which], id); else localStorage.removeItem(CTL_KEEP[which]);
  } catch (e) { /* storage refused: nothing is kept across a reload */ }
  return null;
}

/** Submit a job and follow it (progress bar and step), its result, or an Error with its message;
 * ``which``: the kept job (CTL_KEEP) it becomes. */
async function ctlJob(path, body, prog, step, which) {
  prog.value = 0;
  delete prog.dataset.done;
  step.textContent = 'submitting';
  const j = await api('POST', path, body);
  if (which) ctlKept(which, j.id);
  return ctlFollow(j, prog, step);
}

/** Follow a job's record ``j`` to its end: its result, or an Error with its message. */
async function ctlFollow(j, prog, step) {
  while (j.status === 'queued' || j.status === 'running') {
    prog.value = j.progress || 0;
    step.textContent = `${j.step || j.status} (${Math.round((j.progress || 0) * 100)} %)`;
    await ctlSleep(300);
    j = await api('GET', `/api/jobs/${encodeURIComponent(j.id)}`);
  }
  if (j.status !== 'done') {
    step.textContent = `failed: ${j.error || j.status}`;
    throw new Error(j.error || j.status);
  }
  prog.value = 1;
  prog.dataset.done = 'true';
  step.textContent = 'done (100 %)';
  return j.result;
}

/** How a metric is shown: {label, val(SI)}: overshoot in %, lengths in the page's unit. */
function ctlMetricShown(k) {
  if (k === 'overshoot') return { label: '%', val: (v) => v * 100 };
  const unit = { rise_time: 's', settling_time: 's', steady_state_error: 'm', rms_error: 'm', hunting_amplitude: 'm',
    hunting_frequency: 'Hz', switchings: '-', air_per_move: 'NL' }[k] || '-';
  if (unit === 'm') { const d = ctlShown('m', true); return { label: d.unit, val: (v) => v / d.scale }; }
  return { label: unit, val: (v) => v };
}

async function ctlRobust() {
  if (!S.model) return;
  clearErrors();
  let body;
  try { body = { study: ctlStudy(), specification: ctlSpec() }; } catch (e) { ctlApiError(e, 'Robustness study'); return; }
  const n = body.study.samples;
  setStatus(`Robustness study: ${n} closed-loop runs…`, 'busy');
  await busy(document.getElementById('btn-control-robust'), async () => {
    try {
      const res = await ctlJob('/api/jobs/control-study', body, document.getElementById('control-rob-progress'),
        document.getElementById('control-rob-step'), 'robust');
      ctlShowRobust(res);
      setStatus(`Robustness study done: ${res.summary.runs} runs, ${num(res.summary.stable_fraction * 100, 3)} % stable.`, 'ok');
    } catch (e) { ctlApiError(e, 'Robustness study'); }
  });
}

function ctlShowRobust(res) {
  CTL.robust = res;
  ctlPlotHist();
  document.getElementById('panel-control').dataset.robust = '1';
}

/** The last robustness study and tuning this browser ran, shown again after a reload from their
 * job records (followed on if still running); a job the server no longer holds is forgotten. */
async function ctlRestore() {
  const views = {
    robust: ['control-rob', ctlShowRobust, 'robustness study'],
    tune: ['control-tune', ctlShowTune, 'tuning'],
  };
  for (const [which, [pre, show, what]] of Object.entries(views)) {
    const id = ctlKept(which);
    if (!id) continue;
    let j;
    try { j = await api('GET', `/api/jobs/${encodeURIComponent(id)}`); } catch (e) { ctlKept(which, null); continue; }
    const step = document.getElementById(`${pre}-step`);
    try {
      const res = await ctlFollow(j, document.getElementById(`${pre}-progress`), step);
      show(res);
      step.textContent = `the last ${what} on this browser (job ${id}): for the model, gains and ranges it was run on`;
    } catch (e) { ctlKept(which, null); }
  }
}

/** The spec's bounds in words, in the page's units. */
function ctlSpecText(spec) {
  return Object.entries(spec || {}).map(([k, v]) => {
    const d = ctlMetricShown(k);
    return `${k === 'steady_state_error' ? '|steady-state error|' : k.replace(/_/g, ' ')} ≤ ${num(d.val(v), 4)} ${d.label}`;
  }).join(', ');
}

/** The chosen metric's histogram over the runs (|value|; the runs meeting the specification and
 * the others stacked), its bound marked, and the share of runs meeting the specification. */
function ctlPlotHist() {
  const res = CTL.robust;
  if (!res) return;
  const k = document.getElementById('control-rob-metric').value;
  const j = res.metrics.indexOf(k);
  const d = ctlMetricShown(k);
  const meets = res.meets || null;
  const ok = [];
  const bad = [];
  let undef = 0;
  res.rows.forEach((row, i) => {
    const v = row[j];
    if (v == null) { undef += 1; return; }
    (meets && !meets[i] ? bad : ok).push(d.val(Math.abs(v)));
  });
  const all = ok.concat(bad);
  const spec = res.specification || {};
  const shapes = [];
  const annotations = [];
  if (spec[k] != null) {
    const x = d.val(spec[k]);
    shapes.push({ type: 'line', xref: 'x', yref: 'paper', x0: x, x1: x, y0: 0, y1: 1, line: { color: '#d62728', width: 2, dash: 'dash' } });
    annotations.push({ text: 'specification', x, xref: 'x', y: 1, yref: 'paper', yanchor: 'bottom', showarrow: false, font: { size: 10, color: '#d62728' } });
  }
  let xbins;
  if (all.length) {
    let lo = Math.min(...all, spec[k] != null ? d.val(spec[k]) : Infinity);
    let hi = Math.max(...all, spec[k] != null ? d.val(spec[k]) : -Infinity);
    if (!(hi > lo)) { lo -= Math.abs(lo) * 0.05 + 1e-12; hi += Math.abs(hi) * 0.05 + 1e-12; }
    const nb = Math.max(5, Math.min(30, Math.round(2 * Math.sqrt(all.length))));
    xbins = { start: lo, end: hi + (hi - lo) / nb * 0.999, size: (hi - lo) / nb };
  } else annotations.push(...emptyNote(`No run defines ${k}`));
  const traces = [];
  const name = k === 'steady_state_error' ? `|${k}|` : k;
  if (ok.length) traces.push({ type: 'histogram', x: ok, xbins, autobinx: false, name: meets ? 'meets the specification' : name, marker: { color: '#2ca02c' } });
  if (bad.length) traces.push({ type: 'histogram', x: bad, xbins, autobinx: false, name: 'fails it', marker: { color: '#d62728' } });
  plot('control-rob-hist', traces, baseLayout({
    height: 320, barmode: 'stack', bargap: 0.04, shapes, annotations,
    title: { text: `${name} over ${res.summary.runs} runs${undef ? ` (${undef} undefined or failed)` : ''}`, font: { size: 12 } },
    xaxis: axis(`${name} [${d.label}]`), yaxis: axis('runs [-]'),
  }));
  const hist = document.getElementById('control-rob-hist');
  hist.dataset.count = String(all.length);
  hist.dataset.runs = String(res.summary.runs);
  const share = document.getElementById('control-rob-share');
  const stable = `${num(res.summary.stable_fraction * 100, 3)} % of the runs stable`;
  if (meets) {
    const nm = meets.filter(Boolean).length;
    share.textContent = `${nm} of ${meets.length} runs meet the specification (${num(res.summary.meets_fraction * 100, 3)} %): ` +
      `${ctlSpecText(spec)}; ${stable}.`;
    share.dataset.share = String(res.summary.meets_fraction);
  } else {
    share.textContent = `No specification: ${stable}.`;
    delete share.dataset.share;
  }
}

/** The tuning's gain values {name: [SI, ...]} from the filled value lists. */
function ctlTuneGains() {
  const gains = {};
  for (const input of document.querySelectorAll('#control-tune-gains input')) {
    const text = input.value.trim();
    if (!text) continue;
    const vals = text.split(/[,;\s]+/).filter(Boolean).map(Number);
    if (!vals.length || vals.some((v) => !Number.isFinite(v))) {
      throw ctlFail(`gains.${input.dataset.gain}`, input.id, 'values must be numbers, comma-separated');
    }
    gains[input.dataset.gain] = vals.map((v) => v * Number(input.dataset.scale || 1));
  }
  if (!Object.keys(gains).length) {
    const first = document.querySelector('#control-tune-gains input');
    throw ctlFail('gains', first ? first.id : 'btn-control-tune', 'give the values to try of at least one gain');
  }
  return gains;
}

async function ctlTune() {
  if (!S.model) return;
  clearErrors();
  let body;
  try {
    body = { study: ctlStudy(), gains: ctlTuneGains(), objective: document.getElementById('control-tune-objective').value,
      specification: ctlSpec() };
  } catch (e) { ctlApiError(e, 'Tuning'); return; }
  const sets = Object.values(body.gains).reduce((n, v) => n * v.length, 1);
  setStatus(`Tuning: ${sets} gain sets × ${body.study.samples} runs…`, 'busy');
  const use = document.getElementById('btn-control-tune-use');
  use.disabled = true;
  await busy(document.getElementById('btn-control-tune'), async () => {
    try {
      const res = await ctlJob('/api/jobs/tune-controller', body, document.getElementById('control-tune-progress'),
        document.getElementById('control-tune-step'), 'tune');
      ctlShowTune(res);
      setStatus(`Tuning done: ${res.candidates.length} gain sets ranked.`, 'ok');
    } catch (e) { ctlApiError(e, 'Tuning'); }
  });
}

function ctlShowTune(res) {
  const worst = (c) => (c.worst == null ? Infinity : c.worst);
  const meets = (c) => (c.summary.meets_fraction == null ? 0 : c.summary.meets_fraction);
  res.ranked = res.candidates.slice().sort((a, b) => (meets(b) - meets(a)) || (worst(a) - worst(b)));
  CTL.tune = res;
  ctlTuneTable();
  document.getElementById('btn-control-tune-use').disabled = false;
  document.getElementById('panel-control').dataset.tuned = '1';
}

/** The ranked gain sets: gains in the page's units, the worst objective, stable and meeting shares. */
function ctlTuneTable() {
  const res = CTL.tune;
  const box = document.getElementById('control-tune-table');
  box.textContent = '';
  if (!res) return;
  const kind = CTL.byKind[document.getElementById('control-kind').value] || { gains: {} };
  const names = Object.keys((res.ranked[0] || {}).gains || {});
  const obj = ctlMetricShown(res.objective);
  const table = document.createElement('table');
  table.className = 'data';
  table.id = 'control-tune-ranked';
  const head = table.createTHead().insertRow();
  const cols = ['rank [-]'].concat(names.map((n) => `${n} [${ctlShown((kind.gains[n] || {}).unit || '-').unit}]`),
    [`worst ${res.objective} [${obj.label}]`, 'stable [%]'], res.specification ? ['meets the spec [%]'] : []);
  for (const c of cols) { const th = document.createElement('th'); th.scope = 'col'; th.textContent = c; head.append(th); }
  const body = table.createTBody();
  res.ranked.forEach((c, i) => {
    const tr = body.insertRow();
    if (i === 0) tr.className = 'selected';
    tr.insertCell().textContent = String(i + 1);
    for (const n of names) tr.insertCell().textContent = num(c.gains[n] / ctlShown((kind.gains[n] || {}).unit || '-').scale, 5);
    tr.insertCell().textContent = c.worst == null ? 'unstable or undefined' : num(obj.val(Math.abs(c.worst)), 4);
    tr.insertCell().textContent = num(c.stable_fraction * 100, 3);
    if (res.specification) tr.insertCell().textContent = num((c.summary.meets_fraction || 0) * 100, 3);
  });
  box.append(table);
}

/** The best gain set into the gain fields (shown in their units). */
function ctlUseBest() {
  const res = CTL.tune;
  if (!res || !res.ranked.length) return;
  const best = res.ranked[0].gains;
  for (const [name, v] of Object.entries(best)) {
    const input = document.getElementById(`control-gain-${name}`);
    if (input && v != null) ctlSetSI(input, Number(v));
  }
  setStatus(`Gains set to the best tuned set: ${Object.entries(best).map(([k, v]) => `${k} = ${num(v, 5)}`).join(', ')} (SI).`, 'ok');
}

document.addEventListener('DOMContentLoaded', () => {
  const run = document.getElementById('btn-control-run');
  if (!run) return;
  run.addEventListener('click', ctlRun);
  document.getElementById('btn-control-linearize').addEventListener('click', ctlLinearize);
  document.getElementById('btn-control-robust').addEventListener('click', ctlRobust);
  document.getElementById('btn-control-tune').addEventListener('click', ctlTune);
  document.getElementById('btn-control-tune-use').addEventListener('click', ctlUseBest);
  document.getElementById('control-rob-metric').addEventListener('change', ctlPlotHist);
  ctlInit();
});
