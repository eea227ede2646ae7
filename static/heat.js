/* pneucore page: heat models (loaded after app.js; uses its S, api, busy, plot, esc, ... helpers).
 *
 * - the model panel's heat select lists every model of GET /api/heat-models, with an input per
 *   parameter of the chosen model (unit, bounds and default from the registry);
 * - the "Heat models side by side" panel runs one scenario under every heat model (pressures and
 *   temperatures overlaid), and one measurement against every heat model, each calibrated on its
 *   own parameters (a table of pressure and temperature errors per model).
 * All text from the server or the user goes through textContent or esc().
 */
'use strict';

const HEAT = { models: [], byName: {}, colors: ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#8c564b', '#e377c2'] };

function heatSpec(name) { return HEAT.byName[name]; }

/** Keep only the fields the chosen model accepts (the API refuses the others by name). */
function heatSection(heat, name) {
  const spec = heatSpec(name);
  const out = { model: name, coefficient: heat && heat.coefficient != null ? heat.coefficient : 25.0 };
  if (!spec) return out;
  for (const p of spec.parameters) {
    if (heat && heat[p.name] != null) out[p.name] = heat[p.name];
  }
  return out;
}

function renderHeatParams() {
  const box = document.getElementById('heat-params');
  if (!box || !S.model) return;
  const heat = S.model.heat || {};
  const spec = heatSpec(heat.model || 'convective');
  box.textContent = '';
  if (!spec) return;
  const desc = document.getElementById('heat-model-desc');
  if (desc) desc.textContent = spec.description;
  for (const p of spec.parameters) {
    if (p.name === 'coefficient') continue;   // the page's own coefficient field
    const id = `heat-${p.name}`;
    const div = document.createElement('div');
    div.className = 'field';
    const label = document.createElement('label');
    label.htmlFor = id;
    label.textContent = `${p.name.replace(/_/g, ' ')} [${p.unit}]`;
    label.title = `${p.description} (${p.min} to ${p.max}, default ${p.default})`;
    const input = document.createElement('input');
    input.id = id;
    input.type = 'number';
    input.step = 'any';
    input.dataset.field = `model.heat.${p.name}`;
    input.value = String(heat[p.name] != null ? heat[p.name] : p.default);
    const err = document.createElement('span');
    err.className = 'field-error';
    err.setAttribute('role', 'alert');
    div.append(label, input, err);
    box.append(div);
  }
  const coef = document.getElementById('heat-coefficient');
  if (coef) coef.closest('.field').style.display = spec.parameters.some((p) => p.name === 'coefficient') ? '' : 'none';
}

function onHeatModelChange(ev) {
  if (!S.model) return;
  S.model.heat = heatSection(S.model.heat, ev.target.value);
  renderHeatParams();
}

/* ------------------------------------------------------------ side by side: one scenario */
/** `show` converts a series to the plot's unit (app.js plotUnit, the header's unit system). */
function heatTraces(runs, signal, show, dash) {
  return Object.entries(runs).map(([name, run], i) => ({
    x: run.series.t, y: show(run.series[signal] || []),
    name: `${name} ${signal}`, mode: 'lines', line: { color: HEAT.colors[i % HEAT.colors.length], width: 1.5, dash },
  }));
}

async function heatSimulateAll() {
  clearErrors();
  const scenario = scenarioForRequest();
  if (!scenario) return;
  setStatus('Simulating the scenario under every heat model…', 'busy');
  await busy(document.getElementById('btn-heat-all'), async () => {
    try {
      // t and q_supply among the series: each run's stats then carry its stroke metrics
      const series = ['t', 'u', 'p_a', 'p_b', 'T_a', 'T_b', 'x', 'v', 'q_supply'];
      const res = await api('POST', '/api/heat-models/simulate', { model: S.model, scenario, series });
      const runs = res.runs;
      const b = S.model.valve && S.model.valve.kind === '4/2';
      HEAT.redraw = () => drawHeatRuns(runs, b);
      HEAT.redraw();
      document.getElementById('panel-heat').dataset.simulated = String(Object.keys(runs).length);
      setStatus(`Scenario run under ${Object.keys(runs).length} heat models: ${Object.keys(runs).join(', ')}.`, 'ok');
    } catch (e) { showApiError(e, 'Heat models side by side'); }
  });
}

/** The heat models' runs of one scenario: pressures, temperatures (the page's units) and each
 * model's stroke times and end speeds side by side (SMC's, from the valve switching). */
function drawHeatRuns(runs, b) {
  const P = plotUnit('Pa').val, K = plotUnit('K').val;
  plot('heat-plot-pressure', [...heatTraces(runs, 'p_a', P, 'solid'), ...(b ? heatTraces(runs, 'p_b', P, 'dot') : [])],
    baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`pressure [${plotUnit('Pa').label}]`) }));
  plot('heat-plot-temperature', [...heatTraces(runs, 'T_a', K, 'solid'), ...(b ? heatTraces(runs, 'T_b', K, 'dot') : [])],
    baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`gas temperature [${plotUnit('K').label}]`) }));
  const V = metricDisplay('m/s'), T = metricDisplay('K');
  const f = (v, d = 4) => (v == null ? '–' : num(v, d));
  const rows = Object.entries(runs).map(([name, r]) => {
    const sm = (r.stats && r.stats.stroke) || {};
    const tmin = Math.min(...(r.series.T_a || []).concat(r.series.T_b || []).filter((v) => v != null));
    return `<tr><th scope="row">${esc(name)}</th><td>${f(sm.full_stroke_time_extend)}</td><td>${f(sm.full_stroke_time_retract)}</td>` +
      `<td>${sm.end_speed_max == null ? '–' : num(V.val(sm.end_speed_max), 4)}</td><td>${f(sm.air_per_cycle_NL)}</td>` +
      `<td>${Number.isFinite(tmin) ? num(T.val(tmin), 4) : '–'}</td></tr>`;
  }).join('');
  const box = document.getElementById('heat-strokes');
  if (box) {
    box.innerHTML = `<table class="data" id="heat-strokes-table"><caption>Strokes under each heat model (SMC's times from the valve switching)</caption>` +
      `<thead><tr><th scope="col">heat model</th><th scope="col">full stroke extending [s]</th><th scope="col">full stroke retracting [s]</th>` +
      `<th scope="col">stroke end speed [${esc(V.label)}]</th><th scope="col">air per cycle [NL]</th><th scope="col">lowest gas temperature [${esc(T.label)}]</th></tr></thead>` +
      `<tbody>${rows}</tbody></table>`;
  }
}
function drawHeatEmpty() {
  plot('heat-plot-pressure', [], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`pressure [${plotUnit('Pa').label}]`), annotations: emptyNote('Run every heat model') }));
  plot('heat-plot-temperature', [], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`gas temperature [${plotUnit('K').label}]`), annotations: emptyNote('Run every heat model') }));
}

