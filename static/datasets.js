/* pneucore page: the measurements (views "Data" and "Compare"): the dataset picker, the experiment set with its
 * per-experiment context, uploads, and the measured series fetched once per dataset.
 *
 * A classic script loaded before app.js (index.html); it only declares functions and constants,
 * so it uses app.js's S, api, plot, esc, ... helpers at call time. */
'use strict';

/* ------------------------------------------------------------------ measurement */
async function loadDatasets(selectValue) {
  S.datasets = await api('GET', '/api/datasets');
  const sel = $('#dataset-select');
  const groups = new Map();
  for (const d of S.datasets) {
    const g = d.sample || '';
    if (!groups.has(g)) groups.set(g, []);
    groups.get(g).push(d);
  }
  let html = '';
  for (const [g, list] of groups) {
    if (g) {
      html += `<optgroup label="sample: ${esc(g)} — ${esc(list[0].description || '')}">`;
      html += `<option value="sample:${esc(g)}">${esc(g)}: use the whole sample (${list.length} experiments)</option>`;
    } else html += '<optgroup label="uploaded">';
    for (const d of list) {
      html += `<option value="ds:${esc(d.id)}">${esc(d.name)} (${esc(d.signals.join(', '))}; ${d.scenario && d.scenario.locked ? 'locked' : 'free'})</option>`;
    }
    html += '</optgroup>';
  }
  sel.innerHTML = html;
  if (selectValue && [...sel.options].some((o) => o.value === selectValue)) sel.value = selectValue;
  onDatasetSelect();
}
/** The datasets of the picker's selected options, in order, each once: whole samples,
 * single datasets and the session's experiments may be combined (the method depends on
 * diagnosing a rig's tests together: a locked test identifies no friction and no mass). */
function selectedDatasets() {
  const out = [];
  const add = (d) => { if (d && !out.includes(d)) out.push(d); };
  for (const o of $('#dataset-select').selectedOptions) {
    const v = o.value || '';
    if (v.startsWith('sample:')) S.datasets.filter((d) => d.sample === v.slice(7)).forEach(add);
    else if (v.startsWith('ds:')) add(S.datasets.find((d) => d.id === v.slice(3)));
    else if (v === 'session' && S.session) S.session.experiments.forEach((e) => add(S.datasets.find((d) => d.id === e.dataset_id)));
  }
  return out;
}
function onDatasetSelect() {
  const list = selectedDatasets();
  // a session's experiments keep the context they were stored with (locked, x0, time offset)
  const kept = new Map((S.session ? S.session.experiments : []).concat(S.experiments || [])
    .filter((e) => e.dataset_id).map((e) => [e.dataset_id, e]));
  S.experiments = list.map((d) => {
    const k = kept.get(d.id);
    const e = { dataset_id: d.id };
    if (k && k.scenario) e.scenario = clone(k.scenario);
    if (k && k.time_offset != null) e.time_offset = k.time_offset;
    return e;
  });
  // a record without a command: the command proposed or entered (static/rigdata.js), plotted
  if (typeof showDatasetData === 'function') { applyCommands(); showDatasetData(list); }
  $('#dataset-info').innerHTML = list.map((d) => {
    const sc = d.scenario || {};
    return `<div><b>${esc(d.name)}</b>: ${d.n_samples} samples, signals ${esc(d.signals.join(', '))}, ` +
      `stored as ${sc.locked ? 'piston locked' : 'piston free'}${sc.x0 != null ? `, x0 = ${num(1e3 * sc.x0)} mm` : ''}</div>`;
  }).join('') + (list.length > 1 ? `<div>${list.length} experiments compared, calibrated and diagnosed together; each one's context below.</div>` : '') ||
    'No dataset selected.';
  renderExperimentSet(list);
  clearFieldError($('#dataset-select'));
}
/** One row per selected experiment: its own context (piston locked, x0 [mm], time offset [s]),
 * starting from what the dataset was stored with; an edit changes this request's scenario only. */
