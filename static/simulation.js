/* pneucore page: the scenario panel and the simulation (view "Scenario & simulation"): the command,
 * scenario presets, POST /api/simulate, its plots and stroke metrics, the heat-model overlay.
 *
 * A classic script loaded before app.js (index.html); it only declares functions and constants,
 * so it uses app.js's S, api, plot, esc, ... helpers at call time. */
'use strict';

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
  const title = $('#sim-scenario-name');
  if (title) title.textContent = s.name ? `(scenario ${s.name})` : '(your scenario)';
}
/** A preset's name and description no longer describe a scenario the user changed (its
 * command, duration, start...): both are dropped, and the page says what it was edited from. */
function markScenarioEdited() {
  const s = S.scenario;
  if (!s || (!s.name && !s.description)) return;
  const from = s.name;
  s.name = '';
  s.description = '';
  $('#scenario-desc').textContent = from ? `Your scenario (edited from ${from}).` : 'Your scenario.';
  const title = $('#sim-scenario-name');
  if (title) title.textContent = '(your scenario)';
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
  markScenarioEdited();
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
  markScenarioEdited();
  $('#scn-command').value = cmd.map(([a, b]) => `${num(a, 8)}, ${num(b, 8)}`).join('\n');
  const next = +(t + 0.1).toFixed(6);
  $('#step-time').value = next;
}
function clearCommand() {
  S.scenario.command = [[0, 0]];
  markScenarioEdited();
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
      renderStartState(res);
      setStatus(`${note}Simulation done: ${msg}.${res.status ? ' Solver: ' + res.message : ''}`, res.status ? 'error' : 'ok');
    } catch (e) { showApiError(e, 'Simulation'); }
  });
}
/** The state the run started from, in the page's units: the cyclic steady state found (with its
 * cycles) or the given one (blank fields: ambient), read off the first sample. */
function renderStartState(res) {
  const el = $('#sim-start');
  if (!el) return;
  const s = res && res.series;
  if (!s || !s.t || !s.t.length) { el.textContent = ''; return; }
  const cyc = res.stats && res.stats.cyclic;
  const P = plotUnit('Pa'), TK = plotUnit('K'), X = plotUnit('m');
  const st = cyc ? cyc.state : { p_a: s.p_a[0], p_b: s.p_b[0], T_a: s.T_a[0], T_b: s.T_b[0], x0: s.x[0] };
  const f = (U, v) => `${num(U.val([v])[0], 4)} ${U.label}`;
  const what = cyc
    ? `Start state: cyclic steady state after ${cyc.cycles} cycle${cyc.cycles === 1 ? '' : 's'}${cyc.converged ? '' : ' (NOT converged)'}`
    : 'Start state: as given';
  el.textContent = `${what}: p_a ${f(P, st.p_a)}, p_b ${f(P, st.p_b)}, T_a ${f(TK, st.T_a)}, T_b ${f(TK, st.T_b)}, x0 ${f(X, st.x0)}.`;
  el.dataset.start = cyc ? 'cyclic' : 'given';
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
