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
  ['cushion_capacity', 'Cushion capacity of bores no catalogue gives', 'J', '', 'blank: none (such a bore is refused)'],
  ['tube_length', 'Tube length per port', 'm', '', 'blank: no tube'],
  ['valve_on_time', 'Valve switching time ON, catalogue', 's', '', 'blank: 0'],
  ['valve_off_time', 'Valve switching time OFF, spring return', 's', '', 'blank: 0'],
  // the load checks' limits: their defaults and notes are the API's (its OpenAPI schema, read
  // by sizingLimitDefaults), never a copy here
  ['max_load_factor', 'Max load factor, load over the theoretical output at the supply', '-', '', ''],
  ['min_buckling_safety', "Min buckling safety of the rod (Euler)", '-', '', ''],
];
/** The fields whose default is the API's own (RequirementSpec's in /openapi.json). */
const SIZING_LIMITS = ['max_load_factor', 'min_buckling_safety'];
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
  applyCapacityUnits();
  if (SZ.ans) renderSizing();
  drawSizingPlot();
}
function sizingInput(ev) {
  const el = ev.target;
  if (!el.dataset || !el.dataset.si) return;
  if (ev.type === 'input') el.dataset.edited = 'true';
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
/** A number field's text the browser could not read ("1e", "0,7"): its value reads '' and would
 * send nothing (the API's default, or an older value, in place of what the user typed), so the
 * request carries this instead and the API's 422 names the field. */
const NOT_A_NUMBER = 'not a number';
function badNumber(el) { return !!(el.validity && el.validity.badInput); }
function sizingRequest() {
  const requirement = {};
  for (const [name] of SIZING_FIELDS) {
    const el = document.getElementById(`sz-${name}`);
    if (badNumber(el)) { requirement[name] = NOT_A_NUMBER; continue; }
    sizingInput({ target: el });
    const v = (el.dataset.siValue || '').trim();
    if (v !== '') requirement[name] = Number(v);
  }
  const table = capacityRequest();
  if (table.length) requirement.cushion_capacities = table;
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
    <th>end speed out [${esc(VU.label)}]</th><th>end speed in [${esc(VU.label)}]</th><th>meter-out throttle C ext / ret [${esc(CU.label)}] (0: none)</th>${cushioned ? `<th>cushion needle C ext / ret [${esc(CU.label)}] (open: not needed)</th><th>impact energy ext / ret / capacity [J]</th>` : ''}<th title="${esc(limitsTitle(ans))}">load factor / buckling safety [-]</th><th>feasible</th></tr></thead>
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

/** The load checks' column title with the limits the answer was sized to (the request's). */
function limitsTitle(ans) {
  const r = ans.requirement || {};
  return `SMC load factor (limit ${r.max_load_factor}) / Euler buckling safety of the rod (at least ${r.min_buckling_safety})`;
}

/* ---------------------------------------------------------- the cushion capacity table
 * requirement.cushion_capacities: one row per {series, bore [m], capacity [J]}; the bore is
 * shown in the page's units (its SI value kept in data-si-value like the form's fields), the
 * energy in J. Each cell's data-field is its index in the request, renumbered as rows go, so
 * that a 422 lands next to the cell it names; the request is read from the cells as they are
 * when Size is pressed (a removed row is gone, an edited cell sends what it shows). */
const CAP_COLUMNS = [
  ['series', 'series (blank: every series)', '-'],
  ['bore', 'bore', 'm'],
  ['capacity', 'capacity', 'J'],
];
let CAP_ROW_KEY = 0;
function capacityRows() { return Array.from(document.querySelectorAll('#sz-cap-table tbody tr')); }
function capLabel(i, text, si) { return `Row ${i + 1} ${text} [${prettyUnitText(sizingShown(si).unit)}]`; }
/** Add a row (values in SI; blank by default). */
function addCapacityRow(values = {}) {
  const key = CAP_ROW_KEY++;
  const tr = document.createElement('tr');
  tr.dataset.key = String(key);
  for (const [col, , si] of CAP_COLUMNS) {
    const td = document.createElement('td');
    const input = document.createElement('input');
    input.id = `sz-cap-${key}-${col}`;
    input.className = `sz-cap-${col}`;
    if (col === 'series') {
      input.type = 'text';
      input.setAttribute('list', 'sz-cap-series-list');
      input.value = values.series || '';
    } else {
      input.type = 'number';
      input.step = 'any';
      input.dataset.si = si;
      input.dataset.siValue = values[col] == null ? '' : String(values[col]);
    }
    const lab = document.createElement('label');
    lab.htmlFor = input.id;
    lab.className = 'sr-only';
    const err = document.createElement('span');
    err.className = 'field-error';
    err.setAttribute('role', 'alert');
    td.append(lab, input, err);
    tr.append(td);
  }
  const td = document.createElement('td');
  const rm = document.createElement('button');
  rm.type = 'button';
  rm.className = 'sz-cap-remove';
  rm.textContent = 'Remove';
  rm.addEventListener('click', () => { tr.remove(); renumberCapacityRows(); });
  td.append(rm);
  tr.append(td);
  document.querySelector('#sz-cap-table tbody').append(tr);
  renumberCapacityRows();
  applyCapacityUnits();
  return tr;
}
/** Each row's data-field and labels follow its place in the table (the request's index). */
function renumberCapacityRows() {
  capacityRows().forEach((tr, i) => {
    for (const [col, text, si] of CAP_COLUMNS) {
      const input = tr.querySelector(`.sz-cap-${col}`);
      input.dataset.field = `requirement.cushion_capacities[${i}].${col}`;
      document.querySelector(`label[for="${input.id}"]`).textContent = capLabel(i, text, si);
    }
    tr.querySelector('.sz-cap-remove').setAttribute('aria-label', `remove row ${i + 1}`);
    // an error shown for the index this row had is not this row's any more
    for (const e of tr.querySelectorAll('.field-error')) e.textContent = '';
    for (const e of tr.querySelectorAll('.invalid')) { e.classList.remove('invalid'); e.removeAttribute('aria-invalid'); }
  });
}
/** The table's headers, labels and bores in the page's unit system. */
function applyCapacityUnits() {
  for (const [col, text, si] of CAP_COLUMNS) {
    const th = document.getElementById(`sz-cap-h-${col}`);
    if (th) th.textContent = `${text} [${prettyUnitText(sizingShown(si).unit)}]`;
  }
  capacityRows().forEach((tr, i) => {
    for (const [col, text, si] of CAP_COLUMNS) {
      const input = tr.querySelector(`.sz-cap-${col}`);
      document.querySelector(`label[for="${input.id}"]`).textContent = capLabel(i, text, si);
      if (col === 'series') continue;
      const d = sizingShown(si);
      const v = input.dataset.siValue;
      input.value = v === '' || v == null ? '' : String(+((Number(v) - d.offset) / d.scale).toPrecision(10));
    }
  });
}
/** The table as the request's requirement.cushion_capacities: every row, read now. A blank
 * bore or capacity goes as null and unreadable text as NOT_A_NUMBER, so that the API's 422
 * names the cell rather than a row being dropped (which would move the others' indices). */
function capacityRequest() {
  return capacityRows().map((tr) => {
    const out = {};
    for (const [col] of CAP_COLUMNS) {
      const input = tr.querySelector(`.sz-cap-${col}`);
      if (col === 'series') { out.series = input.value.trim() || null; continue; }
      if (badNumber(input)) { out[col] = NOT_A_NUMBER; continue; }
      sizingInput({ target: input });
      const v = (input.dataset.siValue || '').trim();
      out[col] = v === '' ? null : (Number.isFinite(Number(v)) ? Number(v) : NOT_A_NUMBER);
    }
    return out;
  });
}
/** The limits' defaults and meanings from the API's schema (RequirementSpec in /openapi.json). */
async function sizingLimitDefaults() {
  let props;
  try { props = (await fetchOpenApi()).components.schemas.RequirementSpec.properties; } catch (e) { return; }
  for (const name of SIZING_LIMITS) {
    const p = props[name];
    const el = document.getElementById(`sz-${name}`);
    const row = SIZING_FIELDS.find((f) => f[0] === name);
    if (!p || !el || !row || p.default == null) continue;
    row[4] = `blank: ${p.default}`;
    el.title = p.description || '';
    el.dataset.default = String(p.default);
    // the user's own value stays; a field not yet typed in takes the API's default
    if ((el.dataset.siValue || '') === '' && !el.dataset.edited) el.dataset.siValue = String(p.default);
  }
  applySizingUnits();
  document.getElementById('panel-sizing').dataset.limits = 'true';
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
  // the catalogue's cushion capacities: what a sizing with a cushion takes for those bores
  // (the table below overrides one), and the rubber bumpers' (a sizing without a cushion)
  const energies = (key) => Object.entries(s.cylinders).filter(([, v]) => v[key])
    .map(([n, v]) => `${n}: ${Object.entries(v[key]).map(([m, e]) => `${m} ${num(e, 3)}`).join(', ')}`).join('; ');
  const q = document.createElement('p');
  q.id = 'sz-series-capacities';
  q.className = 'muted small';
  const cu = energies('cushion_capacity'), bu = energies('bumper_capacity');
  q.textContent = (cu ? `Catalogue cushion capacities [J] (taken for those bores unless the table names them): ${cu}.` : '')
    + (bu ? ` Rubber bumpers [J] (without a cushion): ${bu}.` : '');
  if (q.textContent) box.append(q);
  // the capacity table's series: the cylinder series (a typed name is sent as typed)
  const dl = document.getElementById('sz-cap-series-list');
  dl.textContent = '';
  for (const n of Object.keys(s.cylinders)) { const o = document.createElement('option'); o.value = n; dl.append(o); }
}
function initSizing() {
  buildSizingForm();
  showSizingSeries();
  document.getElementById('sizing-form').addEventListener('input', sizingInput);
  sizingLimitDefaults();
  const caps = document.getElementById('sizing-capacities');
  caps.addEventListener('input', (ev) => {
    sizingInput(ev);
    // the cell's 422 goes once it is edited (it was about the value no longer there)
    const el = ev.target;
    el.classList.remove('invalid');
    el.removeAttribute('aria-invalid');
    const slot = el.nextElementSibling;
    if (slot && slot.classList.contains('field-error')) { slot.textContent = ''; slot.removeAttribute('data-error-for'); }
  });
  document.getElementById('btn-sz-cap-add').addEventListener('click', () => addCapacityRow().querySelector('input').focus());
  // the form starts from the model panel's design once the page holds it
  const wait = setInterval(() => { if (document.body.dataset.ready && S.model) { clearInterval(wait); sizingFromModel(); } }, 100);
  document.getElementById('btn-size').addEventListener('click', (ev) => busy(ev.target, () => runSizing(ev.target)));
  document.getElementById('btn-size-use').addEventListener('click', useChosenDesign);
  document.getElementById('btn-size-export').addEventListener('click', exportChosenDesign);
  document.getElementById('panel-sizing').dataset.ready = 'true';
}
if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', initSizing); else initSizing();
