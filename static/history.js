/* pneucore page: the refinement session and its history (view "Diagnose & refine"): the stored session,
 * its versions, the diff between versions, resume and new session.
 *
 * A classic script loaded before app.js (index.html); it only declares functions and constants,
 * so it uses app.js's S, api, plot, esc, ... helpers at call time. */
'use strict';

/* ------------------------------------------------------------------ sessions and history */
async function ensureSession() {
  if (S.session && sameExperiments(S.session.experiments, S.experiments)) return S.session;
  if (S.session) {
    // the data changed: the same session goes on (a new one only from "New session"), with a
    // version of the current model on the new experiments; the history marks the change
    const names = S.experiments.map((e) => e.dataset_id || e.name || 'inline').join(', ');
    try {
      const s = await api('POST', `/api/sessions/${encodeURIComponent(S.session.id)}/versions`,
        { model: S.model, experiments: clone(S.experiments), note: `experiments changed to ${names}` });
      setSession(s);
      return s;
    } catch (e) {
      if (!(e instanceof ApiError && e.status === 404)) throw e;   // deleted meanwhile: start one
    }
  }
  const name = $('#dataset-select').selectedOptions[0] ? $('#dataset-select').selectedOptions[0].textContent.split(':')[0] : 'session';
  const s = await api('POST', '/api/sessions', { name, model: S.model, experiments: clone(S.experiments) });
  setSession(s);
  return s;
}
function setSession(s) {
  S.session = s;
  if (s) localStorage.setItem(SESSION_KEY, s.id); else localStorage.removeItem(SESSION_KEY);
  if (s) modelDraft.markClean(S.model);   // static/draft.js: the model just stored as a version
  renderHistory();
}
async function recordVersion(added, params) {
  await ensureSession();
  const s = await api('POST', `/api/sessions/${S.session.id}/versions`, { model: S.model, added: added || null, params: params || {} });
  setSession(s);
  return s;
}
/** Whether version `i` was compared on other experiments than version i - 1 (sessions stored
 * before versions recorded their experiments say nothing: null). */
function dataChangedAt(v, i) {
  if (i === 0 || !v[i].experiments || !v[i - 1].experiments) return false;
  return !sameExperiments(v[i].experiments, v[i - 1].experiments);
}
function renderHistory() {
  const s = S.session;
  if (!s) {
    $('#session-info').textContent = 'No session yet: the first comparison or diagnosis starts one.';
    plot('history-plot', [], baseLayout({ xaxis: axis('model version [-]'), yaxis: axis('overall error [%]'), annotations: emptyNote('No model version yet') }));
    $('#history-table').innerHTML = '';
    return;
  }
  $('#session-info').innerHTML = `Session <code id="session-id">${esc(s.id)}</code> “${esc(s.name)}”, ${s.versions.length} version(s), ` +
    `experiments: ${esc(s.experiments.map((e) => e.dataset_id || e.name || 'inline').join(', '))}`;
  const v = s.versions;
  plot('history-plot', [{
    x: v.map((q) => q.version), y: v.map((q) => (q.overall == null ? null : q.overall * 100)), mode: 'lines+markers+text', name: 'overall error',
    text: v.map((q) => (q.overall == null ? '' : `${pct(q.overall)} %`)), textposition: 'top right', line: { color: '#1f77b4', width: 2 }, marker: { size: 9 },
    customdata: v.map((q) => q.label), hovertemplate: '%{customdata}: %{y:.3f} %<extra></extra>',
  }], baseLayout({
    title: { text: 'Overall error per model version', font: { size: 12 }, x: 0.5, xanchor: 'center', y: 0.995 },
    xaxis: axis('model version [-]', { tickvals: v.map((q) => q.version), ticktext: v.map((q) => q.label), range: [-0.4, Math.max(v.length - 1, 1) + 0.6] }),
    yaxis: axis('overall error [%]', { range: [0, 1.22 * Math.max(1e-9, ...v.map((q) => (q.overall || 0) * 100))] }),
    showlegend: false, hovermode: 'closest', margin: { l: 64, r: 30, t: 40, b: 56 },
    // a dashed line where the experiments changed: errors either side are on other data
    shapes: v.map((q, i) => (dataChangedAt(v, i) ? { type: 'line', xref: 'x', yref: 'paper', x0: q.version - 0.5, x1: q.version - 0.5,
      y0: 0, y1: 1, line: { color: '#a35a00', width: 1.5, dash: 'dash' } } : null)).filter(Boolean),
  }));
  const sigs = [...new Set(v.flatMap((q) => Object.keys(q.errors || {})))];
  $('#history-table').innerHTML = '<table class="data"><thead><tr><th scope="col">version</th><th scope="col">change</th>' +
    sigs.map((q) => `<th scope="col">${esc(q)} [%]</th>`).join('') + '<th scope="col">overall [%]</th></tr></thead><tbody>' +
    v.map((q, i) => `<tr data-version="${q.version}"><td class="num">${q.version}${i > 0 && q.model && v[i - 1].model ? ` <button type="button" class="icon version-diff" data-index="${i}" title="What changed from version ${v[i - 1].version}">diff</button>` : ''}</td><td>${esc(q.label)}` +
      (dataChangedAt(v, i) ? ` <span class="badge data-changed" title="${esc(q.note || 'the experiments changed')}: the errors from here on are on other data">data changed</span>` : '') + `${q.params && Object.keys(q.params).length ? ` <span class="muted small">(${esc(Object.entries(q.params).map(([k, x]) => `${k} = ${num(typeof x === 'object' && x ? x.value : x)}`).join(', '))})</span>` : ''}</td>` +
      sigs.map((g) => `<td class="num">${pct(q.errors && q.errors[g])}</td>`).join('') + `<td class="num"><b>${pct(q.overall)}</b></td></tr>`).join('') +
    '</tbody></table>';
}
/** Open a stored session: its last version's model, its experiments (with their contexts)
 * and its history; it becomes the page's session (kept across reloads). */
