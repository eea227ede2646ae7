/* pneucore page: the step-by-step identification of the paper (section 4), loaded after app.js
 * (uses its S, api, busy, plot, num, fieldError, showApiError, runCompare, ... helpers).
 *
 * 1. valve flow bench (ISO 6358-1; paper section 2.1, Fig. 2): a bench file -> POST
 *    /api/identify/valve -> C(u), b(u) with standard errors, the null band, every point's
 *    residual; plotted as the paper's Fig. 2 (C and b against the opening) beside the measured
 *    flow against the pressure ratio with the identified law at the same points;
 * 2. friction bench (section 2.3, Fig. 4): stored records with the rod force F -> POST
 *    /api/identify/friction -> the law with standard errors, the friction map (force against
 *    velocity, both quadrants, one colour per pressure level) and the prediction of records not
 *    fitted on; or the rig's own files as they come (no header, the columns declared, the TU Delft
 *    bench's layout by default) read by POST /api/identify/friction/records into records sent
 *    inline (chamber B at ambient when the files have no p_b: the answer's warnings say so);
 * 3. locked-chamber tests (Figs. 6-7) and 4. free motion (Figs. 9-10): the model, with the bench
 *    values in it, compared on its own tests (panel 4 shows the plots).
 * "Carry into the model" puts the answer's model in the model panel: its provenance marks the
 * bench values, which later calibrations, diagnoses and refinements hold (bench_known).
 * Also here: the rod force F and the flows q_a, q_b, q_s of a comparison (plotCompareBench).
 * All text from the server, a file or the user goes through textContent.
 */
'use strict';

const IDF = { valve: null, friction: null, extras: [], rig: [] };

/** Bench file columns, SI units (the CLI's `pneucore identify valve` reads the same CSV). */
const BENCH_COLUMNS = { opening: '-', p_up: 'Pa', p_down: 'Pa', T_up: 'K', flow: 'kg/s' };
/** Colours of the pressure levels of the friction map, in order of gauge pressure. */
const LEVEL_COLORS = ['#1f77b4', '#2ca02c', '#ff7f0e', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#17becf'];

/* ------------------------------------------------------------------ small DOM helpers */
function h(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'text') e.textContent = v;
    else if (k === 'dataset') Object.assign(e.dataset, v);
    else e.setAttribute(k, v);
  }
  for (const c of children) if (c != null) e.append(c);
  return e;
}
function fieldBox(label, control, field) {
  control.dataset.field = field;
  const lab = h('label', { for: control.id, text: label });
  return h('div', { class: 'field' }, lab, control, h('span', { class: 'field-error', role: 'alert' }));
}
function textTable(id, headers, rows) {
  const t = h('table', { id, class: 'data' });
  const hr = t.createTHead().insertRow();
  for (const x of headers) hr.append(h('th', { scope: 'col', text: x }));
  const body = t.createTBody();
  for (const r of rows) {
    const tr = body.insertRow();
    if (r.dataset) Object.assign(tr.dataset, r.dataset);
    for (const c of r.cells) { const td = tr.insertCell(); td.textContent = c; if (/^[-+−]?[0-9.]/.test(c)) td.className = 'num'; }
  }
  return t;
}
/** value ± se as text ('–' for a missing one). */
function pm(v, se, digits = 4) { return se == null ? num(v, digits) : `${num(v, digits)} ± ${num(se, 2)}`; }