/* ------------------------------------------------------------ side by side: one measurement */
function heatTable(rows) {
  const table = document.createElement('table');
  table.className = 'data';
  const head = table.createTHead().insertRow();
  const signals = [...new Set(rows.flatMap((r) => Object.keys(r.errors)))];
  const cols = ['heat model', 'fitted parameters', ...signals.map((s) => `${s} Eq. 25 [%]`), 'T rms [K]'];
  for (const c of cols) { const th = document.createElement('th'); th.textContent = c; head.append(th); }
  const best = {};
  for (const s of signals) best[s] = Math.min(...rows.map((r) => (r.errors[s] == null ? Infinity : r.errors[s])));
  const body = table.createTBody();
  for (const r of rows) {
    const tr = body.insertRow();
    tr.dataset.model = r.name;
    tr.insertCell().textContent = r.name;
    tr.insertCell().textContent = Object.entries(r.parameters).map(([k, v]) => `${k.replace(/^heat\./, '')} = ${num(v.value, 4)}`).join(', ') || '—';
    for (const s of signals) {
      const td = tr.insertCell();
      td.textContent = r.errors[s] == null ? '—' : pct(r.errors[s]);
      if (r.errors[s] === best[s]) td.style.fontWeight = 'bold';   // the best of the column
    }
    const rms = Object.entries(r.temperature_rms || {}).map(([k, v]) => `${k} ${v == null ? '—' : num(v, 3)}`).join(', ');
    tr.insertCell().textContent = rms || '—';
  }
  return table;
}

