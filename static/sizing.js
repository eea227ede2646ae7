/* pneucore page: the sizing panel (loaded after app.js; uses its S, api, busy, plot, esc, ...).
 *
 * The requirement form -> POST /api/sizing -> the ranked designs as a table (and the reason of
 * every family that fails); the chosen design's motion plot (one cycle through POST
 * /api/simulate, the design's model as it is); "use in the model panel" and "export the
 * model (JSON)". All text from the server or the user goes through textContent or esc().
 */
'use strict';

const SZ = { ans: null, chosen: 0 };

/** Requirement fields: [field, label, SI unit, default in SI ('' = not given), blank note].
 * The label's unit and the values shown follow the page's unit system (static/units.js); the
 * request is SI. The defaults are the model panel's (its stroke, mass, load and angle). */
const SIZING_FIELDS = [
  ['stroke', 'Stroke', 'm', 0.2, ''], ['moving_mass', 'Moving mass', 'kg', 5, ''],
  ['load_force', 'Load force against the extension', 'N', 50, ''], ['angle', 'Mounting angle, 90 = rod up', 'deg', 30, ''],
  ['supply_pressure', 'Supply pressure', 'Pa', 7e5, ''],
  ['extend_time', 'Extend time, full stroke', 's', 0.6, 'blank with a cycle time'],
  ['retract_time', 'Retract time, full stroke', 's', 0.6, 'blank with a cycle time'],
  ['cycle_time', 'Cycle time instead of the two times', 's', '', 'blank: none'],
  ['dwell', 'Dwell at each end stop, with a cycle time', 's', '', 'blank: 0'],
  ['max_end_speed', 'Max stroke-end speed', 'm/s', 1.0, 'blank: none'],
  ['max_end_energy', 'Max kinetic energy at the end stop', 'J', '', 'blank: none'],
  ['cushion_length', 'Cushion length at each end', 'm', '', 'blank: no cushion'],
  ['cushion_capacity', 'Cushion capacity, its cushioning energy', 'J', '', 'with a cushion length'],
  ['tube_length', 'Tube length per port', 'm', '', 'blank: no tube'],
  ['valve_on_time', 'Valve switching time ON, catalogue', 's', '', 'blank: 0'],
  ['valve_off_time', 'Valve switching time OFF, spring return', 's', '', 'blank: 0'],
];
/** How a sizing field's SI unit is shown: {unit, scale, offset} (a supply pressure in bar g
 * is gauge against the requirement's ambient, the model's). */
function sizingShown(si) {
  const d = typeof unitShow === 'function' ? unitShow(si) : { unit: si, scale: 1, offset: 0 };
  return { unit: d.unit, scale: d.scale || 1, offset: d.offset || 0 };
}
function sizingLabel(label, si, note) {
  return `${label}${note ? ` (${note})` : ''} [${prettyUnitText(sizingShown(si).unit)}]`;
}
const SIZING_CHOICES = [
  ['bore', 'Cylinders (series or series:member, comma-separated; blank: all) [-]', 'iso15552, iso6432'],
  ['valve', 'Valves (blank: all) [-]', 'ckd-4ga'],
  ['tube_inner_diameter', 'Tubes (blank: all) [-]', ''],
];

function buildSizingForm() {
  const box = document.getElementById('sizing-form');
  const rows = SIZING_FIELDS.map(([n, l, si, d, note]) => [n, sizingLabel(l, si, note), d, si])
    .concat(SIZING_CHOICES);
  for (const [name, label, dflt, si] of rows) {
    const isChoice = SIZING_CHOICES.some((c) => c[0] === name);
    const div = document.createElement('div');
    div.className = 'field';
    const lab = document.createElement('label');
    lab.htmlFor = `sz-${name}`;
    lab.textContent = label;
    const input = document.createElement('input');
    input.id = `sz-${name}`;
    input.type = isChoice ? 'text' : 'number';
    if (!isChoice) input.step = 'any';
    if (si) { input.dataset.si = si; input.dataset.siValue = String(dflt); }
    input.value = String(dflt);
    input.dataset.field = `${isChoice ? 'choices' : 'requirement'}.${name}`;
    const err = document.createElement('span');
    err.className = 'field-error';
    err.setAttribute('role', 'alert');
    div.append(lab, input, err);
    box.append(div);
  }
}