/* ------------------------------------------------------------------ the panel */
function buildIdentifyPanel() {
  const panel = document.getElementById('panel-identify');
  panel.textContent = '';
  panel.append(
    h('h2', { text: 'Step by step: identify each component on its own test (paper section 4)' }),
    h('p', { class: 'muted small', text: 'The paper identifies the valve on a flow bench and the seals on a friction bench, '
      + 'then validates on the locked-chamber tests and the free motion. Each step\'s values go into the model with '
      + 'their source (provenance); a later calibration, diagnosis or refinement holds bench values as known.' }));
  // step 1: valve flow bench
  const edge = h('select', { id: 'id-valve-edge' });
  const file = h('input', { id: 'id-valve-file', type: 'file', accept: '.csv,.txt,.json,text/csv,application/json' });
  panel.append(h('section', { id: 'id-step-valve', class: 'id-step' },
    h('h3', { text: '1. Valve flow bench (ISO 6358-1; paper Fig. 2)' }),
    h('p', { class: 'muted small', text: 'A CSV file with a header opening,p_up,p_down,T_up,flow in SI units '
      + '(opening [-], pressures [Pa abs], temperature [K], mass flow [kg/s]; a fixed orifice leaves the opening blank), '
      + 'or JSON {"points": [...]}: one metering edge per file, steady points or a slow sweep.' }),
    h('div', { class: 'grid' }, fieldBox('Metering edge [-]', edge, 'identify.valve.edge'),
      fieldBox('Bench file (CSV or JSON) [-]', file, 'identify.valve.points')),
    h('div', { class: 'row actions' }, h('button', { id: 'btn-id-valve', type: 'button', class: 'primary', text: 'Identify the edge' }),
      h('button', { id: 'btn-id-valve-use', type: 'button', disabled: '', text: 'Carry into the model (marked known: bench)' })),
    h('p', { id: 'id-valve-summary', class: 'small' }),
    h('div', { id: 'id-valve-table', class: 'table-wrap' }),
    h('div', { id: 'id-valve-plot', class: 'plot' })));
  // step 2: friction bench
  const fit = h('select', { id: 'id-fric-fit', multiple: '', size: '5' });
  const val = h('select', { id: 'id-fric-validate', multiple: '', size: '5' });
  panel.append(h('section', { id: 'id-step-friction', class: 'id-step' },
    h('h3', { text: '2. Friction bench (paper Eq. 17-20, Fig. 4)' }),
    h('p', { class: 'muted small', text: 'Records of a prescribed motion with each chamber held at a pressure and the '
      + 'rod force measured: store them here (files with named columns: t, x, p_a, p_b, F with their units) or through '
      + 'panel 4\'s upload (any rig file, its columns mapped, the rod force to F in N, kN, daN or lbf), then choose '
      + 'which records to fit on and which to predict (records not fitted on validate the law).' }),
    h('div', { class: 'row' }, fieldBox('Records to store and fit on: CSV, TDMS, .mat, .npz with named columns (t, x, p_a, p_b, F) [-]',
      h('input', { id: 'id-fric-files', type: 'file', multiple: '', accept: '.csv,.txt,.tsv,.dat,.tdms,.mat,.npz' }), 'identify.friction.files'),
    h('button', { id: 'btn-id-fric-upload', type: 'button', text: 'Store the records' })),
    h('div', { class: 'row' }, fieldBox('Rig files as the rig writes them: no header, one sample a line [-]',
      h('input', { id: 'id-fric-rig-files', type: 'file', multiple: '', accept: '.csv,.txt,.tsv,.dat,text/plain,text/csv' }), 'identify.friction.rig'),
    fieldBox('Their columns in order: signal[unit], - for a column not read, a leading - negates x or F; empty = the TU Delft friction bench [-]',
      h('input', { id: 'id-fric-rig-columns', type: 'text', placeholder: 't[ms], -, -, -, -x[mm], p_a[bar(g)], F[N]', size: '48' }), 'identify.friction.columns'),
    h('button', { id: 'btn-id-fric-rig', type: 'button', text: 'Read the rig files' })),
    h('ul', { id: 'id-fric-rig-warnings', class: 'small' }),
    h('div', { class: 'grid' }, fieldBox('Fit on (records with F) [-]', fit, 'identify.friction.experiments'),
      fieldBox('Predict (validation) [-]', val, 'identify.friction.validate')),
    h('div', { id: 'id-fric-extras', class: 'row' }),
    h('div', { class: 'row actions' }, h('button', { id: 'btn-id-friction', type: 'button', class: 'primary', text: 'Identify the friction' }),
      h('button', { id: 'btn-id-friction-use', type: 'button', disabled: '', text: 'Carry into the model (marked known: bench)' })),
    h('p', { id: 'id-fric-summary', class: 'small' }),
    h('ul', { id: 'id-fric-warnings', class: 'small' }),
    h('div', { id: 'id-fric-params', class: 'table-wrap' }),
    h('div', { id: 'id-fric-plot', class: 'plot' }),
    h('div', { id: 'id-fric-validation', class: 'table-wrap' })));
  // steps 3 and 4: validation on the rig's own tests
  for (const [key, title, note] of [
    ['locked', '3. Locked-chamber tests (paper Figs. 6-7: heat exchange)', 'The piston held: the chambers\' pressure and heat exchange alone.'],
    ['free', '4. Free motion (paper Figs. 9-10)', 'The whole jack: everything identified so far, validated on a motion.']]) {
    const sel = h('select', { id: `id-${key}-select`, multiple: '', size: '4' });
    panel.append(h('section', { id: `id-step-${key}`, class: 'id-step' },
      h('h3', { text: title }), h('p', { class: 'muted small', text: `${note} Compared in panel 4 (plots and tables there).` }),
      fieldBox(`${key === 'locked' ? 'Locked' : 'Free'} tests [-]`, sel, `identify.${key}`),
      h('div', { class: 'row actions' }, h('button', { id: `btn-id-${key}`, type: 'button', text: 'Compare the model on these tests' })),
      h('p', { id: `id-${key}-result`, class: 'small' })));
  }
  panel.append(h('h3', { text: 'Where the model\'s values came from (provenance)' }),
    h('div', { id: 'id-provenance', class: 'table-wrap' }));
}