async function openSession(id, verb = 'Opened') {
  const s = await api('GET', `/api/sessions/${encodeURIComponent(id)}`);
  const last = s.versions[s.versions.length - 1];
  S.session = s;
  localStorage.setItem(SESSION_KEY, s.id);
  if (last && last.model) { S.model = last.model; renderModel(); modelDraft.markClean(last.model); }
  selectExperiments(s.experiments);
  renderHistory();
  setStatus(`${verb} session ${s.id} “${s.name}” (${s.versions.length} version(s), last: ${last ? last.label : '?'}).`, 'ok');
  return s;
}
/** The changes from the previous version to this one (POST /api/models/diff), under the table. */
async function showVersionDiff(ev) {
  const btn = ev.target.closest('.version-diff');
  if (!btn || !S.session) return;
  const v = S.session.versions;
  const i = Number(btn.dataset.index);
  await busy(btn, async () => {
    try {
      const changes = await api('POST', '/api/models/diff', { before: v[i - 1].model, after: v[i].model });
      let box = $('#version-diff');
      if (!box) { box = document.createElement('div'); box.id = 'version-diff'; $('#history-table').after(box); }
      box.innerHTML = `<h3>Version ${v[i - 1].version} → ${v[i].version} (${esc(v[i].label)})</h3>` +
        (changes.length ? changesTable(changes, `${changes.length} value(s) changed`, true) : '<p class="muted small">The two models are the same.</p>');
    } catch (e) { showApiError(e, 'Comparing the versions'); }
  });
}
async function resumeSession() {
  const id = localStorage.getItem(SESSION_KEY);
  if (!id) { renderHistory(); return false; }
  try {
    await openSession(id, 'Resumed');
    return true;
  } catch (e) {
    localStorage.removeItem(SESSION_KEY);
    renderHistory();
    return false;
  }
}
async function newSession() {
  clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); setStatus('New session: no dataset selected.', 'error'); return; }
  await busy($('#btn-new-session'), async () => {
    try {
      S.session = null;
      await ensureSession();
      setStatus(`New session ${S.session.id} started with the current model as version 0.`, 'ok');
    } catch (e) { showApiError(e, 'New session', (f) => (f.startsWith('experiments') ? 'experiments' : f)); }
  });
}
async function recordCurrent() {
  clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); return; }
  await busy($('#btn-record-version'), async () => {
    try {
      const s = await recordVersion(null, {});
      const last = s.versions[s.versions.length - 1];
      setStatus(`Recorded ${last.label}: overall error ${pct(last.overall)} %.`, 'ok');
    } catch (e) { showApiError(e, 'Recording the version'); }
  });
}
