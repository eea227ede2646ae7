'use strict';
/* Downloads: simulation and comparison as CSV (the API's Accept: text/csv answer, units in
 * the header; uploads read it back), the simulation as a NumPy .npz archive (Accept:
 * application/x-npz), HTML reports of a comparison, a diagnosis or the whole session (one
 * self-contained file), the fitted model as JSON. */

function saveBlob(blob, filename) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = filename;
  document.body.appendChild(a);
  a.click();
  setTimeout(() => { URL.revokeObjectURL(a.href); a.remove(); }, 1000);
}

async function download(path, body, accept, filename, what) {
  clearErrors();
  setStatus(`${what}…`, 'busy');
  const r = await fetch(path, { method: 'POST', headers: { 'content-type': 'application/json', accept }, body: JSON.stringify(body) });
  if (!r.ok) {
    const text = await r.text();
    let data; try { data = JSON.parse(text); } catch (e) { data = { detail: text }; }
    throw new ApiError(r.status, data.detail);
  }
  saveBlob(await r.blob(), filename);
  setStatus(`${what}: saved ${filename}.`, 'ok');
}

function needExperiments() {
  if (S.experiments.length) return true;
  fieldError('experiments', 'select a dataset or a sample first', $('#dataset-select'));
  setStatus('No dataset selected.', 'error');
  return false;
}

function wireExports() {
  $('#btn-sim-csv').addEventListener('click', (ev) => busy(ev.target, async () => {
    try { await download('/api/simulate', { model: S.model, scenario: scenarioForRequest() }, 'text/csv', 'simulation.csv', 'Simulation CSV'); } catch (e) { showApiError(e, 'Simulation CSV'); }
  }));
  $('#btn-sim-npz').addEventListener('click', (ev) => busy(ev.target, async () => {
    try { await download('/api/simulate', { model: S.model, scenario: scenarioForRequest() }, 'application/x-npz', 'simulation.npz', 'Simulation .npz'); } catch (e) { showApiError(e, 'Simulation .npz'); }
  }));
  $('#btn-compare-csv').addEventListener('click', (ev) => busy(ev.target, async () => {
    if (!needExperiments()) return;
    try { await download('/api/compare', { model: S.model, experiments: clone(S.experiments) }, 'text/csv', 'comparison.csv', 'Comparison CSV'); } catch (e) { showApiError(e, 'Comparison CSV'); }
  }));
  $('#btn-compare-report').addEventListener('click', (ev) => busy(ev.target, async () => {
    // the comparison on screen (its model and experiments, even when the model changed since:
    // the same numbers, the comparison being deterministic); the current ones when none is shown
    const shown = S.compare && S.compare.model ? { model: JSON.parse(S.compare.model), experiments: clone(S.compare.experiments) } : null;
    if (!shown && !needExperiments()) return;
    const body = shown || { model: S.model, experiments: clone(S.experiments) };
    try { await download('/api/reports/compare', body, 'text/html', 'comparison-report.html', 'Comparison report'); } catch (e) { showApiError(e, 'Comparison report'); }
  }));
  $('#btn-diag-report').addEventListener('click', (ev) => busy(ev.target, async () => {
    if (!needExperiments()) return;
    // the diagnosis on screen is exported as it is; a new one runs only when none is shown
    const shown = S.diag && sameExperiments(S.diag.experiments, S.experiments) ? S.diag : null;
    const body = shown ? { model: shown.model || S.model, experiments: clone(shown.experiments), diagnosis: shown.result }
      : { model: S.model, experiments: clone(S.experiments), known: typeof knownPaths === 'function' ? knownPaths() : [] };
    try { await download('/api/reports/diagnose', body, 'text/html', 'diagnosis-report.html', 'Diagnosis report'); } catch (e) { showApiError(e, 'Diagnosis report'); }
  }));
  $('#btn-session-report').addEventListener('click', (ev) => busy(ev.target, async () => {
    // the refinement as recorded: every version of the session on screen (not a new refinement)
    if (!S.session) { setStatus('Session report: no session yet (the first comparison or diagnosis starts one).', 'error'); return; }
    try {
      await download(`/api/reports/sessions/${encodeURIComponent(S.session.id)}`, {}, 'text/html', 'session-report.html', 'Session report');
    } catch (e) { showApiError(e, 'Session report'); }
  }));
  $('#btn-cal-download').addEventListener('click', () => {
    if (typeof CAL === 'undefined' || !CAL.result) return;
    saveBlob(new Blob([JSON.stringify(CAL.result.model, null, 1)], { type: 'application/json' }), 'fitted-model.json');
    setStatus('Fitted model saved as fitted-model.json (load it with POST /api/simulate or the CLI --model).', 'ok');
  });
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', wireExports); else wireExports();