/* ------------------------------------------------------------------ step 1: valve bench */
function fillEdges() {
  const sel = document.getElementById('id-valve-edge');
  const ports = S.model && S.model.valve && S.model.valve.ports ? Object.keys(S.model.valve.ports) : ['P-A'];
  const was = sel.value;
  sel.textContent = '';
  for (const p of ports) sel.append(h('option', { value: p, text: p }));
  if (ports.includes(was)) sel.value = was;
}

/** Bench points from a file's text: JSON ({points} or a list) or CSV with the BENCH_COLUMNS
 * header (a unit in brackets, if any, must be the SI one). Throws an Error naming the row. */
function parseBenchFile(text) {
  const s = text.trim();
  if (s.startsWith('{') || s.startsWith('[')) {
    const d = JSON.parse(s);
    const pts = Array.isArray(d) ? d : d.points;
    if (!Array.isArray(pts)) throw new Error('a JSON bench file holds {"points": [...]} or a list of points');
    return pts;
  }
  const lines = s.split(/\r?\n/).filter((l) => l.trim() !== '');
  if (lines.length < 2) throw new Error('a header line and at least one point are needed');
  const split = (l) => l.split(/[,;\t]/).map((c) => c.trim());
  const names = split(lines[0]).map((c) => {
    const m = /^([A-Za-z_]+)\s*(?:\[([^\]]*)\])?$/.exec(c);
    if (!m || !(m[1] in BENCH_COLUMNS)) throw new Error(`unknown column "${c}" (known: ${Object.keys(BENCH_COLUMNS).join(', ')})`);
    if (m[2] != null && m[2] !== BENCH_COLUMNS[m[1]]) throw new Error(`column ${m[1]}: unit [${m[2]}] given, the file holds SI units [${BENCH_COLUMNS[m[1]]}]`);
    return m[1];
  });
  return lines.slice(1).map((l, i) => {
    const cells = split(l);
    const p = {};
    names.forEach((n, k) => {
      const c = cells[k];
      if (c == null || c === '') { if (n === 'opening') p[n] = null; return; }
      const v = Number(c);
      if (!Number.isFinite(v)) throw new Error(`row ${i + 2}, column ${n}: "${c}" is not a number`);
      p[n] = v;
    });
    return p;
  });
}

/** An API error whose fields lie inside a request the page built from a file: each message
 * keeps its own path (points[3].p_down) and lands next to `field`. */
