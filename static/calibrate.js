'use strict';
/* Calibration panel: pick parameters, fit, read an lmfit-style report, apply.
 * The parameters, their units, current values and default bounds come from the service
 * (POST /api/calibrate/parameters): nothing is restated here. The fit is POST /api/calibrate
 * on the model of panel 1 and the datasets chosen in panel 4. Values are sent in SI (as the API) and shown in the
 * unit system of the header (static/units.js). */

const CAL = { options: [], result: null, checked: new Set(['jack.moving_mass']) };

/** The parameter paths declared known, in the calibration's field or the diagnosis's. */
function calKnown() {
  return new Set(['#cal-known', '#diag-known'].flatMap((id) => ($(id) ? $(id).value.split(/[\s,;]+/).filter(Boolean) : [])));
}

/** The fittable parameters follow the model as it is (issue 39: the panel showed the preset's
 * mass and supply until "Reload parameters"): reloaded shortly after every model change. */
let calReloadTimer = null;
function scheduleCalReload() {
  if (!$('#cal-params')) return;
  clearTimeout(calReloadTimer);
  calReloadTimer = setTimeout(() => loadCalOptions({ keepTyped: true }), 250);
}

/** ``opts.keepTyped``: bounds the user typed stay (a reload after a model change); "Reload
 * parameters" puts every field back to the service's. */
async function loadCalOptions(opts) {
  if (!S.model) return;
  // the answer for a model the user has since changed (a preset loaded, or a field edited in
  // place, while the request ran) is dropped: neither its parameters nor its error may
  // overwrite what the newer model shows (a 422 for a rod typed wider than the bore flagged
  // the field again after the user had corrected it)
  const sent = JSON.stringify(S.model);
  const current = () => JSON.stringify(S.model) === sent;
  try {
    const options = await api('POST', '/api/calibrate/parameters', { model: JSON.parse(sent) });
    if (!current()) return;
    CAL.options = options;
    renderCalOptions(!!(opts && opts.keepTyped === true));
  } catch (e) { if (current()) showApiError(e, 'Loading the fittable parameters'); }
}

function srLabel(control, text) {
  const lab = document.createElement('label');
  const span = document.createElement('span');
  span.className = 'sr-only';
  span.textContent = text;
  lab.append(span, control);
  return lab;
}

function calInput(path, key, value, u) {
  // shown in the page's unit system: display = (SI - offset) / scale (static/units.js)
  const inp = document.createElement('input');
  inp.type = 'number'; inp.step = 'any';
  inp.value = String(+((value - u.offset) / u.scale).toPrecision(8));
  inp.dataset.scale = String(u.scale); inp.dataset.offset = String(u.offset);
  inp.dataset.field = `parameters.${path}.${key}`;
  inp.dataset.path = path; inp.dataset.key = key;
  return inp;
}

function renderCalOptions(keepTyped = true) {
  const box = $('#cal-params');
  // bounds the user typed are kept across a reload (the start values follow the model)
  const typed = {};
  if (keepTyped) box.querySelectorAll('input[data-edited]').forEach((inp) => { if (inp.dataset.key !== 'value') typed[`${inp.dataset.path}|${inp.dataset.key}`] = inp.value; });
  const known = calKnown();
  box.textContent = '';
  const table = document.createElement('table');
  const head = table.insertRow();
  for (const h of ['fit', 'parameter', 'unit', 'start', 'min', 'max']) { const th = document.createElement('th'); th.textContent = h; head.appendChild(th); }
  for (const o of CAL.options) {
    const tr = table.insertRow();
    tr.dataset.path = o.path;
    const cb = document.createElement('input');
    // a value declared known is never ticked by default (the weighed mass was)
    if (known.has(o.path)) { CAL.checked.delete(o.path); tr.classList.add('known'); tr.title = 'declared known: not fitted unless ticked'; }
    cb.type = 'checkbox'; cb.checked = CAL.checked.has(o.path); cb.dataset.path = o.path;

    cb.addEventListener('change', () => { if (cb.checked) CAL.checked.add(o.path); else CAL.checked.delete(o.path); });
    tr.insertCell().appendChild(srLabel(cb, `Fit ${o.path} [-]`));
    const name = tr.insertCell(); name.textContent = o.path; name.title = o.label;
    const u = typeof unitShow === 'function' ? unitShow(o.unit) : { unit: o.unit, scale: 1, offset: 0 };
    const unit = prettyUnit(u.unit || '-');
    tr.insertCell().textContent = unit;
    for (const k of ['value', 'min', 'max']) {
      const td = tr.insertCell();
      const inp = calInput(o.path, k, o[k], u);
      if (typed[`${o.path}|${k}`] !== undefined) { inp.value = typed[`${o.path}|${k}`]; inp.dataset.edited = '1'; }
      inp.addEventListener('input', () => { inp.dataset.edited = '1'; });
      td.appendChild(srLabel(inp, `${k} of ${o.path} [${unit}]`));
      const err = document.createElement('span'); err.className = 'field-error'; err.setAttribute('role', 'alert'); td.appendChild(err);
    }
  }
  box.appendChild(table);
}