async function heatCompareAll() {
  clearErrors();
  if (!S.experiments || !S.experiments.length) {
    fieldError('experiments', 'select a dataset or a sample first');
    setStatus('Heat models against the measurement: pick a dataset in panel 4 first.', 'error');
    return;
  }
  setStatus('Calibrating every heat model on the measurement…', 'busy');
  await busy(document.getElementById('btn-heat-compare'), async () => {
    try {
      const sensor = document.getElementById('heat-fit-sensor').checked;
      const res = await api('POST', '/api/heat-models/compare', { model: S.model, experiments: clone(S.experiments), sensor });
      const wrap = document.getElementById('heat-table');
      wrap.textContent = '';
      wrap.append(heatTable(res.models));
      HEAT.redraw = () => drawHeatCompare(res);
      HEAT.redraw();
      document.getElementById('panel-heat').dataset.compared = String(res.models.length);
      setStatus(`Every heat model calibrated on ${res.experiment || 'the measurement'}; errors in the table.`, 'ok');
    } catch (e) { showApiError(e, 'Heat models against the measurement', (f) => (f.startsWith('experiments') ? 'experiments' : f)); }
  });
}
function drawHeatCompare(res) {
  {
    {
      const m = res.measured;
      const P = plotUnit('Pa').val, K = plotUnit('K').val;   // as the header's unit system
      const meas = (sig, show) => ({ x: m.t, y: show(m[sig]), name: `measured ${sig}`, mode: 'markers', marker: { color: '#000', size: 5 } });
      const sim = (sig, show) => res.models.map((r, i) => ({
        x: r.t, y: show(r.simulated[sig] || []), name: `${r.name} ${sig}`, mode: 'lines',
        line: { color: HEAT.colors[i % HEAT.colors.length], width: 1.5 } }));
      const pSig = ['p_a', 'p_b'].filter((s) => s in m);
      const tSig = ['T_a', 'T_b'].filter((s) => s in m);
      plot('heat-plot-pressure', pSig.flatMap((s) => [meas(s, P), ...sim(s, P)]),
        baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`pressure [${plotUnit('Pa').label}]`), annotations: pSig.length ? [] : emptyNote('no pressure measured') }));
      plot('heat-plot-temperature', tSig.flatMap((s) => [meas(s, K), ...sim(s, K)]),
        baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`gas temperature [${plotUnit('K').label}]`), annotations: tSig.length ? [] : emptyNote('no gas temperature measured') }));
    }
  }
}

async function initHeat() {
  try {
    HEAT.models = await api('GET', '/api/heat-models');
  } catch (e) { showApiError(e, 'Loading the heat models'); return; }
  HEAT.byName = Object.fromEntries(HEAT.models.map((m) => [m.name, m]));
  const sel = document.getElementById('heat-model');
  const current = sel.value;
  sel.textContent = '';
  for (const m of HEAT.models) {
    const o = document.createElement('option');
    o.value = m.name;
    o.textContent = m.name === 'convective' ? 'convective (Eq. 9)' : m.name.replace(/_/g, ' ');
    o.title = m.description;
    sel.append(o);
  }
  sel.value = (S.model && S.model.heat && S.model.heat.model) || current;
  sel.addEventListener('change', onHeatModelChange);
  // the model panel re-renders on every preset/session load: the heat inputs follow
  const render = window.renderModel;
  window.renderModel = function renderModelWithHeat() { render(); renderHeatParams(); };
  renderHeatParams();
  document.getElementById('btn-heat-all').addEventListener('click', heatSimulateAll);
  document.getElementById('btn-heat-compare').addEventListener('click', heatCompareAll);
  HEAT.redraw = drawHeatEmpty;
  drawHeatEmpty();
  document.getElementById('panel-heat').dataset.ready = 'true';
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', initHeat); else initHeat();