/** The form's values in the chosen units (after a change of the system or of the model). */
function applySizingUnits() {
  for (const [name, label, si, , note] of SIZING_FIELDS) {
    const el = document.getElementById(`sz-${name}`);
    if (!el) continue;
    const lab = document.querySelector(`label[for="sz-${name}"]`);
    if (lab) lab.textContent = sizingLabel(label, si, note);
    const d = sizingShown(si);
    const v = el.dataset.siValue;
    el.value = v === '' || v == null ? '' : String(+((Number(v) - d.offset) / d.scale).toPrecision(10));
  }
  if (SZ.ans) renderSizing();
  drawSizingPlot();
}
function sizingInput(ev) {
  const el = ev.target;
  if (!el.dataset || !el.dataset.si) return;
  const raw = el.value.trim();
  const d = sizingShown(el.dataset.si);
  el.dataset.siValue = raw === '' ? '' : (Number.isFinite(Number(raw)) ? String(+(Number(raw) * d.scale + d.offset).toPrecision(12)) : raw);
}
/** The sizing form starts from the model panel's design (its stroke, moving mass, load,
 * angle and supply), as the user has it: called when the sizing view opens unsized. */
function sizingFromModel() {
  const m = S.model;
  if (!m || !m.jack) return;
  const set = (name, v) => { const el = document.getElementById(`sz-${name}`); if (el && v != null) el.dataset.siValue = String(v); };
  set('stroke', m.jack.stroke);
  set('moving_mass', m.jack.moving_mass);
  set('load_force', m.jack.load_force);
  set('angle', m.jack.mounting_angle);
  if (m.supply) set('supply_pressure', m.supply.pressure);
  applySizingUnits();
}
function sizingRequest() {
  const requirement = {};
  for (const [name] of SIZING_FIELDS) {
    const el = document.getElementById(`sz-${name}`);
    sizingInput({ target: el });
    const v = (el.dataset.siValue || '').trim();
    if (v !== '') requirement[name] = Number(v);
  }
  const choices = {};
  for (const [name] of SIZING_CHOICES) {
    const v = document.getElementById(`sz-${name}`).value.trim();
    if (v === '') continue;
    choices[name] = v.split(',').map((s) => s.trim()).filter((s) => s)
      .map((s) => (name === 'tube_inner_diameter' && /^[0-9.eE+-]+$/.test(s) ? Number(s) : s));
  }
  return { requirement, choices };
}

function metric(d, dir, name, digits = 3) {
  const v = d.metrics[dir][name];
  const u = d.metrics.units && d.metrics.units[name];
  return v == null ? '–' : num(u ? metricDisplay(u).val(v) : v, digits);
}