function showIdentifyError(err, what, field, where = (loc) => loc) {
  if (err instanceof ApiError && Array.isArray(err.detail)) {
    for (const e of err.detail) {
      const loc = e.field || (Array.isArray(e.loc) ? e.loc.slice(e.loc[0] === 'body' ? 1 : 0).join('.') : '');
      e.msg = `${where(loc)}: ${e.msg}`;
    }
  }
  showApiError(err, what, () => field);
}
/** points[4].p_down -> "points[4].p_down (point 5, line 6 of a CSV file)": where to look in the file. */
function benchPlace(loc) {
  const m = /^points(?:\[|\.)(\d+)/.exec(loc);
  return m ? `${loc} (point ${Number(m[1]) + 1}, line ${Number(m[1]) + 2} of a CSV file)` : loc;
}

async function identifyValve(btn) {
  clearErrors();
  const f = document.getElementById('id-valve-file').files[0];
  if (!f) { fieldError('identify.valve.points', 'choose a bench file first'); setStatus('Valve bench: choose a bench file first.', 'error'); return; }
  let points;
  try { points = parseBenchFile(await f.text()); } catch (e) {
    fieldError('identify.valve.points', `${f.name}: ${e.message}`);
    setStatus(`Valve bench: ${f.name} could not be read.`, 'error');
    return;
  }
  const edge = document.getElementById('id-valve-edge').value;
  setStatus(`Identifying edge ${edge} from ${points.length} bench points…`, 'busy');
  await busy(btn, async () => {
    try {
      IDF.valve = await api('POST', '/api/identify/valve', { edge, points, model: S.model });
      IDF.valvePoints = points;
      renderValve();
      document.getElementById('btn-id-valve-use').disabled = false;
      setStatus(`Edge ${edge} identified on ${points.length} points.`, 'ok');
    } catch (e) {
      const onEdge = e.detail && JSON.stringify(e.detail).includes('"edge');
      showIdentifyError(e, 'Valve bench', onEdge ? 'identify.valve.edge' : 'identify.valve.points', benchPlace);
    }
  });
}

function renderValve() {
  const r = IDF.valve;
  const dm3 = C_UNITS.dm3.scale;   // dm^3/(s bar) in m^3/(s Pa)
  const rows = r.edge.opening.map((u, i) => ({
    dataset: { opening: u == null ? 'fixed' : String(u) },
    cells: [u == null ? 'fixed orifice' : num(u, 4), pm(r.edge.C[i] / dm3, r.C_se[i] == null ? null : r.C_se[i] / dm3),
      r.b_fitted[i] ? pm(r.edge.b[i], r.b_se[i], 3) : `${num(r.edge.b[i], 3)} (copied: closed)`, r.closed[i] ? 'closed' : 'open'],
  }));
  const box = document.getElementById('id-valve-table');
  box.textContent = '';
  box.append(textTable('id-valve-values', ['opening [-]', `C ± se [${C_UNITS.dm3.label}]`, 'b ± se [-]', 'edge'], rows));
  const nb = r.null_band;
  const qu = plotUnit('kg/s');
  document.getElementById('id-valve-summary').textContent = `Edge ${r.name}: ${r.points.length} points, rms residual `
    + `${num(qu.diff([r.rms_residual])[0], 3)} ${qu.label}; ` + (r.fixed_orifice ? 'a fixed orifice: one C and one b. '
      : nb ? `null / overlap band from u = ${num(nb.low, 3)} to ${num(nb.high, 3)} (C reaches zero at ${num(nb.onset_low, 3)} and ${num(nb.onset_high, 3)}). `
        : 'no closed opening. ') + `Law linearised above p_down/p_up = ${num(r.laminar_ratio, 3)}, as in the model.`;
  plotValveBench(r);
}

/** Fig. 2 as the paper draws it (C and b against the opening) and the bench's own view, the
 * mass flow against the pressure ratio per opening: measured points and the identified law at
 * the same points (joined in order of ratio). */
function plotValveBench(r) {
  const dm3 = C_UNITS.dm3.scale;
  const traces = [];
  const u = r.edge.opening.map((x) => (x == null ? 0 : x));
  traces.push({ x: u, y: r.edge.C.map((c) => c / dm3), error_y: { type: 'data', array: r.C_se.map((s) => (s == null ? 0 : s / dm3)), visible: true },
    mode: 'lines+markers', name: `C(u) [${C_UNITS.dm3.label}]`, xaxis: 'x', yaxis: 'y', line: { color: '#1f77b4' } });
  traces.push({ x: u, y: r.edge.b, error_y: { type: 'data', array: r.b_se.map((s) => (s == null ? 0 : s)), visible: true },
    mode: 'lines+markers', name: 'b(u) [-]', xaxis: 'x', yaxis: 'y2', line: { color: '#d62728', dash: 'dot' } });
  // one curve per opening and upstream pressure (the points answer in the request's order;
  // upstream pressures within 0.1 bar are one curve: a regulator's setting)
  const sent = IDF.valvePoints || [];
  const groups = new Map();
  r.points.forEach((p, i) => {
    const k = p.opening == null ? 'fixed' : String(p.opening);
    const pu = sent[i] ? Math.round(sent[i].p_up / 1e4) : 0;
    if (!groups.has(k)) groups.set(k, new Map());
    const byP = groups.get(k);
    if (!byP.has(pu)) byP.set(pu, []);
    byP.get(pu).push(p);
  });
  const qu = plotUnit('kg/s');   // the header's unit switch (units.js)
  let i = 0;
  for (const [k, byP] of groups) {
    const color = LEVEL_COLORS[i++ % LEVEL_COLORS.length];
    const label = k === 'fixed' ? 'orifice' : `u = ${num(Number(k), 3)}`;
    let first = true;
    for (const pts of byP.values()) {
      const s = pts.slice().sort((a, b) => a.ratio - b.ratio);
      traces.push({ x: s.map((p) => p.ratio), y: qu.val(s.map((p) => p.flow)), mode: 'markers', name: `${label} measured`,
        legendgroup: k, showlegend: first, xaxis: 'x3', yaxis: 'y3', marker: { color, size: 5 } });
      traces.push({ x: s.map((p) => p.ratio), y: qu.val(s.map((p) => p.flow_model)), mode: 'lines', name: `${label} ISO 6358`,
        legendgroup: k, showlegend: false, xaxis: 'x3', yaxis: 'y3', line: { color, width: 1.2 } });
      first = false;
    }
  }
  const layout = baseLayout({ height: 340, hovermode: 'closest', margin: { l: 64, r: 64, t: 40, b: 46 } });
  layout.xaxis = axis('opening u [-]', { domain: [0, 0.42] });
  layout.yaxis = axis(`C [${C_UNITS.dm3.label}]`);
  layout.yaxis2 = axis('b [-]', { overlaying: 'y', side: 'right', showgrid: false, mirror: false });
  layout.xaxis3 = axis('pressure ratio p_down / p_up [-]', { domain: [0.58, 1], anchor: 'y3' });
  layout.yaxis3 = axis(`mass flow [${qu.label}]`, { anchor: 'x3' });
  layout.legend = { orientation: 'h', x: 0, y: -0.25, yanchor: 'top', font: { size: 10 } };
  layout.height = 420;
  layout.shapes = [];
  if (r.null_band) {
    layout.shapes.push({ type: 'rect', xref: 'x', yref: 'paper', x0: r.null_band.low, x1: r.null_band.high, y0: 0, y1: 1,
      fillcolor: '#9aa5b1', opacity: 0.18, line: { width: 0 }, layer: 'below' });
  }
  plot('id-valve-plot', traces, layout);
  document.getElementById('id-valve-plot').dataset.points = String(r.points.length);
}

/* ------------------------------------------------------------------ step 2: friction bench */
function fillDatasetLists() {
  const ds = S.datasets || [];
  // the rig's files read in this step (records held here, sent inline) beside the stored datasets
  const rig = IDF.rig.map((r, i) => ({ id: `rig:${i}`, name: r.name, signals: ['t', 'x', 'p_a', 'p_b', 'F'], rig: true }));
  const lists = {
    'id-fric-fit': rig.concat(ds.filter((d) => d.signals.includes('F'))),
    'id-fric-validate': rig.concat(ds.filter((d) => d.signals.includes('F'))),
    'id-locked-select': ds.filter((d) => d.scenario && d.scenario.locked),
    'id-free-select': ds.filter((d) => !(d.scenario && d.scenario.locked)),
  };
  for (const [id, list] of Object.entries(lists)) {
    const sel = document.getElementById(id);
    const was = new Set(Array.from(sel.selectedOptions).map((o) => o.value));
    sel.textContent = '';
    for (const d of list) {
      const o = h('option', { value: d.id, text: `${d.name} (${d.rig ? 'rig file: ' : ''}${d.signals.join(', ')})` });
      o.selected = was.has(d.id);
      sel.append(o);
    }
  }
}

/** Friction-bench files stored as datasets (POST /api/datasets, the importer's own column
 * mapping from the names and units) and chosen to fit on; a file whose rod force the importer
 * cannot find is named (its columns are mapped in panel 4's upload). */
async function uploadFrictionRecords(btn) {
  clearErrors();
  const files = Array.from(document.getElementById('id-fric-files').files);
  if (!files.length) { fieldError('identify.friction.files', 'choose one or more record files first'); return; }
  await busy(btn, async () => {
    const stored = [];
    for (const f of files) {
      setStatus(`Storing ${f.name}…`, 'busy');
      const fd = new FormData();
      fd.append('file', f);
      fd.append('name', f.name.replace(/\.[^.]*$/, '').slice(0, 200));
      fd.append('ambient_pressure', String(pAtm()));
      try {
        const info = await api('POST', '/api/datasets', fd);
        if (!info.signals.includes('F')) fieldError('identify.friction.files', `${f.name}: stored, but no rod force column was found (signals ${info.signals.join(', ')}): map it to F in panel 4's upload`);
        else stored.push(info.id);
      } catch (e) { showIdentifyError(e, `Storing ${f.name}`, 'identify.friction.files', (loc) => `${f.name}${loc ? ' ' + loc : ''}`); return; }
    }
    await loadDatasets();
    fillDatasetLists();
    for (const o of document.getElementById('id-fric-fit').options) if (stored.includes(o.value)) o.selected = true;
    setStatus(`${stored.length} record(s) with a rod force stored and chosen to fit on.`, stored.length === files.length ? 'ok' : 'error');
  });
}

/** The rig's files as they come (no header): POST /api/identify/friction/records reads them with
 * the declared columns (empty: the TU Delft bench's layout) into records held here and chosen to
 * fit on; its warnings (chamber B taken at ambient) are listed under the files. A refused file is
 * named with its line and column. */
async function readRigFiles(btn) {
  clearErrors();
  const files = Array.from(document.getElementById('id-fric-rig-files').files);
  if (!files.length) { fieldError('identify.friction.rig', 'choose one or more rig files first'); return; }
  const fd = new FormData();
  for (const f of files) fd.append('file', f);
  const cols = document.getElementById('id-fric-rig-columns').value.trim();
  if (cols) fd.append('columns', cols);
  fd.append('ambient_pressure', String(pAtm()));
  setStatus(`Reading ${files.length} rig file(s)…`, 'busy');
  await busy(btn, async () => {
    let out;
    try { out = await api('POST', '/api/identify/friction/records', fd); } catch (e) {
      const onCols = e.detail && JSON.stringify(e.detail).includes('"columns');
      showIdentifyError(e, 'Reading the rig files', onCols ? 'identify.friction.columns' : 'identify.friction.rig', (loc) => {
        const m = /^file\[(\d+)\](?:\.line\[(\d+)\])?/.exec(loc);
        return m && files[Number(m[1])] ? `${files[Number(m[1])].name}${m[2] ? `, line ${m[2]}` : ''}` : loc;
      });
      return;
    }
    const first = IDF.rig.length;
    IDF.rig = IDF.rig.concat(out.records);
    const ul = document.getElementById('id-fric-rig-warnings');
    ul.textContent = '';
    for (const w of out.warnings) ul.append(h('li', { class: 'warn', text: w }));
    for (const f of out.files) ul.append(h('li', { text: `${f.name}: ${f.samples} samples over ${num(f.duration, 4)} s, `
      + `p_a ${num((f.p_a_median - out.ambient_pressure) / BAR, 3)} bar g, stroke ${num(f.stroke * 1e3, 3)} mm` }));
    fillDatasetLists();
    const fresh = out.records.map((r, i) => `rig:${first + i}`);
    for (const o of document.getElementById('id-fric-fit').options) if (fresh.includes(o.value)) o.selected = true;
    setStatus(`${out.records.length} rig file(s) read and chosen to fit on.`, 'ok');
  });
}

async function loadExtras() {
  // the extras the service can identify, from its own schema (pneucore.identify.friction_bench.EXTRAS)
  try {
    const spec = await fetchOpenApi();
    const req = spec.components.schemas.FrictionIdentifyRequest.properties.extras;
    IDF.extras = (req.items && req.items.enum) || [];
  } catch (e) { IDF.extras = []; }
  const box = document.getElementById('id-fric-extras');
  box.textContent = '';
  if (IDF.extras.length) box.append(h('span', { class: 'small', text: 'Also identify: ' }));
  for (const x of IDF.extras) {
    const cb = h('input', { type: 'checkbox', id: `id-extra-${x}`, value: x });
    // a choice, not a quantity: [-] (the extra's own unit is in its result row)
    box.append(h('label', { class: 'check small' }, cb, ` ${x} `, h('span', { class: 'sr-only', text: '(identify it) [-]' })));
  }
}

async function identifyFriction(btn) {
  clearErrors();
  const chosen = (id) => Array.from(document.getElementById(id).selectedOptions).map((o) => (o.value.startsWith('rig:')
    ? IDF.rig[Number(o.value.slice(4))] : { dataset_id: o.value, name: o.textContent.replace(/ \(.*$/, '') }));
  const experiments = chosen('id-fric-fit');
  const validate = chosen('id-fric-validate');
  if (!experiments.length) {
    fieldError('identify.friction.experiments', 'choose at least one record with a rod force F (upload it in panel 4)');
    setStatus('Friction bench: no record chosen.', 'error');
    return;
  }
  const extras = IDF.extras.filter((x) => { const cb = document.getElementById(`id-extra-${x}`); return cb && cb.checked; });
  setStatus(`Identifying the friction on ${experiments.length} record(s)…`, 'busy');
  await busy(btn, async () => {
    try {
      IDF.friction = await api('POST', '/api/identify/friction', { model: S.model, experiments, validate, extras });
      IDF.frictionNames = experiments.map((e) => e.name);
      renderFrictionBench();
      document.getElementById('btn-id-friction-use').disabled = false;
      setStatus(`Friction identified: rms force residual ${num(IDF.friction.rms, 3)} N.`, 'ok');
    } catch (e) {
      const field = e.detail && JSON.stringify(e.detail).includes('"validate') ? 'identify.friction.validate' : 'identify.friction.experiments';
      showIdentifyError(e, 'Friction bench', field);
    }
  });
}

function renderFrictionBench() {
  const r = IDF.friction;
  const rows = Object.entries(r.parameters).map(([name, p]) => ({
    dataset: { name },
    cells: [name, p.identified === false ? `${num(p.value, 4)} (held)` : pm(p.value, p.se), prettyUnit(p.unit || '-'),
      p.identified === false ? (p.reason || 'not determined: held at the model\'s value')
        : p.at_bound ? 'identified, at a bound'
          : p.se != null && Math.abs(p.se) > Math.abs(p.value) ? 'not determined: its standard error exceeds its value' : 'identified'],
  }));
  const box = document.getElementById('id-fric-params');
  box.textContent = '';
  box.append(textTable('id-fric-values', ['parameter', 'value ± se', 'unit', 'status'], rows));
  document.getElementById('id-fric-summary').textContent = `rms force residual ${num(r.rms, 3)} N over the sliding samples; `
    + (r.linear_in_pressure === false ? 'the friction is NOT linear in pressure: Eq. 19-20 do not hold (see the warnings).'
      : r.linear_in_pressure ? 'friction linear in pressure (Eq. 19-20 hold).' : 'linearity in pressure not testable (fewer than three levels).')
    + (r.stribeck && r.stribeck.kept ? ` Breakaway (Stribeck) term kept: static ratio ${num(r.stribeck.static_ratio, 3)}.` : '');
  const ul = document.getElementById('id-fric-warnings');
  ul.textContent = '';
  for (const w of r.warnings || []) ul.append(h('li', { class: 'warn', text: w }));
  document.getElementById('id-step-friction').dataset.linear = String(r.linear_in_pressure);
  plotFrictionMap(r);
  const vbox = document.getElementById('id-fric-validation');
  vbox.textContent = '';
  if ((r.validation || []).length) {
    const d = (x) => (x && x.rms != null ? `${num(x.mean, 3)} / ${num(x.rms, 3)}` : '–');
    vbox.append(h('h4', { text: 'Prediction of the records not fitted on: predicted − measured rod force, mean / rms [N]' }),
      textTable('id-fric-validation-table', ['record', 'all', 'extend', 'retract', 'samples'],
        r.validation.map((v) => ({ dataset: { name: v.name }, cells: [v.name, d(v), d(v.extend), d(v.retract), String(v.n)] }))));
  }
}

/** Fig. 4: friction force against velocity, both directions (quadrants), one colour per
 * pressure level: the measured friction binned in velocity (markers), the law (lines). */
function plotFrictionMap(r) {
  // one level per record, named by its held gauge pressures (0.1 bar: a regulator's wander)
  const names = IDF.frictionNames || [];
  const bar = (p) => (Math.abs(p / BAR) < 0.05 ? '0.0' : (p / BAR).toFixed(1));
  const key = (m) => `${names[m.record] || `record ${m.record + 1}`}: ${bar(m.p_a)} / ${bar(m.p_b)}`;
  const levels = [...new Set(r.friction_map.map(key))];
  const vu = plotUnit('m/s'), fu = plotUnit('N');   // the header's unit switch (units.js)
  const traces = [];
  const seen = new Set();
  for (const m of r.friction_map) {
    const k = key(m);
    const color = LEVEL_COLORS[levels.indexOf(k) % LEVEL_COLORS.length];
    const first = !seen.has(k);
    seen.add(k);
    const v = vu.val(m.velocity);
    traces.push({ x: v, y: fu.val(m.measured), mode: 'markers', name: `${k} bar g, measured`, legendgroup: k, showlegend: first,
      marker: { color, size: 6 } });
    traces.push({ x: v, y: fu.val(m.model), mode: 'lines', name: `${k} bar g, law`, legendgroup: k, showlegend: first,
      line: { color, width: 1.5 } });
  }
  const layout = baseLayout({ height: 360, hovermode: 'closest' });
  layout.xaxis = axis(`velocity v [${vu.label}]`, { zeroline: true, zerolinecolor: '#9aa5b1' });
  layout.yaxis = axis(`friction force [${fu.label}]`, { zeroline: true, zerolinecolor: '#9aa5b1' });
  layout.annotations = [{ text: 'p_a / p_b gauge [bar]', xref: 'paper', yref: 'paper', x: 1, y: 0, xanchor: 'right', showarrow: false, font: { size: 10, color: '#8a94a0' } }];
  plot('id-fric-plot', traces, layout);
  document.getElementById('id-fric-plot').dataset.levels = String(levels.length);
}

/* ------------------------------------------------------------------ carrying into the model */
function carry(model, what) {
  S.model = clone(model);
  renderModel();
  if (typeof markStaleComparison === 'function') markStaleComparison();
  fillEdges();
  renderProvenance();
  setStatus(`${what} carried into the model; marked known (source: bench), held by later fits.`, 'ok');
}

function renderProvenance() {
  const box = document.getElementById('id-provenance');
  box.textContent = '';
  const prov = (S.model && S.model.provenance) || {};
  const rows = Object.entries(prov).map(([path, p]) => ({
    dataset: { path, source: String(p.source || '') },
    cells: [path, String(p.source || '–'), p.stderr == null ? '–'
      : `${num(p.stderr, 3)}${p.unit && p.unit !== '-' ? ' ' + prettyUnit(p.unit) : p.unit === '-' ? ' (relative)' : ''}`,
      String(p.method || ''), p.source === 'bench' ? 'yes (bench)' : 'no'],
  }));
  if (!rows.length) { box.append(h('p', { class: 'muted small', text: 'No value of this model has a recorded source yet.' })); return; }
  box.append(textTable('id-provenance-table', ['parameter', 'source', 'standard error', 'method', 'known in later fits'], rows));
}

/* ------------------------------------------------------------------ steps 3 and 4 */
async function validateOn(key, btn) {
  clearErrors();
  const ids = Array.from(document.getElementById(`id-${key}-select`).selectedOptions).map((o) => o.value);
  if (!ids.length) { fieldError(`identify.${key}`, 'choose at least one test'); setStatus('Choose a test first.', 'error'); return; }
  const sel = $('#dataset-select');
  for (const o of sel.options) o.selected = o.value.startsWith('ds:') && ids.includes(o.value.slice(3));
  onDatasetSelect();
  await busy(btn, async () => {
    const res = await runCompare();
    const out = document.getElementById(`id-${key}-result`);
    if (!res) { out.textContent = 'The comparison was refused: see the messages above.'; return; }
    const bench = Object.entries((S.model && S.model.provenance) || {}).filter(([, p]) => p.source === 'bench').map(([k]) => k);
    out.textContent = `Overall error ${pct(res.overall)} % (Eq. 25; per signal: `
      + Object.entries(res.errors).map(([s, v]) => `${s} ${pct(v)} %`).join(', ') + `); bench values in the model: `
      + (bench.length ? bench.join(', ') : 'none') + '.';
    out.dataset.overall = String(res.overall);
  });
}

/* ------------------------------------------------------------------ F and q in the comparison */
/** The rod force F [N] and the flows q_a, q_b, q_s [kg/s] of a comparison, where a record has
 * them (the two axes of panel 4's plot hold pressures and positions): one row per experiment,
 * force on the left, flows on the right; hidden when no experiment has one. */
const BENCH_SIGNALS = { F: { si: 'N', color: '#8c564b', left: true }, q_a: { si: 'kg/s', color: '#1f77b4' },
  q_b: { si: 'kg/s', color: '#d62728' }, q_s: { si: 'kg/s', color: '#2ca02c' } };
function plotCompareBench(c, exps) {
  const el = document.getElementById('compare-plot-bench');
  if (!el) return;
  const has = c.experiments.map((e) => Object.keys(e.simulated || {}).filter((s) => s in BENCH_SIGNALS));
  if (!has.some((l) => l.length)) { el.hidden = true; el.dataset.signals = ''; return; }
  el.hidden = false;
  const fu = plotUnit('N'), qu = plotUnit('kg/s');
  const { layout, rows } = stackedLayout(c.experiments.length, `rod force F [${fu.label}]`, `mass flow q [${qu.label}]`, c.experiments.map((e) => e.name));
  const traces = [];
  const seen = new Set();
  c.experiments.forEach((e, i) => {
    const meas = S.measured[exps[i] && exps[i].dataset_id] || {};
    for (const sig of has[i]) {
      const spec = BENCH_SIGNALS[sig];
      const u = spec.left ? fu : qu;
      const ax = spec.left ? rows[i].y : rows[i].y2;
      if (meas[sig]) {
        traces.push({ x: meas.t, y: u.val(meas[sig]), xaxis: rows[i].x, yaxis: ax, mode: 'markers', name: `${sig} measured`,
          legendgroup: `${sig}m`, showlegend: !seen.has(`${sig}m`) && !!seen.add(`${sig}m`), marker: { size: 3.5, color: spec.color, opacity: 0.35 } });
      }
      traces.push({ x: e.t, y: u.val(e.simulated[sig]), xaxis: rows[i].x, yaxis: ax, mode: 'lines', name: `${sig} simulated`,
        legendgroup: `${sig}s`, showlegend: !seen.has(`${sig}s`) && !!seen.add(`${sig}s`), line: { color: spec.color, width: 1.4 } });
    }
  });
  plot('compare-plot-bench', traces, layout);
  el.dataset.signals = [...new Set(has.flat())].join(',');
}

/* ------------------------------------------------------------------ wiring */
function initIdentify() {
  buildIdentifyPanel();
  document.getElementById('btn-id-valve').addEventListener('click', (ev) => identifyValve(ev.target));
  document.getElementById('btn-id-valve-use').addEventListener('click', () => IDF.valve && IDF.valve.model && carry(IDF.valve.model, `Edge ${IDF.valve.name}'s table`));
  document.getElementById('btn-id-friction').addEventListener('click', (ev) => identifyFriction(ev.target));
  document.getElementById('btn-id-fric-upload').addEventListener('click', (ev) => uploadFrictionRecords(ev.target));
  document.getElementById('btn-id-fric-rig').addEventListener('click', (ev) => readRigFiles(ev.target));
  document.getElementById('btn-id-friction-use').addEventListener('click', () => IDF.friction && carry(IDF.friction.model, 'The identified friction'));
  for (const key of ['locked', 'free']) document.getElementById(`btn-id-${key}`).addEventListener('click', (ev) => validateOn(key, ev.target));
  // the plots follow the header's unit switch (after units.js has taken the new system)
  document.getElementById('unit-system').addEventListener('change', () => setTimeout(() => {
    if (IDF.valve) renderValve();
    if (IDF.friction) plotFrictionMap(IDF.friction);
  }, 0));
  // the lists follow panel 4's datasets (an upload there adds a record here)
  new MutationObserver(fillDatasetLists).observe(document.getElementById('dataset-select'), { childList: true });
  const wait = setInterval(() => {
    if (!document.body.dataset.ready) return;
    clearInterval(wait);
    fillEdges();
    fillDatasetLists();
    renderProvenance();
    loadExtras().then(() => { document.getElementById('panel-identify').dataset.ready = 'true'; });
  }, 100);
}
if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', initIdentify); else initIdentify();
