/* pneucore page: the robustness study (view "Studies"): the parameter rows, POST /api/studies, its
 * progress, the stored studies, and the histogram, scatter, ranking and table of results.
 *
 * A classic script loaded before app.js (index.html); it only declares functions and constants,
 * so it uses app.js's S, api, plot, esc, ... helpers at call time. */
'use strict';

/* ------------------------------------------------------------------ robustness study */
// Paths offered in the parameter picker (any other model path can be typed; see pneucore.description.paths).
const STUDY_PATHS = [
  ['friction.extend.fc0', 'Coulomb force, extension'],
  ['friction.retract.fc0', 'Coulomb force, retraction'],
  ['friction.extend.kv0', 'viscous coefficient, extension'],
  ['supply.pressure', 'supply pressure (abs)'],
  ['jack.moving_mass', 'moving mass'],
  ['jack.load_force', 'load force'],
  ['heat.coefficient', 'convection coefficient h'],
  ['jack.dead_volume_a', 'dead volume A'],
  ['valve.ports.*.C', 'conductance C of every edge (scale)'],
];
const STUDY_CUSTOM = '__custom__';
const STUDY_KINDS = [['grid', 'grid (full factorial)'], ['uniform', 'uniform'], ['normal', 'normal'], ['lognormal', 'lognormal']];
// kind -> [key, label, required, unit override]; the API's field names (parameters.<path>.<key>)
const STUDY_FIELDS = {
  grid: [['grid', 'values', true]],
  uniform: [['min', 'min', true], ['max', 'max', true]],
  normal: [['mean', 'mean', true], ['std', 'std', true], ['min', 'min', false], ['max', 'max', false]],
  lognormal: [['median', 'median', true], ['sigma', 'sigma of ln x', true, '-'], ['min', 'min', false], ['max', 'max', false]],
};
const METHOD_NAMES = {
  prcc: 'partial rank correlation (PRCC) with Spearman',
  factorial_variance: 'variance decomposition of the full factorial (S_i, S_Ti)',
};
const DESIGN_NAMES = { monte_carlo: 'Monte Carlo', factorial: 'full factorial', mixed: 'grid × Monte Carlo' };

/** Value of `path` in the current model (1 for valve scale factors), or null. */
function studyNominal(path) {
  if (!S.model || !path) return null;
  const parts = path.split('.');
  if (parts[0] === 'valve') return 1;
  if (parts[0] === 'effects' && parts.length === 3) {
    const have = S.model.effects && S.model.effects[parts[1]];
    if (have && typeof have[parts[2]] === 'number') return have[parts[2]];
    const e = catalog(parts[1]);
    const p = e && e.parameters.find((q) => q.name === parts[2]);
    return p ? p.default : null;
  }
  let v = getPath(S.model, parts);
  if (v == null && parts[0] === 'friction' && parts[1] === 'retract') v = getPath(S.model, ['friction', 'extend', parts[2]]);
  return typeof v === 'number' ? v : null;
}
function studyPathOptions() {
  const opts = STUDY_PATHS.slice();
  for (const [name, params] of Object.entries((S.model && S.model.effects) || {})) {
    for (const p of Object.keys(params)) opts.push([`effects.${name}.${p}`, `${name}: ${p}`]);
  }
  return opts;
}
/** Starting values of a row from the parameter's value in the current model (±20 %, 5 % std). */
function studyDefaults(path, kind) {
  const v = studyNominal(path);
  if (v == null) return {};
  const r = (x) => String(+x.toPrecision(6));
  const a = Math.abs(v) || 1;
  if (kind === 'grid') return { grid: [v - 0.2 * a, v, v + 0.2 * a].map(r).join(', ') };
  if (kind === 'uniform') return { min: r(v - 0.2 * a), max: r(v + 0.2 * a) };
  if (kind === 'normal') return { mean: r(v), std: r(0.05 * a) };
  return { median: r(v > 0 ? v : 1), sigma: '0.1' };
}
function nominalText(path) {
  if (String(path).startsWith('valve.')) return 'scale factor on the table: 1 = as given';
  const v = studyNominal(path);
  return v == null ? (path ? 'not in the current model' : '') : `current model: ${+v.toPrecision(6)} ${prettyUnit(paramUnit(path))}`;
}

function addStudyRow(path, kind = 'uniform', values) {
  const used = new Set(S.study.rows.map((r) => r.path));
  if (typeof path !== 'string') path = (STUDY_PATHS.find(([p]) => !used.has(p)) || STUDY_PATHS[0])[0];
  S.study.rows.push({ path, custom: !studyPathOptions().some(([p]) => p === path), kind, f: values || studyDefaults(path, kind) });
  renderStudyRows();
}
function renderStudyRows() {
  const box = $('#study-param-rows');
  box.innerHTML = S.study.rows.length ? S.study.rows.map(studyRowHtml).join('')
    : '<p class="muted small">No parameter yet: add one.</p>';
  updateRunCount();
}
/** How the row's values are shown: the chosen unit system's {unit, scale, offset} for the path's
 * SI unit (a std is a difference: scale only, no offset). The rows keep SI. */