function renderSizing() {
  const ans = SZ.ans;
  document.getElementById('sizing-summary').textContent = ans.summary;
  const cushioned = ans.designs.some((d) => d.cushion);
  const CU = metricDisplay(ans.units['settings.*_meter_out_C']);   // the model panel's C unit
  const VU = metricDisplay('m/s');
  const steady = (d) => (d.steady_cycle && d.steady_cycle.full_stroke_time
    ? ['extend', 'retract'].map((k) => (d.steady_cycle.full_stroke_time[k] == null ? '–' : num(d.steady_cycle.full_stroke_time[k], 3))).join(' / ') : '–');
  // the short list: the least-air design of each cylinder (others: near-identical valve sizes)
  const shortList = ans.designs.some((d) => d.best_of_cylinder === false) && !SZ.showAll;
  const shown = ans.designs.map((d, i) => [d, i]).filter(([d, i]) => !shortList || d.best_of_cylinder || i === SZ.chosen);
  const checks = (d) => {
    const c = d.checks;
    if (!c) return '–';
    const lf = Object.values(c.load_factor).filter((v) => v != null);
    return `<span class="${c.load_factor_ok ? '' : 'warn'}">${num(lf.length ? Math.max(...lf) : 0, 2)}</span> / ` +
      `<span class="${c.buckling_ok ? '' : 'warn'}">${c.buckling_safety == null ? '–' : num(c.buckling_safety, 3)}</span>`;
  };
  const rows = shown.map(([d, i]) => `<tr data-rank="${d.rank}" title="${esc(d.why || '')}">
    <td><input type="radio" name="sz-pick" value="${i}" ${i === SZ.chosen ? 'checked' : ''} aria-label="choose design ${d.rank}"></td>
    <td>${d.rank}</td><td>${esc(d.cylinder.name)}</td><td>${esc(d.valve.name)}</td>
    <td>${esc(d.tube ? d.tube.name : '–')}</td><td>${num(d.air_per_cycle, 3)}</td>
    <td>${metric(d, 'extend', 'full_stroke_time')}</td><td>${metric(d, 'retract', 'full_stroke_time')}</td>
    <td class="sz-steady">${steady(d)}</td>
    <td>${metric(d, 'extend', 'end_speed')}</td><td>${metric(d, 'retract', 'end_speed')}</td>
    <td>${num(CU.val(d.settings.extend_meter_out_C), 3)} / ${num(CU.val(d.settings.retract_meter_out_C), 3)}</td>
    ${cushioned ? cushionCells(d) : ''}
    <td class="sz-checks">${checks(d)}</td>
    <td>${d.feasible ? 'yes' : 'no'}</td></tr>`).join('');
  const reasons = Object.entries(ans.reasons).map(([r, n]) => `${n} ${esc(r)} (${esc(ans.reason_meanings[r] || '')})`).join('; ');
  document.getElementById('sizing-table').innerHTML = `<table id="sizing-designs"><thead><tr><th></th><th>rank</th>
    <th>cylinder</th><th>valve</th><th>tube</th><th>air per cycle [NL]</th><th>extend [s]</th><th>retract [s]</th>
    <th>steady cycle ext / ret [s]</th>
    <th>end speed out [${esc(VU.label)}]</th><th>end speed in [${esc(VU.label)}]</th><th>meter-out throttle C ext / ret [${esc(CU.label)}] (0: none)</th>${cushioned ? `<th>cushion needle C ext / ret [${esc(CU.label)}] (open: not needed)</th><th>impact energy ext / ret / capacity [J]</th>` : ''}<th title="SMC load factor (limit 0.5 moving a load) / Euler buckling safety of the rod (at least 3)">load factor / buckling safety [-]</th><th>feasible</th></tr></thead>
    <tbody>${rows}</tbody></table>
    <p class="small" id="sizing-shortlist">${shortList ? `Short list: the best design of each cylinder (${shown.length} of ${ans.designs.length}). <button type="button" id="btn-size-all">Show all ${ans.designs.length}</button>`
      : (ans.designs.some((d) => d.best_of_cylinder === false) ? `All ${ans.designs.length} designs. <button type="button" id="btn-size-all">Short list</button>` : '')}</p>
    <p class="small" id="sizing-why">${esc((ans.designs[SZ.chosen] || {}).why || '')}</p>
    <p class="muted small">${ans.families} families; failing: ${reasons || 'none'}.</p>
    <ul class="muted small">${ans.notes.map((n) => `<li>${esc(n)}</li>`).join('')}</ul>`;
  for (const r of document.querySelectorAll('input[name="sz-pick"]')) {
    r.addEventListener('change', (ev) => {
      SZ.chosen = Number(ev.target.value);
      document.getElementById('sizing-why').textContent = (SZ.ans.designs[SZ.chosen] || {}).why || '';
      plotChosenDesign();
    });
  }
  const all = document.getElementById('btn-size-all');
  if (all) all.addEventListener('click', () => { SZ.showAll = !SZ.showAll; renderSizing(); });
  const none = !ans.designs.length;
  document.getElementById('btn-size-use').disabled = none;
  document.getElementById('btn-size-export').disabled = none;
}

/** A design's cushion cells: each end's needle (open where not needed), impact energy and capacity. */
function cushionCells(d) {
  const c = d.cushion;
  if (!c) return '<td>–</td><td>–</td>';
  const CU = metricDisplay('m^3/(s Pa)');
  const needle = (k) => (c[k].needle_solved ? num(CU.val(c[k].needle_C), 3) : 'open');
  const energy = (k) => (c[k].end_energy == null ? '–' : num(c[k].end_energy, 3));
  return `<td class="sz-needle">${needle('extend')} / ${needle('retract')}</td>
    <td class="sz-impact">${energy('extend')} / ${energy('retract')} / ${num(c.capacity, 3)}</td>`;
}

