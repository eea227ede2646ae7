'use strict';
/* The upload's mapping step and import report (panel 4).
 * Choosing a file asks the service for a preview (POST /api/datasets/inspect): the detected
 * format and dialect, the columns with their units and a proposed mapping, shown as a table
 * of selects. The upload sends the mapping (`columns`) and the model's ambient pressure
 * (`ambient_pressure`, for gauge units), then shows the service's import report: every unit
 * conversion, every missing cell, every warning. Signal names and units come from the
 * service's preview, not from a copy here. User text is inserted with textContent / esc(). */

const IMPORT = { preview: null, file: null };

/** Fields of a sensor object (the service's SENSOR_FIELDS besides signal): label, input kind */
const SENSOR_INPUTS = [
  ['unit', 'unit of gain × raw + offset (bar, mm; empty = the file\'s) [-]', 'text'],
  ['gain', 'gain: unit per raw unit (1 bar/V) [unit/raw]', 'number'],
  ['offset', 'offset, in unit (the sensor\'s zero) [unit]', 'number'],
  ['reference', 'pressures: gauge or absolute [-]', 'select'],
  ['raw_unit', 'what the column holds (V, mA) [-]', 'text'],
];

function importMapping() {
  if (!IMPORT.preview) return null;
  const out = {};
  for (const sel of $$('#upload-mapping select[data-column]')) {
    const col = sel.dataset.column;
    out[col] = sel.value || null;
    if (!sel.value) continue;
    // a sensor: unit, gain, offset, gauge or absolute, raw unit (volts to bar or mm)
    const sensor = {};
    for (const el of $$('#upload-mapping [data-sensor-for]')) {
      if (el.dataset.sensorFor !== col || el.value.trim() === '') continue;
      sensor[el.dataset.key] = el.type === 'number' ? Number(el.value) : el.value.trim();
    }
    if (Object.keys(sensor).length) out[col] = Object.assign({ signal: sel.value }, sensor);
  }
  return out;
}

function renderMapping() {
  const box = $('#upload-mapping');
  box.textContent = '';
  const pv = IMPORT.preview;
  if (!pv) return;
  const info = document.createElement('p');
  info.className = 'muted small';
  const bits = [`format ${pv.format}`];
  if (pv.encoding) bits.push(`encoding ${pv.encoding}`);
  if (pv.delimiter) bits.push(`delimiter ${pv.delimiter === '\t' ? 'tab' : `“${pv.delimiter}”`}`);
  if (pv.decimal) bits.push(`decimal mark “${pv.decimal}”`);
  if (pv.units_row) bits.push('units row found');
  info.textContent = `Detected: ${bits.join(', ')}. Map each column to a signal (or ignore it):`;
  box.appendChild(info);
  const table = document.createElement('table');
  table.className = 'mapping';
  const head = table.insertRow();
  for (const h of ['column', 'unit in file', 'signal (SI unit)', 'unit', 'gain [unit/raw]', 'offset [unit]', 'gauge / absolute', 'raw unit', 'first values']) {
    const th = document.createElement('th'); th.textContent = h; head.appendChild(th);
  }
  pv.columns.forEach((c, j) => {
    const tr = table.insertRow();
    tr.insertCell().textContent = c.name;
    tr.insertCell().textContent = c.unit || '—';
    const sel = document.createElement('select');
    sel.dataset.column = c.name;
    const lab = document.createElement('label');
    const txt = document.createElement('span');
    txt.className = 'sr-only';
    txt.textContent = `Signal for column ${c.name} [-]`;
    lab.append(txt, sel);
    const none = document.createElement('option');
    none.value = ''; none.textContent = '(ignore)';
    sel.appendChild(none);
    for (const [sig, spec] of Object.entries(pv.signals)) {
      const o = document.createElement('option');
      o.value = sig; o.textContent = `${sig} [${spec.unit}]`;
      o.title = `accepted units: ${spec.accepted_units.join(', ')}`;
      sel.appendChild(o);
    }
    sel.value = c.signal || '';
    tr.insertCell().appendChild(lab);
    for (const [key, title, kind] of SENSOR_INPUTS) {
      let el;
      if (kind === 'select') {
        el = document.createElement('select');
        for (const [v, t] of [['', '(as the unit says)'], ['gauge', 'gauge'], ['absolute', 'absolute']]) {
          const o = document.createElement('option'); o.value = v; o.textContent = t; el.appendChild(o);
        }
      } else {
        el = document.createElement('input');
        el.type = kind;
        if (kind === 'number') el.step = 'any';
        el.size = 6;
      }
      el.dataset.sensorFor = c.name;
      el.dataset.key = key;
      el.title = title;
      const l = document.createElement('label');
      const t = document.createElement('span');
      t.className = 'sr-only';
      t.textContent = `${key} of column ${c.name}: ${title}`;
      l.append(t, el);
      tr.insertCell().appendChild(l);
    }
    tr.insertCell().textContent = pv.rows.slice(0, 3).map((r) => r[j]).join(', ');
  });
  box.appendChild(table);
}

async function inspectUpload() {
  const file = $('#upload-file').files[0];
  IMPORT.preview = null;
  $('#upload-report').textContent = '';
  renderMapping();
  if (!file) return;
  const fd = new FormData();
  fd.append('file', file);
  try {
    IMPORT.preview = await api('POST', '/api/datasets/inspect', fd);
    renderMapping();
  } catch (e) {
    showApiError(e, 'Reading the file', () => 'upload.file');
  }
}

function showImportReport(rep) {
  const box = $('#upload-report');
  box.textContent = '';
  if (!rep) return;
  const add = (tag, text, cls) => { const el = document.createElement(tag); el.textContent = text; if (cls) el.className = cls; box.appendChild(el); return el; };
  add('b', 'How the file was read');
  const ul = add('ul', '');
  for (const c of rep.conversions || []) {
    const li = document.createElement('li');
    li.textContent = `${c.column} → ${c.signal}: ` +
      (c.gain != null ? `${c.gain} ${c.from} per ${c.raw_unit || 'raw unit'}, offset ${c.offset} ${c.from}, ` : '') +
      `${c.from} → ${c.to}` +
      (c.ambient_pressure != null ? ` (gauge: + ambient ${c.ambient_pressure} Pa)` : '') +
      (c.how !== 'name' ? ` [${c.how}]` : '');
    ul.appendChild(li);
  }
  if ((rep.ignored_columns || []).length) add('div', `Ignored columns: ${rep.ignored_columns.join(', ')}`, 'muted');
  for (const m of rep.missing_cells || []) {
    add('div', `Missing cells in ${m.column}: ${m.count} (rows ${m.rows.map(([a, b]) => (a === b ? `${a}` : `${a}-${b}`)).join(', ')})`, 'muted');
  }
  for (const w of rep.warnings || []) add('div', `Warning: ${w}`, 'warning');
}

function wireImporter() {
  $('#upload-file').addEventListener('change', inspectUpload);
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', wireImporter); else wireImporter();