function calRequest() {
  const parameters = {};
  const errors = [];
  for (const path of CAL.checked) {
    const spec = {};
    for (const k of ['value', 'min', 'max']) {
      const inp = $(`#cal-params input[data-path="${CSS.escape(path)}"][data-key="${k}"]`);
      if (!inp) continue;
      const v = Number(inp.value);
      if (inp.value.trim() === '' || !Number.isFinite(v)) errors.push([`parameters.${path}.${k}`, 'must be a number', inp]);
      else spec[k] = +(v * Number(inp.dataset.scale)).toPrecision(12) + Number(inp.dataset.offset);
    }
    parameters[path] = spec;
  }
  return { parameters, errors };
}

async function runCalibration(btn) {
  clearErrors();
  const { parameters, errors } = calRequest();
  if (!S.experiments.length) errors.push(['experiments', 'select a dataset or a sample in panel 4 first', $('#dataset-select')]);
  if (!Object.keys(parameters).length) errors.push(['parameters', 'tick at least one parameter to fit', $('#cal-params')]);
  if (errors.length) {   // every error of the form at once
    for (const [f, m, el] of errors) fieldError(f, m, el);
    setStatus(`Fit refused: ${errors.length} error${errors.length === 1 ? '' : 's'}.`, 'error');
    return;
  }
  setStatus(`Fitting ${Object.keys(parameters).join(', ')}…`, 'busy');
  await busy(btn, async () => {
    try {
      const known = $('#cal-known').value.split(/[\s,;]+/).filter(Boolean);
      CAL.result = await api('POST', '/api/calibrate', { model: S.model, experiments: clone(S.experiments), parameters, max_nfev: 60, known });
      CAL.known = known;
      renderCalReport();
      $('#btn-cal-apply').disabled = false;
      $('#btn-cal-download').disabled = false;
      const r = CAL.result;
      // a fit whose values would raise the overall error keeps the model as given and says so
      setStatus(r.kept_start ? `Fit kept the model as given: ${r.message}.`
        : `Fit done: overall error ${pct(r.error_before.overall)} % → ${pct(r.error_after.overall)} %.`, r.kept_start ? 'error' : 'ok');
    } catch (e) {
      showApiError(e, 'Fit', (f) => (f.startsWith('experiments') ? 'experiments' : f.startsWith('known') ? 'calibrate.known' : f));
    }
  });
}

function cell(tr, text, cls) { const td = tr.insertCell(); td.textContent = text; if (cls) td.className = cls; return td; }