function studyShown(path) {
  const si = paramUnit(path);
  const d = si && typeof unitShow === 'function' ? unitShow(si) : { unit: si || 'SI unit', scale: 1, offset: 0 };
  return { label: prettyUnit(d.unit) || 'SI unit', scale: d.scale || 1, offset: d.offset || 0 };
}
function studyValueShown(v, d, key) {
  if (v == null || String(v).trim() === '') return '';
  const off = key === 'std' ? 0 : d.offset;
  const one = (x) => { const n = Number(x); return Number.isFinite(n) && String(x).trim() !== '' ? String(+((n - off) / d.scale).toPrecision(10)) : String(x).trim(); };
  return key === 'grid' ? String(v).split(',').map(one).join(', ') : one(v);
}
function studyValueSI(text, d, key) {
  const off = key === 'std' ? 0 : d.offset;
  const one = (x) => { const n = Number(x); return Number.isFinite(n) && String(x).trim() !== '' ? String(+(n * d.scale + off).toPrecision(12)) : String(x).trim(); };
  return key === 'grid' ? String(text).split(',').map(one).join(', ') : one(text);
}
function studyRowHtml(r, i) {
  const opts = studyPathOptions();
  const custom = r.custom || !opts.some(([p]) => p === r.path);
  const shown = studyShown(r.path);
  const unit = shown.label;
  const id = (k) => `sp-${i}-${k}`;
  const pathSel = opts.map(([p, d]) => `<option value="${esc(p)}"${!custom && p === r.path ? ' selected' : ''}>${esc(p)} — ${esc(d)}</option>`).join('') +
    `<option value="${STUDY_CUSTOM}"${custom ? ' selected' : ''}>other path (type it)…</option>`;
  const kindSel = STUDY_KINDS.map(([k, d]) => `<option value="${k}"${k === r.kind ? ' selected' : ''}>${esc(d)}</option>`).join('');
  const fields = STUDY_FIELDS[r.kind].map(([k, label, req, u]) => {
    const grid = k === 'grid';
    // a std is a difference: its unit without abs/g (static/units.js)
    const lu = u || (k === 'std' ? unit.replace(/ (abs|g)$/, '') : unit);
    return `<div class="field${grid ? ' sp-wide' : ''}"><label for="${id(k)}">${esc(label)} [${esc(lu)}]` +
      `${grid ? ', comma-separated' : ''}${req ? '' : ' <span class="muted">(optional)</span>'}</label>` +
      `<input id="${id(k)}" type="${grid ? 'text' : 'number'}" step="any" data-key="${k}" data-field="parameters.${esc(r.path)}.${k}"` +
      ` value="${esc(u ? (r.f[k] ?? '') : studyValueShown(r.f[k], shown, k))}"${req ? '' : ' placeholder="none"'}${grid ? ' spellcheck="false"' : ''}><span class="field-error" role="alert"></span></div>`;
  }).join('');
  return `<div class="study-param field" id="study-param-${i}" data-row="${i}" data-field="parameters.${esc(r.path)}">` +
    '<div class="sp-head">' +
    `<span class="sp-num" title="parameter ${i + 1}">${i + 1}</span>` +
    `<div class="field"><label for="${id('path')}">Parameter path [-]</label><select id="${id('path')}" class="sp-path">${pathSel}</select>` +
    (custom ? `<label class="sr-only" for="${id('custom')}">Custom parameter path [-]</label>` +
      `<input id="${id('custom')}" class="sp-custom" type="text" value="${esc(r.path)}" placeholder="e.g. jack.bore or effects.piston_leakage.conductance" spellcheck="false">` : '') +
    '</div>' +
    `<div class="field"><label for="${id('kind')}">Kind [-]</label><select id="${id('kind')}" class="sp-kind" data-field="parameters.${esc(r.path)}.distribution">${kindSel}</select></div>` +
    `<button type="button" class="icon sp-remove" id="${id('remove')}" aria-label="Remove parameter ${i + 1}" title="Remove this parameter">×</button>` +
    '</div>' +
    `<div class="sp-values">${fields}</div>` +
    `<div class="sp-nominal muted">${esc(nominalText(r.path))}</div>` +
    '<span class="field-error" role="alert"></span></div>';
}
/** The path changed while typing: move the row's data-field attributes along (errors must find them). */
function retargetStudyRow(i) {
  const row = $(`#study-param-${i}`);
  const path = S.study.rows[i].path;
  row.dataset.field = `parameters.${path}`;
  $$('[data-key]', row).forEach((el) => { el.dataset.field = `parameters.${path}.${el.dataset.key}`; });
  $('.sp-kind', row).dataset.field = `parameters.${path}.distribution`;
}
function refreshStudyHints() {
  // the picker lists the current model's effects: redraw the rows when they changed
  const key = studyPathOptions().map(([p]) => p).join('|');
  if (S.study.optionsKey !== undefined && key !== S.study.optionsKey) { S.study.optionsKey = key; renderStudyRows(); return; }
  S.study.optionsKey = key;
  S.study.rows.forEach((r, i) => {
    const el = $(`#study-param-${i} .sp-nominal`);
    if (el) el.textContent = nominalText(r.path);
  });
}
function studyRowOf(el) {
  const row = el.closest('.study-param');
  return row ? Number(row.dataset.row) : -1;
}
function onStudyRowChange(ev) {
  const el = ev.target;
  const i = studyRowOf(el);
  if (i < 0) return;
  const r = S.study.rows[i];
  if (el.classList.contains('sp-path')) {
    if (el.value === STUDY_CUSTOM) {
      r.custom = true;
      renderStudyRows();
      $(`#sp-${i}-custom`).focus();
      return;
    }
    r.custom = false;
    r.path = el.value;
    r.f = studyDefaults(r.path, r.kind);
    renderStudyRows();
  } else if (el.classList.contains('sp-custom')) {
    r.path = el.value.trim();
    const filled = STUDY_FIELDS[r.kind].some(([k]) => String(r.f[k] ?? '').trim() !== '');
    if (!filled) r.f = studyDefaults(r.path, r.kind);
    renderStudyRows();
  } else if (el.classList.contains('sp-kind')) {
    r.kind = el.value;
    const d = studyDefaults(r.path, r.kind);
    for (const [k, , req] of STUDY_FIELDS[r.kind]) if (req && String(r.f[k] ?? '').trim() === '' && d[k] != null) r.f[k] = d[k];
    renderStudyRows();
  }
}
function onStudyRowInput(ev) {
  const el = ev.target;
  const i = studyRowOf(el);
  if (i < 0) return;
  const r = S.study.rows[i];
  if (el.classList.contains('sp-custom')) { r.path = el.value.trim(); retargetStudyRow(i); return; }
  if (el.dataset.key) {
    const k = el.dataset.key;
    const raw = (STUDY_FIELDS[r.kind].find((f) => f[0] === k) || [])[3];   // a unit override: as typed
    r.f[k] = raw ? el.value : studyValueSI(el.value, studyShown(r.path), k);
    clearFieldError(el);
    const slot = $(':scope > .field-error', el.closest('.study-param'));
    if (slot) { slot.textContent = ''; slot.removeAttribute('data-error-for'); }
    updateRunCount();
  }
}
function onStudyRowClick(ev) {
  const btn = ev.target.closest('.sp-remove');
  if (!btn) return;
  S.study.rows.splice(studyRowOf(btn), 1);
  renderStudyRows();
}
function parseGrid(text) {
  const toks = String(text || '').split(/[\s,;]+/).filter(Boolean);
  if (!toks.length) return { error: 'give at least one value' };
  const bad = toks.find((t) => !Number.isFinite(Number(t)));
  if (bad !== undefined) return { error: `"${bad}" is not a number` };
  return { values: toks.map(Number) };
}
function updateRunCount() {
  const rows = S.study.rows;
  let grid = 1;
  for (const r of rows.filter((q) => q.kind === 'grid')) { const g = parseGrid(r.f.grid); grid *= g.values ? g.values.length : NaN; }
  const random = rows.some((r) => r.kind !== 'grid');
  const samples = Number($('#study-samples').value);
  const n = random ? grid * samples : grid;
  $('#study-nruns').textContent = !rows.length ? '' : !Number.isFinite(n) ? '' :
    random ? `${grid > 1 ? `${grid} grid points × ` : ''}${samples} samples = ${n} runs` : `${n} runs (full factorial; samples not used)`;
}
function numOrRaw(text) {
  const raw = String(text ?? '').trim();
  if (raw === '') return null;
  const v = Number(raw);
  return Number.isFinite(v) ? v : raw;   // the API names a non-number next to its field
}
/** The POST /api/studies body, or null (errors shown next to the rows) when the form is incomplete. */
function studyRequest(scenario) {
  let bad = 0;
  const parameters = {};
  const seen = new Map();
  if (!S.study.rows.length) { fieldError('parameters', 'add at least one parameter to vary'); bad++; }
  S.study.rows.forEach((r, i) => {
    const row = $(`#study-param-${i}`);
    const path = (r.path || '').trim();
    if (!path) { fieldError(`parameters (row ${i + 1})`, 'type a parameter path', row); bad++; return; }
    if (seen.has(path)) {
      fieldError(`parameters.${path}`, `${path} is already varied by parameter ${seen.get(path) + 1}`, row); bad++; return;
    }
    seen.set(path, i);
    if (r.kind === 'grid') {
      const g = parseGrid(r.f.grid);
      if (g.error) { fieldError(`parameters.${path}.grid`, g.error, $(`#sp-${i}-grid`)); bad++; return; }
      parameters[path] = { grid: g.values };
      return;
    }
    const spec = { distribution: r.kind };
    for (const [k, , req] of STUDY_FIELDS[r.kind]) {
      const v = numOrRaw(r.f[k]);
      if (v !== null || req) spec[k] = v;   // a missing required value: the API says so next to it
    }
    parameters[path] = spec;
  });
  if (bad) { setStatus(`Study: ${bad} problem${bad > 1 ? 's' : ''} in the parameter table.`, 'error'); return null; }
  const random = S.study.rows.some((r) => r.kind !== 'grid');
  const body = { model: S.model, scenario, parameters, samples: random ? numOrRaw($('#study-samples').value) : null };
  const seed = numOrRaw($('#study-seed').value);
  if (seed !== null) body.seed = seed;
  body.scheduler = $('#study-scheduler').value.trim() || null;
  return body;
}
function setStudyProgress(stored, n, step) {
  const prog = $('#study-progress');
  prog.max = Math.max(n || 0, 1);
  prog.value = Math.min(stored || 0, prog.max);
  $('#study-progress-text').textContent = `${stored || 0}/${n || 0}`;
  if (step != null) $('#study-step').textContent = step;
}
async function runStudy() {
  clearErrors();
  const scenario = scenarioForRequest();
  if (!scenario) return;
  const body = studyRequest(scenario);
  if (!body) return;
  await busy($('#btn-study-run'), async () => {
    try {
      delete $('#study-progress').dataset.done;
      setStudyProgress(0, 0, 'submitting');
      setStatus('Starting the study…', 'busy');
      const r = await api('POST', '/api/studies', body);
      setStatus(`Study ${r.id}: ${r.n_runs} runs on ${body.scheduler ? `cluster “${body.scheduler}”` : 'the default cluster'}…`, 'busy');
      loadStudies();
      await followStudy(r.id, r.job_id, r.n_runs);
    } catch (e) {
      $('#study-step').textContent = 'refused';
      showApiError(e, 'Study');
    }
  });
}
/** Poll GET /api/studies/{id} every 300 ms until its job ends, then show the results. */
async function followStudy(id, jobId, nRuns) {
  const token = ++S.study.poll;
  S.study.following = id;
  try {
    return await pollStudy(id, jobId, nRuns, token);
  } finally {
    if (token === S.study.poll) S.study.following = null;
  }
}
async function pollStudy(id, jobId, nRuns, token) {
  const prog = $('#study-progress');
  delete prog.dataset.done;
  prog.dataset.study = id;
  setStudyProgress(0, nRuns || 0, 'queued');
  const stopped = () => token !== S.study.poll;
  for (;;) {
    if (stopped()) return false;
    let st;
    try {
      st = await api('GET', `/api/studies/${encodeURIComponent(id)}`);
    } catch (e) {
      // a service that writes the study row only when its job starts: meanwhile ask the job
      if (!(e instanceof ApiError && e.status === 404 && jobId)) throw e;
      const j = await api('GET', `/api/jobs/${encodeURIComponent(jobId)}`);
      if (stopped()) return false;
      if (j.status === 'error') { studyFailed(id, j.error); return false; }
      if (j.status === 'done') throw e;   // finished, yet no study: it was deleted
      setStudyProgress(0, nRuns || 0, `${j.status}: ${j.step}`);
      await sleep(300);
      continue;
    }
    if (stopped()) return false;
    const job = st.job;
    setStudyProgress(st.stored, st.n_runs, job ? `${job.step}` : st.status);
    if (job && (job.status === 'queued' || job.status === 'running')) {
      setStatus(`Study ${id} ${job.status}: ${st.stored}/${st.n_runs} runs stored${st.failed ? `, ${st.failed} failed` : ''}.`, 'busy');
      await sleep(300);
      continue;
    }
    if (job && job.status === 'error') { studyFailed(id, job.error, st); return false; }
    if (st.status !== 'done') {
      $('#study-step').textContent = st.status;
      setStatus(`Study ${id} is ${st.status} (${st.stored}/${st.n_runs} runs stored) and no job of this server runs it: ` +
        'resume it from the list of stored studies.', 'error');
      loadStudies();
      return false;
    }
    break;
  }
  prog.dataset.done = 'true';
  $('#study-step').textContent = `study ${id} done`;
  await loadStudyResults(id);
  if (stopped()) return false;
  await loadStudies();
  const r = S.study.res;
  setStatus(`Study ${id} done: ${r.stored}/${r.n_runs} runs stored, ${r.failed} failed.`, r.failed ? 'info' : 'ok');
  return true;
}
function studyFailed(id, error, st) {
  $('#study-step').textContent = `stopped: ${error || 'error'}`;
  setStatus(`Study ${id} stopped${st ? ` after ${st.stored}/${st.n_runs} runs` : ''}: ${error || 'error'}. ` +
    'The stored runs are kept; Resume it from the list of stored studies.', 'error');
  loadStudies();
}
async function loadStudies() {
  try {
    S.study.list = await api('GET', '/api/studies');
  } catch (e) {
    $('#study-list').innerHTML = `<p class="field-error">Could not list the studies: ${esc(e.message)}</p>`;
    return;
  }
  renderStudyList();
}
function renderStudyList() {
  const list = S.study.list.slice().sort((a, b) => b.created - a.created);
  const shown = S.study.res && S.study.res.id;
  if (!list.length) { $('#study-list').innerHTML = '<p class="muted small">No stored study yet.</p>'; return; }
  $('#study-list').innerHTML = '<table class="data" id="study-list-data"><thead><tr><th scope="col">study</th><th scope="col">created</th>' +
    '<th scope="col">status</th><th scope="col">runs stored [-]</th><th scope="col">failed [-]</th><th scope="col"></th></tr></thead><tbody>' +
    list.map((s) => {
      const sid = esc(s.id);
      const when = new Date(s.created * 1000);
      const actions = [
        `<button type="button" class="icon study-load" data-id="${sid}" id="study-load-${sid}"${s.stored ? '' : ' disabled'}` +
          ` title="Show the results of the stored runs">Load results</button>`,
        s.status === 'interrupted' ? `<button type="button" class="icon study-resume" data-id="${sid}" id="study-resume-${sid}"` +
          ' title="Compute the missing runs (stored runs are kept)">Resume</button>' : '',
        s.status === 'running' || s.status === 'queued' ? `<button type="button" class="icon study-follow" data-id="${sid}" id="study-follow-${sid}"` +
          ' title="Follow its progress">Follow</button>' : '',
      ].join(' ');
      return `<tr id="study-row-${sid}" data-status="${esc(s.status)}"${s.id === shown ? ' class="selected"' : ''}>` +
        `<td><code>${sid}</code>${s.name ? ` ${esc(s.name)}` : ''}</td>` +
        `<td class="small">${esc(when.toLocaleDateString())} ${esc(when.toLocaleTimeString())}</td>` +
        `<td><span class="st st-${esc(s.status)}">${esc(s.status)}</span></td>` +
        `<td class="num">${s.stored}/${s.n_runs}</td><td class="num">${s.failed}</td><td class="nowrap">${actions}</td></tr>`;
    }).join('') + '</tbody></table>';
}
async function onStudyListClick(ev) {
  const btn = ev.target.closest('button');
  if (!btn || !btn.dataset.id) return;
  const id = btn.dataset.id;
  clearErrors();
  setStatus(`Study ${id}: ${btn.textContent.toLowerCase()}…`, 'busy');
  await busy(btn, async () => {
    try {
      if (btn.classList.contains('study-load')) {
        await loadStudyResults(id);
        const r = S.study.res;
        fillStudyForm(r.definition);
        if (!S.study.following) {   // the bar shows the study on screen unless another one is running
          setStudyProgress(r.stored, r.n_runs, `study ${id} loaded (${r.status})`);
          $('#study-progress').dataset.study = id;
        }
        setStatus(`Study ${id} loaded: ${r.stored}/${r.n_runs} runs stored, ${r.failed} failed (status ${r.status}).`, 'ok');
        renderStudyList();
      } else if (btn.classList.contains('study-resume')) {
        let r;
        try {
          r = await api('POST', `/api/studies/${encodeURIComponent(id)}/resume`);
        } catch (e) {
          if (!(e instanceof ApiError && e.status === 409)) throw e;
          await followStudy(id);   // already queued or running: follow it instead
          return;
        }
        setStatus(`Study ${id} resumed: computing the missing runs…`, 'busy');
        loadStudies();
        await followStudy(id, r.job_id);
      } else if (btn.classList.contains('study-follow')) {
        await followStudy(id);
      }
    } catch (e) { showApiError(e, `Study ${id}`); }
  });
}
/** The share of the runs whose selected metric meets "at most / at least" a value typed in the
 * metric's shown unit (the page's unit system); runs that leave the metric undefined count
 * as not meeting it. */
