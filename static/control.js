/* pneucore page: the Control view (issue 42; loaded after app.js; uses its S, api, busy, plot,
 * baseLayout, axis, num, setStatus, showApiError helpers).
 *
 * - a controller (kind from GET /api/controllers, its gains with their units and defaults), a
 *   setpoint ([[t [s], x [m]], ...] or a shape as JSON), the sample period and the scenario's
 *   duration and start: POST /api/simulate with scenario.controller on the model panel's model;
 *   position and reference, and the valve command, plotted; the loop's metrics in a table;
 * - "Linearise": POST /api/linearize at the setpoint's first position: natural frequency,
 *   damping, and the closed form of the pneumatic spring.
 * All text from the server or the user goes through textContent.
 */
'use strict';

const CTL = { kinds: [], byKind: {} };

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
    const input = ctlField(box, `control-gain-${name}`, `${name} [${g.unit}]`, g.default, g.description || '');
    input.type = 'number';
    input.step = 'any';
    input.dataset.gain = name;
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
}

function ctlRequest() {
  const gains = {};
  for (const input of document.querySelectorAll('#control-gains input')) {
    if (input.value.trim() !== '') gains[input.dataset.gain] = Number(input.value);
  }
  let setpoint;
  const x0v = Number(document.getElementById('control-x0').value);
  const text = document.getElementById('control-setpoint').value.trim();
  // an empty field: a 20 mm step from the start position at 50 ms
  try { setpoint = text ? JSON.parse(text) : [[0, x0v], [0.05, x0v + 0.02]]; } catch (e) {
    throw new Error('setpoint: not valid JSON ([[t [s], x [m]], ...] or {"kind": ...})');
  }
  const x0 = Number(document.getElementById('control-x0').value);
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
  const x = Number(document.getElementById('control-x0').value);
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