function renderExperimentSet(list) {
  if (!list.length) { $('#experiment-set').innerHTML = ''; return; }
  let h = '<table id="experiment-set-table" class="data"><thead><tr><th scope="col">experiment</th><th scope="col">samples</th>' +
    '<th scope="col">signals</th><th scope="col">locked</th><th scope="col">x0 [mm]</th><th scope="col">time offset [s]</th></tr></thead><tbody>';
  list.forEach((d, i) => {
    const e = S.experiments[i];
    const sc = e.scenario || d.scenario || {};
    h += `<tr data-index="${i}"><th scope="row">${esc(d.name)}</th><td class="num">${d.n_samples}</td><td>${esc(d.signals.join(', '))}</td>` +
      `<td><input type="checkbox" data-key="locked" aria-label="${esc(d.name)}: piston locked"${sc.locked ? ' checked' : ''}></td>` +
      `<td><input type="number" step="any" data-key="x0" aria-label="${esc(d.name)}: x0 [mm]" value="${sc.x0 != null ? num(1e3 * sc.x0) : ''}"></td>` +
      `<td><input type="number" step="any" data-key="time_offset" aria-label="${esc(d.name)}: time offset [s]" value="${e.time_offset != null ? num(e.time_offset) : ''}"></td></tr>`;
  });
  $('#experiment-set').innerHTML = h + '</tbody></table>';
  for (const input of $('#experiment-set').querySelectorAll('input')) {
    input.addEventListener('change', () => {
      const i = Number(input.closest('tr').dataset.index);
      const d = list[i], e = S.experiments[i];
      const sc = e.scenario || clone(d.scenario || {});
      if (input.dataset.key === 'locked') sc.locked = input.checked;
      else if (input.dataset.key === 'x0') sc.x0 = input.value === '' ? (d.scenario || {}).x0 : Number(input.value) / 1e3;
      else if (input.value === '') delete e.time_offset;
      else e.time_offset = Number(input.value);
      if (input.dataset.key !== 'time_offset') e.scenario = sc;
    });
  }
}
function selectExperiments(exps) {
  // choose the option of the dataset picker that matches a list of experiments
  const ids = exps.map((e) => e.dataset_id);
  const sel = $('#dataset-select');
  const bySample = new Map();
  for (const d of S.datasets) if (d.sample) { if (!bySample.has(d.sample)) bySample.set(d.sample, []); bySample.get(d.sample).push(d.id); }
  for (const [g, list] of bySample) if (JSON.stringify(list) === JSON.stringify(ids)) { sel.value = `sample:${g}`; onDatasetSelect(); return; }
  if (ids.length && ids.every((id) => S.datasets.some((d) => d.id === id))) {
    // several stored datasets: select each of them (the session's contexts are kept)
    for (const o of sel.options) o.selected = ids.includes(o.value.slice(3)) && o.value.startsWith('ds:');
    onDatasetSelect();
    return;
  }
  if (ids.length) {
    const opt = document.createElement('option');
    opt.value = 'session';
    opt.textContent = `session experiments (${ids.join(', ')})`;
    sel.prepend(opt);
    sel.value = 'session';
    onDatasetSelect();
  }
}
async function uploadDataset() {
  clearErrors();
  const file = $('#upload-file').files[0];
  if (!file) { fieldError('upload.file', 'choose a CSV file first'); setStatus('Upload: choose a CSV file first.', 'error'); return; }
  const fd = new FormData();
  fd.append('file', file);
  if ($('#upload-name').value.trim()) fd.append('name', $('#upload-name').value.trim());
  fd.append('locked', $('#upload-locked').checked ? 'true' : 'false');
  if ($('#upload-x0').value.trim() !== '') fd.append('x0', String(readInput($('#upload-x0'))));
  fd.append('ambient_pressure', String(pAtm()));   // the rig's ambient for gauge units (static/importer.js)
  const mapping = typeof importMapping === 'function' ? importMapping() : null;
  if (mapping) fd.append('columns', JSON.stringify(mapping));
  setStatus(`Uploading ${file.name}…`, 'busy');
  await busy($('#btn-upload'), async () => {
    try {
      const info = await api('POST', '/api/datasets', fd);
      await loadDatasets(`ds:${info.id}`);
      if (typeof showImportReport === 'function') showImportReport(info.import);
      const warn = info.import && info.import.warnings && info.import.warnings.length ? ` ${info.import.warnings.length} warning(s): see the import report.` : '';
      setStatus(`Dataset ${info.name} stored (${info.n_samples} samples, signals ${info.signals.join(', ')}).${warn}`, warn ? 'error' : 'ok');
    } catch (e) {
      showApiError(e, 'Upload', (field, err) => {
        if (field.startsWith('measurement.columns') || field === 'columns') return 'upload.columns';
        if (err.type === 'measurement_error' || field.startsWith('measurement') || field === 'file' || field === '') return 'upload.file';
        return `upload.${field}`;
      });
    }
  });
}
async function measured(id) {
  if (!S.measured[id]) S.measured[id] = (await api('GET', `/api/datasets/${encodeURIComponent(id)}`)).measurement;
  return S.measured[id];
}
/** An experiment as plain JSON with sorted keys and no null fields: what the server stores
 * (pydantic's exclude_none), so an edited command or context compares as a change. */
function canonicalJson(x) {
  if (Array.isArray(x)) return `[${x.map(canonicalJson).join(',')}]`;
  if (x && typeof x === 'object') {
    return `{${Object.keys(x).filter((k) => x[k] != null).sort().map((k) => `${JSON.stringify(k)}:${canonicalJson(x[k])}`).join(',')}}`;
  }
  return JSON.stringify(x);
}
/** The same experiments as they stand: the datasets and everything given with them (the
 * scenario and its command, loads, offsets), not the dataset ids alone (issue 39: a version
 * recorded after the command was edited was scored on the session's old command). */
function sameExperiments(a, b) {
  return canonicalJson(a || []) === canonicalJson(b || []);
}