function renderStudyRequirement() {
  const res = S.study.res;
  const out = $('#study-req-share');
  if (!out) return;
  const m = S.study.metric;
  const info = res && res.metrics[m];
  const lab = $('#study-req-value-label');
  const d = info && typeof unitShow === 'function' ? unitShow(info.unit) : { unit: info ? info.unit : '-', scale: 1, offset: 0 };
  if (lab) lab.textContent = `${m || 'metric'} value [${prettyUnitText(d.unit || '-')}]`;
  const raw = $('#study-req-value').value.trim();
  if (!info || raw === '' || !Number.isFinite(Number(raw))) { out.textContent = info ? `Type a value of ${m} to count the runs meeting it.` : ''; delete out.dataset.share; return; }
  const lim = Number(raw) * (d.scale || 1) + (d.offset || 0);
  const le = $('#study-req-op').value === 'le';
  const vals = res.runs.metrics[m] || [];
  const ok = vals.filter((v) => v != null && (le ? v <= lim : v >= lim)).length;
  const share = vals.length ? ok / vals.length : 0;
  out.dataset.share = String(share);
  out.textContent = `${ok} of ${vals.length} runs (${num(100 * share, 3)} %) have ${m} ${le ? '≤' : '≥'} ${raw} ${prettyUnitText(d.unit || '')}` +
    `${vals.some((v) => v == null) ? '; a run leaving it undefined does not meet it' : ''}.`;
}
/** A stored study's definition back into the form: its parameters, samples and seed. */
function fillStudyForm(def) {
  if (!def || !def.parameters) return;
  S.study.rows = Object.entries(def.parameters).map(([path, spec]) => {
    const kind = spec.grid ? 'grid' : (spec.distribution || 'uniform');
    const f = {};
    if (spec.grid) f.grid = spec.grid.join(', ');
    else for (const [k] of STUDY_FIELDS[kind] || []) if (spec[k] != null) f[k] = String(spec[k]);
    return { path, custom: !studyPathOptions().some(([p]) => p === path), kind, f };
  });
  if (def.samples != null) $('#study-samples').value = String(def.samples);
  if (def.seed != null) $('#study-seed').value = String(def.seed);
  renderStudyRows();
}
async function loadStudyResults(id) {
  const res = await api('GET', `/api/studies/${encodeURIComponent(id)}/results`);
  S.study.res = res;
  const names = Object.keys(res.metrics);
  if (!names.includes(S.study.metric) || !res.metrics[S.study.metric].count) {
    // t95 first; a metric no run defines (t95 of a locked piston) gives way to one that varies
    const varies = (k) => res.metrics[k].count > 0 && res.metrics[k].std > 0;
    S.study.metric = [S.study.metric, 't95'].find((k) => names.includes(k) && varies(k)) ||
      names.find(varies) || names.find((k) => res.metrics[k].count > 0) || names[0];
  }
  const paths = res.parameters.map((p) => p.path);
  if (!paths.includes(S.study.param)) {
    const rk = res.sensitivity.ranking[S.study.metric];
    S.study.param = rk && rk.entries.length ? rk.entries[0].parameter : paths[0];
  }
  renderStudyResults();
  return res;
}
/** A typed-in value written back compactly: 600000 -> 6e5, 0.25 -> 0.25. */
function short(v) {
  if (typeof v !== 'number') return String(v);
  const t = +v.toPrecision(4);
  const a = Math.abs(t);
  return a !== 0 && (a >= 1e5 || a < 1e-3) ? t.toExponential().replace('e+', 'e') : String(t);
}
/** specText in the chosen unit system (a std or a lognormal sigma: scale only / none). */
function specTextShown(spec, unit) {
  const d = metricDisplay(unit);
  if (d.label === (unit || '-')) return specText(spec, unit);
  const s = {};
  for (const [k, v] of Object.entries(spec)) {
    if (typeof v !== 'number' && !Array.isArray(v)) { s[k] = v; continue; }
    if (k === 'sigma') s[k] = v;
    else if (k === 'std') s[k] = d.diff(v);
    else s[k] = Array.isArray(v) ? v.map((x) => d.val(x)) : d.val(v);
  }
  return specText(s, null) + ` ${d.label}`;
}
function specText(spec, unit) {
  const num = short;   // the summary echoes the definition as typed
  const u = unit && unit !== '-' ? ` ${prettyUnit(unit)}` : '';
  const b = (s) => (s.min != null || s.max != null ? ` in [${s.min != null ? num(s.min) : '−∞'}, ${s.max != null ? num(s.max) : '∞'}]${u}` : '');
  if (spec.grid) return `grid {${spec.grid.map((v) => num(v)).join(', ')}}${u}`;
  if (spec.distribution === 'uniform') return `uniform [${num(spec.min)}, ${num(spec.max)}]${u}`;
  if (spec.distribution === 'normal') return `normal (mean ${num(spec.mean)}, std ${num(spec.std)})${u}${b(spec)}`;
  if (spec.distribution === 'lognormal') return `lognormal (median ${num(spec.median)}${u}, sigma of ln x ${num(spec.sigma)})${b(spec)}`;
  return JSON.stringify(spec);
}
function renderStudyResults() {
  const res = S.study.res;
  if (!res) return;
  const def = res.definition || {};
  const m = def.model || {};
  const sc = def.scenario || {};
  $('#study-results').dataset.studyId = res.id;
  $('#study-title').innerHTML = `Results of study <code id="study-id">${esc(res.id)}</code>${res.name ? ` “${esc(res.name)}”` : ''}`;
  $('#study-summary').innerHTML = `${esc(DESIGN_NAMES[res.design] || res.design)}: <b>${res.stored}/${res.n_runs}</b> runs stored, ` +
    `<b>${res.failed}</b> failed, status ${esc(res.status)}${res.missing ? ` (${res.missing} missing: resume it)` : ''}. ` +
    `Model <i>${esc(m.name || 'custom')}${Object.keys(m.effects || {}).length ? ` + ${esc(Object.keys(m.effects).join(' + '))}` : ''}</i>, scenario <i>${esc(sc.name || 'custom')}</i> (${num(sc.duration)} s), seed ${esc(def.seed ?? 0)}. ` +
    'Parameters: ' + res.parameters.map((p) => `<code>${esc(p.path)}</code> ${esc(specTextShown(p.spec, p.unit))}`).join('; ') + '.' +
    ` <a id="study-csv" href="${esc(`/api/studies/${encodeURIComponent(res.id)}/runs.csv`)}" download>Download the runs (CSV, units in the headers)</a>` +
    ` · <a id="study-npz" href="${esc(`/api/studies/${encodeURIComponent(res.id)}/runs.npz`)}" download title="NumPy archive: params and metrics matrices with their names and units; numpy.load reads it">(.npz)</a>`;
  $('#study-metric').innerHTML = Object.entries(res.metrics).map(([k, d]) =>
    `<option value="${esc(k)}"${k === S.study.metric ? ' selected' : ''}>${esc(k)} [${esc(metricDisplay(d.unit).label)}]</option>`).join('');
  $('#study-xparam').innerHTML = res.parameters.map((p) =>
    `<option value="${esc(p.path)}"${p.path === S.study.param ? ' selected' : ''}>${esc(p.path)} [${esc(metricDisplay(p.unit).label)}]</option>`).join('');
  $('#study-metric').disabled = false;
  $('#study-xparam').disabled = false;
  renderStudyTable();
  renderStudyMetric();
  const errs = res.errors || [];
  $('#study-errors').innerHTML = errs.length ? `<h3>Failed runs (${res.failed})</h3><ul class="study-errlist">` +
    errs.map((e) => `<li><b>${e.count}×</b> ${esc(e.message)} <span class="muted small">(runs ${esc(e.runs.join(', '))}${e.count > e.runs.length ? ', …' : ''})</span></li>`).join('') + '</ul>' : '';
}
function renderStudyMetric() {
  const res = S.study.res;
  const d = res.metrics[S.study.metric];
  renderStudyRequirement();
  $('#study-metric-def').innerHTML = d ? `<b>${esc(S.study.metric)}</b>: ${esc(d.definition)} (SI unit ${esc(d.unit)})` : '';
  $$('#study-table-data tbody tr').forEach((tr) => tr.classList.toggle('selected', tr.dataset.metric === S.study.metric));
  plotStudyHist();
  plotStudyScatter();
  renderStudyRanking();
}
function plotEmptyStudy() {
  plot('study-hist', [], baseLayout({ height: 320, xaxis: axis('metric [unit]'), yaxis: axis('runs [-]'), annotations: emptyNote('Run a study or load a stored one') }));
  plot('study-scatter', [], baseLayout({ height: 320, xaxis: axis('parameter [unit]'), yaxis: axis('metric [unit]'), annotations: emptyNote('Metric against a varied parameter') }));
}
function plotStudyHist() {
  const res = S.study.res;
  const m = S.study.metric;
  const info = res.metrics[m];
  const dsp = metricDisplay(info.unit);
  const vals = res.runs.metrics[m].filter((v) => v != null).map(dsp.val);
  const title = `${m} [${dsp.label}]`;
  const lost = [info.failed ? `${info.failed} failed` : '', info.undefined ? `${info.undefined} undefined` : ''].filter(Boolean).join(', ');
  const shapes = [];
  const annotations = [];
  if (vals.length) {
    [['5', '5 %'], ['50', 'median'], ['95', '95 %']].forEach(([q, label]) => {
      const x = info.percentiles[q];
      if (x == null) return;
      shapes.push({ type: 'line', xref: 'x', yref: 'paper', x0: dsp.val(x), x1: dsp.val(x), y0: 0, y1: 1, line: { color: q === '50' ? '#d62728' : '#ff7f0e', width: 1.4, dash: q === '50' ? 'solid' : 'dash' } });
      annotations.push({ text: label, x: dsp.val(x), xref: 'x', y: 1, yref: 'paper', yanchor: 'bottom', showarrow: false, font: { size: 10, color: '#a35a00' } });
    });
  } else annotations.push(...emptyNote(`No run defines ${m}`));
  plot('study-hist', vals.length ? [{
    type: 'histogram', x: vals, name: m, nbinsx: Math.max(6, Math.min(40, Math.round(2 * Math.sqrt(vals.length)))),
    marker: { color: '#1f77b4', line: { color: '#fff', width: 1 } }, hovertemplate: `${esc(m)} %{x}<br>%{y} runs<extra></extra>`,
  }] : [], baseLayout({
    height: 320, title: { text: `Distribution of ${m}: n = ${vals.length} of ${res.stored} runs${lost ? ` (${lost})` : ''}`, font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.98 },
    xaxis: axis(title), yaxis: axis('runs [-]'), bargap: 0.04, showlegend: false, hovermode: 'closest', shapes, annotations,
    margin: { l: 64, r: 24, t: 52, b: 50 },
  }));
  $('#study-hist').dataset.count = String(vals.length);
}
function plotStudyScatter() {
  const res = S.study.res;
  const m = S.study.metric;
  const p = res.parameters.find((q) => q.path === S.study.param) || res.parameters[0];
  const dsp = metricDisplay(res.metrics[m].unit);
  const xs = res.runs.params[p.path];
  const ys = res.runs.metrics[m];
  const x = [], y = [], idx = [];
  const pd = metricDisplay(p.unit);
  ys.forEach((v, k) => { if (v != null && xs[k] != null) { x.push(pd.val(xs[k])); y.push(dsp.val(v)); idx.push(res.runs.index[k]); } });
  const e = ((res.sensitivity.ranking[m] || {}).entries || []).find((q) => q.parameter === p.path);
  const corr = e && e.prcc != null ? `: PRCC ${num(e.prcc, 3)}, Spearman ${num(e.spearman, 3)}` : '';
  const pu = pd.label;
  plot('study-scatter', x.length ? [{
    type: 'scatter', mode: 'markers', x, y, customdata: idx, name: m,
    marker: { size: 7, color: '#2ca02c', opacity: 0.75, line: { color: '#1b6e1b', width: 0.5 } },
    hovertemplate: `run %{customdata}<br>${esc(p.path)} = %{x} ${esc(pu)}<br>${esc(m)} = %{y} ${esc(dsp.label)}<extra></extra>`,
  }] : [], baseLayout({
    height: 320, title: { text: `${m} against ${p.path}${corr}`, font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.98 },
    xaxis: axis(`${p.path} [${pu}]`), yaxis: axis(`${m} [${dsp.label}]`), showlegend: false, hovermode: 'closest',
    margin: { l: 64, r: 24, t: 52, b: 50 }, annotations: x.length ? [] : emptyNote(`No run defines ${m}`),
  }));
}
function renderStudyRanking() {
  const res = S.study.res;
  const m = S.study.metric;
  const rk = res.sensitivity.ranking[m];
  if (!rk) { $('#study-ranking').innerHTML = '<p class="muted small">No ranking for this metric.</p>'; return; }
  const anova = rk.method === 'factorial_variance';
  const units = Object.fromEntries(res.parameters.map((p) => [p.path, metricDisplay(p.unit).label]));
  const bar = (v) => (v == null ? '' : `<span class="sbar-wrap" aria-hidden="true"><span class="sbar ${v < 0 ? 'neg' : 'pos'}" style="${v < 0
    ? `right:50%;width:${(50 * Math.min(1, -v)).toFixed(1)}%` : `left:50%;width:${(50 * Math.min(1, v)).toFixed(1)}%`}"></span></span>`);
  const sbar = (v) => (v == null ? '' : `<span class="sbar-wrap" aria-hidden="true"><span class="sbar tot" style="left:0;width:${(100 * Math.max(0, Math.min(1, v))).toFixed(1)}%"></span></span>`);
  const undefinedNote = rk.entries.every((e) => e.prcc == null && e.spearman == null)
    ? `<p class="muted small">${esc(m)} does not vary (or too few runs define it): no correlation can be computed.</p>` : '';
  $('#study-ranking').innerHTML =
    `<p class="study-method" id="study-method" data-method="${esc(rk.method)}">Which parameters move <b>${esc(m)}</b>? ` +
    `<b>Method: ${esc(METHOD_NAMES[rk.method] || rk.method)}</b>, over n = ${rk.n} runs. ${esc(res.sensitivity.methods[rk.method] || '')}</p>${undefinedNote}` +
    '<table class="data" id="study-ranking-data"><thead><tr><th scope="col">rank</th><th scope="col">parameter</th>' +
    (anova ? '<th scope="col">total index S_Ti [-]</th><th scope="col">first order S_i [-]</th>' : '') +
    '<th scope="col">PRCC [-]</th><th scope="col">p-value</th><th scope="col">Spearman ρ [-]</th><th scope="col">p-value</th></tr></thead><tbody>' +
    rk.entries.map((e) => `<tr data-parameter="${esc(e.parameter)}"${e.parameter === S.study.param ? ' class="selected"' : ''} title="Plot ${esc(m)} against ${esc(e.parameter)}">` +
      `<td class="num">${e.rank}</td><th scope="row">${esc(e.parameter)} <span class="muted small">[${esc(units[e.parameter] || '-')}]</span></th>` +
      (anova ? `<td class="num">${sbar(e.total)} ${num(e.total, 3)}</td><td class="num">${num(e.first_order, 3)}</td>` : '') +
      `<td class="num">${anova ? '' : bar(e.prcc)} ${num(e.prcc, 3)}</td><td class="num">${pval(e.prcc_p)}</td>` +
      `<td class="num">${num(e.spearman, 3)}</td><td class="num">${pval(e.spearman_p)}</td></tr>`).join('') +
    '</tbody></table>';
}
function renderStudyTable() {
  const res = S.study.res;
  const qs = ['5', '25', '50', '75', '95'];
  $('#study-table').innerHTML = '<table class="data" id="study-table-data"><thead><tr><th scope="col">metric</th><th scope="col">unit</th>' +
    '<th scope="col">mean</th><th scope="col">std</th><th scope="col">min</th>' + qs.map((q) => `<th scope="col">${q} %</th>`).join('') +
    '<th scope="col">max</th><th scope="col">runs [-]</th></tr></thead><tbody>' +
    Object.entries(res.metrics).map(([k, d]) => {
      const dsp = metricDisplay(d.unit);
      const v = (x) => (x == null ? '–' : num(dsp.val(x)));
      const lost = [d.failed ? `${d.failed} failed` : '', d.undefined ? `${d.undefined} undefined` : ''].filter(Boolean).join(', ');
      return `<tr data-metric="${esc(k)}"${k === S.study.metric ? ' class="selected"' : ''} title="${esc(d.definition)}">` +
        `<th scope="row">${esc(k)}</th><td class="unit">${esc(dsp.label)}</td>` +
        `<td class="num">${v(d.mean)}</td><td class="num">${d.std == null ? '–' : num(dsp.diff(d.std))}</td><td class="num">${v(d.min)}</td>` +
        qs.map((q) => `<td class="num">${v(d.percentiles[q])}</td>`).join('') +
        `<td class="num">${v(d.max)}</td><td class="num"${lost ? ` title="${esc(lost)}"` : ''}>${d.count}${lost ? '*' : ''}</td></tr>`;
    }).join('') + '</tbody></table>';
}
function selectStudyMetric(name) {
  if (!S.study.res || !(name in S.study.res.metrics)) return;
  S.study.metric = name;
  $('#study-metric').value = name;
  renderStudyMetric();
}
function selectStudyParam(path) {
  if (!S.study.res || !S.study.res.parameters.some((p) => p.path === path)) return;
  S.study.param = path;
  $('#study-xparam').value = path;
  plotStudyScatter();
  $$('#study-ranking-data tbody tr').forEach((tr) => tr.classList.toggle('selected', tr.dataset.parameter === path));
}
function wireStudy() {
  $('#btn-study-add').addEventListener('click', () => addStudyRow());
  for (const id of ['#study-req-op', '#study-req-value']) {
    const el = $(id);
    if (el) { el.addEventListener('input', renderStudyRequirement); el.addEventListener('change', renderStudyRequirement); }
  }
  const rows = $('#study-param-rows');
  rows.addEventListener('change', onStudyRowChange);
  rows.addEventListener('input', onStudyRowInput);
  rows.addEventListener('click', onStudyRowClick);
  for (const id of ['#study-samples', '#study-seed', '#study-scheduler']) {
    $(id).addEventListener('input', (ev) => { clearFieldError(ev.target); updateRunCount(); });
  }
  $('#btn-study-run').addEventListener('click', runStudy);
  $('#btn-study-refresh').addEventListener('click', loadStudies);
  $('#study-list').addEventListener('click', onStudyListClick);
  $('#study-metric').addEventListener('change', (ev) => selectStudyMetric(ev.target.value));
  $('#study-xparam').addEventListener('change', (ev) => selectStudyParam(ev.target.value));
  $('#study-table').addEventListener('click', (ev) => { const tr = ev.target.closest('tr[data-metric]'); if (tr) selectStudyMetric(tr.dataset.metric); });
  $('#study-ranking').addEventListener('click', (ev) => { const tr = ev.target.closest('tr[data-parameter]'); if (tr) selectStudyParam(tr.dataset.parameter); });
}
function initStudyForm() {
  // a small Monte Carlo on friction and supply pressure to start from
  addStudyRow('friction.extend.fc0', 'uniform');
  addStudyRow('supply.pressure', 'normal');
}