function renderCalReport() {
  const r = CAL.result;
  const box = $('#cal-report');
  box.textContent = '';
  if (!r) return;
  const h = document.createElement('h3'); h.textContent = '[[Fit statistics]]'; box.appendChild(h);
  const stats = document.createElement('table');
  for (const [k, v] of [['function evals', r.nfev], ['data points', r.n_data], ['variables', r.n_params],
    ['Akaike info crit (AIC)', `${num(r.aic_before, 6)} → ${num(r.aic, 6)}`],
    ['Bayesian info crit (BIC)', `${num(r.bic_before, 6)} → ${num(r.bic, 6)}`],
    ['overall error (Eq. 25)', `${pct(r.error_before.overall)} % → ${pct(r.error_after.overall)} %`],
    ['converged', `${r.success} (${r.message})`]]) {
    const tr = stats.insertRow(); cell(tr, k, 'l'); cell(tr, String(v));
  }
  box.appendChild(stats);
  const h2 = document.createElement('h3'); h2.textContent = '[[Variables]]'; box.appendChild(h2);
  const vt = document.createElement('table');
  vt.id = 'cal-values';
  const head = vt.insertRow();
  for (const t of ['parameter', 'value', '± stderr', 'relative', 'unit', 'initial', 'bounds']) { const th = document.createElement('th'); th.textContent = t; head.appendChild(th); }
  for (const [path, v] of Object.entries(r.values)) {
    const tr = vt.insertRow(); tr.dataset.path = path;
    // shown in the page's unit system (static/units.js); the relative error does not depend on it
    const u = typeof unitShow === 'function' ? unitShow(v.unit) : { unit: v.unit, scale: 1, offset: 0 };
    const d = (x) => (x - u.offset) / u.scale;
    cell(tr, path, 'l'); cell(tr, num(d(v.value), 6)); cell(tr, num(v.stderr / u.scale, 3));
    cell(tr, v.value ? `${num(100 * Math.abs(v.stderr / v.value), 3)} %` : '—');
    cell(tr, prettyUnit(u.unit || '-')); cell(tr, v.initial != null ? num(d(v.initial), 6) : '—');
    cell(tr, v.min != null ? `[${num(d(v.min), 4)}, ${num(d(v.max), 4)}]${v.at_bound ? ' (at a bound)' : ''}` : 'held');
  }
  box.appendChild(vt);
  // the known values: held where declared (or identified on a bench), and where the data disagree
  const held = document.createElement('p');
  held.id = 'cal-known-report';
  held.className = 'small';
  const known = (CAL.known || []).concat(r.bench_held || []);
  held.textContent = known.length ? `Held as known: ${known.join(', ')}${(r.bench_held || []).length ? ` (bench: ${r.bench_held.join(', ')})` : ''}.` : '';
  box.appendChild(held);
  for (const d of r.known_disagree || []) {
    const p = document.createElement('p');
    p.className = 'small warn';
    p.textContent = d.description || `the data disagree with the declared ${d.path}`;
    box.appendChild(p);
  }
  const paths = Object.keys(r.correlations || {});
  if (paths.length > 1) {
    const h3 = document.createElement('h3'); h3.textContent = '[[Correlations]]'; box.appendChild(h3);
    const ct = document.createElement('table');
    const hr = ct.insertRow(); cell(hr, '');
    for (const p of paths) cell(hr, p);
    for (const p of paths) {
      const tr = ct.insertRow(); cell(tr, p, 'l');
      for (const q of paths) { const c = r.correlations[p][q]; cell(tr, c == null ? '—' : num(c, 3)); }
    }
    box.appendChild(ct);
  }
}

async function applyCalibration(btn) {
  if (!CAL.result) return;
  S.model = clone(CAL.result.model);
  renderModel();
  setStatus('Fitted values applied to the model.', 'ok');
  await loadCalOptions();
  if (S.experiments.length) await runCompare({ keepErrors: true, noSession: true });
}

function wireCalibration() {
  $('#btn-cal-fit').addEventListener('click', (ev) => runCalibration(ev.target));
  $('#btn-cal-apply').addEventListener('click', (ev) => applyCalibration(ev.target));
  $('#btn-cal-refresh').addEventListener('click', loadCalOptions);
  for (const id of ['#cal-known', '#diag-known']) if ($(id)) $(id).addEventListener('change', () => { if (CAL.options.length) renderCalOptions(); });
  // the parameters follow the model: load them once the page has its model
  const wait = setInterval(() => {
    if (document.body.dataset.ready) { clearInterval(wait); loadCalOptions(); }
  }, 100);
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', wireCalibration); else wireCalibration();
