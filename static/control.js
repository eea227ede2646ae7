/* pneucore page: the Control view (issue 42; loaded after app.js; uses its S, api, busy, plot,
 * baseLayout, axis, num, setStatus, showApiError helpers).
 *
 * - a controller (kind from GET /api/controllers, its gains with their units and defaults), a
 *   setpoint ([[t [s], x [m]], ...] or a shape as JSON), the sample period and the scenario's
 *   duration and start: POST /api/simulate with scenario.controller on the model panel's model;
 *   position and reference, and the valve command, plotted; the loop's metrics in a table;
 * - "Linearise": POST /api/linearize at the setpoint's first position: natural frequency,
 *   damping, and the closed form of the pneumatic spring.
 * Positions (the start, the setpoint's table, a gain in m or m/s) are typed and shown in the
 * page's unit system (units.js unitShow: mm in engineering) and sent in SI.
 * All text from the server or the user goes through textContent.
 */
'use strict';

const CTL = { kinds: [], byKind: {} };

/** How a quantity in SI unit ``si`` ('m', 'm/s') is shown on this page: {unit, scale}. */
function ctlShown(si) {
  const d = typeof unitShow === 'function' ? unitShow(si) : { unit: si, scale: 1 };
  return { unit: d.unit, scale: Number(d.scale) || 1 };
}
/** The value of a number input in SI (its shown value times the scale it was shown with). */
function ctlSI(input) { return Number(input.value) * Number(input.dataset.scale || 1); }
/** Show ``input`` (holding a value shown with its dataset.scale) with ``scale`` instead. */
function ctlRescale(input, scale) {
  const prev = Number(input.dataset.scale || 1);
  const v = Number(input.value);
  if (input.value.trim() !== '' && Number.isFinite(v) && prev !== scale) input.value = String(+(v * prev / scale).toPrecision(12));
  input.dataset.scale = String(scale);
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
/** The Control view's lengths in the chosen unit system (called by units.js applyUnits). */
function applyControlUnits() {
  const x0 = document.getElementById('control-x0');
  if (!x0) return;
  const len = ctlShown('m');
  ctlRescale(x0, len.scale);
  document.querySelector('label[for="control-x0"]').textContent = `Start position x0 [${len.unit}]`;
  const area = document.getElementById('control-setpoint');
  ctlRescaleSetpoint(area, len.scale);
  document.querySelector('label[for="control-setpoint"]').textContent =
    `Setpoint: [[t [s], x [${len.unit}]], ...], or a shape {"kind": "step|multi_step|ramp|sine|jerk_limited|recorded", ...} in SI units`;
  for (const input of document.querySelectorAll('#control-gains input')) {
    const shown = ctlShown(input.dataset.si);
    ctlRescale(input, shown.scale);
    document.querySelector(`label[for="${CSS.escape(input.id)}"]`).textContent = `${input.dataset.gain} [${shown.unit}]`;
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
    input.dataset.scale = String(shown.scale);
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
  ctlRenderGains();
  applyControlUnits();
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
    throw new Error(`setpoint: not valid JSON ([[t [s], x [${ctlShown('m').unit}]], ...] or {"kind": ...})`);
  }
  if (text && Array.isArray(setpoint)) setpoint = setpoint.map((row) => (Array.isArray(row) ? [row[0], row[1] * scale] : row));
  return {
    model: S.model,
    scenario: {
      duration: Number(document.getElementById('control-duration').value),
      sample_period: 1e-3, x0,
      controller: { kind: document.getElementById('control-kind').value, gains, setpoint,
        sample_period: Number(document.getElementById('control-ts').value) },
    },
  };
}

function ctlTable(c) {
  const rows = [['rise time (10-90 %)', c.rise_time, 1e3, 'ms'], ['settling time (2 %)', c.settling_time, 1e3, 'ms'],
    ['overshoot', c.overshoot, 100, '%'], ['steady-state error', c.steady_state_error, 1e6, 'µm'],
    ['RMS tracking error', c.rms_error, 1e6, 'µm'], ['hunting amplitude', c.hunting_amplitude, 1e3, 'mm'],
    ['hunting frequency', c.hunting_frequency, 1, 'Hz'], ['valve switchings', c.switchings, 1, '-'],
    ['air per move', c.air_per_move, 1, 'NL']];
  const table = document.createElement('table');
  table.className = 'data';
  const body = table.createTBody();
  for (const [name, v, scale, unit] of rows) {
    const tr = body.insertRow();
    tr.insertCell().textContent = `${name} [${unit}]`;
    tr.insertCell().textContent = v == null ? '—' : num(v * scale, 4);
  }
  const box = document.getElementById('control-table');
  box.textContent = '';
  box.append(table);
}

async function ctlRun() {
  if (!S.model) return;
  let body;
  try { body = ctlRequest(); } catch (e) { setStatus(e.message, 'error'); return; }
  setStatus('Running the closed loop…', 'busy');
  await busy(document.getElementById('btn-control-run'), async () => {
    try {
      const res = await api('POST', '/api/simulate', body);
      const s = res.series;
      const mm = (a) => a.map((v) => (v == null ? null : v * 1e3));
      plot('control-plot-x', [
        { x: s.t, y: mm(s.x_ref), name: 'x_ref', mode: 'lines', line: { dash: 'dot', color: '#555' } },
        { x: s.t, y: mm(s.x), name: 'x', mode: 'lines', line: { color: '#1f77b4' } }],
      baseLayout({ xaxis: axis('time t [s]'), yaxis: axis('position [mm]') }));
      plot('control-plot-u', [{ x: s.t, y: s.u, name: 'u', mode: 'lines', line: { color: '#d62728' } }],
        baseLayout({ xaxis: axis('time t [s]'), yaxis: axis('valve command u [-]') }));
      ctlTable(res.stats.control);
      document.getElementById('panel-control').dataset.ran = '1';
      setStatus(`Closed loop run: ${res.stats.control.kind} at ${num(1 / res.stats.control.sample_period, 4)} Hz.`, 'ok');
    } catch (e) { showApiError(e, 'Closed loop'); }
  });
}

async function ctlLinearize() {
  if (!S.model) return;
  const x = ctlSI(document.getElementById('control-x0'));
  await busy(document.getElementById('btn-control-linearize'), async () => {
    try {
      const r = await api('POST', '/api/linearize', { model: S.model, operating_point: { x } });
      document.getElementById('control-linear').textContent =
        `At x = ${num(x * 1e3, 4)} mm, p_a = ${num(r.operating_point.p_a / 1e5, 4)} bar abs: natural frequency ` +
        `${num(r.natural_frequency, 4)} Hz, damping ${num(r.damping, 3)} (closed chambers, no friction: ` +
        `${num(r.closed_form.isothermal, 4)} Hz isothermal, ${num(r.closed_form.adiabatic, 4)} Hz adiabatic).`;
    } catch (e) { showApiError(e, 'Linearisation'); }
  });
}

document.addEventListener('DOMContentLoaded', () => {
  const run = document.getElementById('btn-control-run');
  if (!run) return;
  run.addEventListener('click', ctlRun);
  document.getElementById('btn-control-linearize').addEventListener('click', ctlLinearize);
  ctlInit();
});