/** One cycle of the chosen design: extension from rest, then retraction. */
async function plotChosenDesign() {
  const d = SZ.ans && SZ.ans.designs[SZ.chosen];
  if (!d) return;
  const req = SZ.ans.requirement;
  // the times this design was sized for (with a cycle time, its shares of it)
  const t1 = 1.5 * d.required_times.extend;
  const t2 = 1.5 * d.required_times.retract;
  const scenario = { duration: t1 + t2, sample_period: (t1 + t2) / 1000,
    command: [[0, 1], [t1, -1]], x0: 0, initial: { p_b: req.supply_pressure } };
  const r = await api('POST', '/api/simulate', { model: d.model, scenario, series: ['t', 'x', 'v'] });
  SZ.plotRun = { r, d };
  drawSizingPlot();
}
/** The chosen design's cycle (SZ.plotRun) in the page's units. */
function drawSizingPlot() {
  if (!SZ.plotRun) return;
  const { r, d } = SZ.plotRun;
  const X = plotUnit('m'), V = plotUnit('m/s');
  plot('sizing-plot', [
    { x: r.series.t, y: X.val(r.series.x), name: `x [${X.label}]`, mode: 'lines' },
    { x: r.series.t, y: V.val(r.series.v), name: `v [${V.label}]`, mode: 'lines', yaxis: 'y2' },
  ], baseLayout({ title: { text: `rank ${d.rank}: ${d.cylinder.name} + ${d.valve.name}`, font: { size: 13 } },
    xaxis: axis('t [s]'), yaxis: axis(`x [${X.label}]`),
    // its own round ticks (Plotly otherwise lines them up with x's grid: 0.555, 0.081, -0.394)
    yaxis2: axis(`v [${V.label}]`, { overlaying: 'y', side: 'right', showgrid: false, tickmode: 'auto', nticks: 6 }) }));
  document.getElementById('panel-sizing').dataset.plotted = String(d.rank);
}

async function runSizing(btn) {
  clearErrors();
  setStatus('Sizing: every cylinder, valve and tube, meter-out and cushion settings solved…', 'busy');
  try {
    SZ.ans = await api('POST', '/api/sizing', sizingRequest());
    SZ.chosen = 0;
    renderSizing();
    document.getElementById('panel-sizing').dataset.sized = String(SZ.ans.designs.length);
    setStatus(`Sizing: ${SZ.ans.summary}.`, SZ.ans.designs.some((d) => d.feasible) ? 'ok' : 'error');
    await plotChosenDesign();
  } catch (e) {
    showApiError(e, 'Sizing');
    document.getElementById('panel-sizing').dataset.sized = 'error';
  }
}

function useChosenDesign() {
  const d = SZ.ans && SZ.ans.designs[SZ.chosen];
  if (!d) return;
  S.model = clone(d.model);
  renderModel();
  // the design's machine cycle from its steady state: the simulation then times the strokes the
  // sizing table shows (the first ranked designs carry it)
  const cyc = d.steady_cycle && d.steady_cycle.scenario;
  if (cyc) { S.scenario = clone(cyc); renderScenario(); }
  setStatus(`Model panel: design ${d.rank} (${d.cylinder.name} + ${d.valve.name})` +
    (cyc ? '; scenario: its steady cycle (start: cyclic steady state).' : '.'), 'ok');
  if (window.showView) showView('model');   // the workspace shows the model it went into
}

function exportChosenDesign() {
  const d = SZ.ans && SZ.ans.designs[SZ.chosen];
  if (!d) return;
  saveBlob(new Blob([JSON.stringify(d.model, null, 1)], { type: 'application/json' }), `design-${d.rank}-model.json`);
}

/** The accepted series names under the choice fields (GET /api/sizing/series). */
async function showSizingSeries() {
  let s;
  try { s = await api('GET', '/api/sizing/series'); } catch (e) { return; }
  const box = document.getElementById('sizing-form');
  const p = document.createElement('p');
  p.id = 'sz-series-hint';
  p.className = 'muted small';
  const list = (kind) => Object.entries(s[kind]).map(([n, v]) => `${n} (${v.members.join(', ')})`).join('; ');
  p.textContent = `Series you may name (a series, or series:member): cylinders ${list('cylinders')}; valves ${list('valves')}; tubes ${list('tubes')}.`;
  box.append(p);
}
function initSizing() {
  buildSizingForm();
  showSizingSeries();
  document.getElementById('sizing-form').addEventListener('input', sizingInput);
  // the form starts from the model panel's design once the page holds it
  const wait = setInterval(() => { if (document.body.dataset.ready && S.model) { clearInterval(wait); sizingFromModel(); } }, 100);
  document.getElementById('btn-size').addEventListener('click', (ev) => busy(ev.target, () => runSizing(ev.target)));
  document.getElementById('btn-size-use').addEventListener('click', useChosenDesign);
  document.getElementById('btn-size-export').addEventListener('click', exportChosenDesign);
  document.getElementById('panel-sizing').dataset.ready = 'true';
}
if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', initSizing); else initSizing();
