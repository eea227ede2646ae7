/* pneucore page: the diagnosis (view "Diagnose & refine"): the diagnosis job, its candidate cards,
 * the parameter changes a candidate makes and adopting one.
 *
 * A classic script loaded before app.js (index.html); it only declares functions and constants,
 * so it uses app.js's S, api, plot, esc, ... helpers at call time. */
'use strict';

/* ------------------------------------------------------------------ diagnosis */
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function runDiagnosis() {
  clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); setStatus('Diagnosis: no dataset selected.', 'error'); return; }
  const prog = $('#diag-progress');
  await busy($('#btn-diagnose'), async () => {
    try {
      prog.value = 0;
      prog.removeAttribute('data-done');
      $('#diag-step').textContent = 'submitting';
      setStatus('Diagnosis running…', 'busy');
      // the residual plot and the error tables show what the diagnosis starts from
      if (!S.compare || !sameExperiments(S.compare.experiments, S.experiments)) {
        if (!(await runCompare({ keepErrors: true }))) return;
      }
      await ensureSession();
      setStatus('Diagnosis running…', 'busy');
      $('#diag-step').textContent = 'submitting';
      const exps = clone(S.experiments);
      const known = typeof knownPaths === 'function' ? knownPaths() : [];
      const job = await api('POST', '/api/jobs/diagnose', { model: S.model, experiments: exps, known });
      let j = job;
      while (j.status === 'queued' || j.status === 'running') {
        prog.value = j.progress || 0;
        $('#diag-step').textContent = `${j.step} (${Math.round((j.progress || 0) * 100)} %)`;
        await sleep(300);
        j = await api('GET', `/api/jobs/${j.id}`);
      }
      if (j.status !== 'done') {
        $('#diag-step').textContent = `failed: ${j.error || j.status}`;
        setStatus(`Diagnosis failed: ${j.error || j.status}`, 'error');
        return;
      }
      prog.value = 1;
      prog.dataset.done = 'true';
      $('#diag-step').textContent = 'done (100 %)';
      S.diag = { result: j.result, experiments: exps, model: clone(S.model) };
      renderDiagnosis();
      setStatus(`Diagnosis done: ${j.result.message}`, 'ok');
    } catch (e) {
      $('#diag-step').textContent = 'refused';
      showApiError(e, 'Diagnosis', (f) => (f.startsWith('experiments') ? 'experiments' : f));
    }
  });
}
function renderDiagnosis() {
  const d = S.diag.result;
  const before = d.error_before ? d.error_before.overall : null;
  const verdict = d.verdict ? esc(d.verdict) : 'none (no catalog effect explains the residual)';
  $('#diag-verdict').innerHTML = `<div class="verdict-name">Verdict: <b id="diag-verdict-name">${verdict}</b></div><div>${esc(d.message)}</div>` +
    `<div class="muted small">Error before: ${pct(before)} % · noise floor ${pct(d.remaining && d.remaining.noise_floor != null ? d.remaining.noise_floor : floorOf(d.noise_floor))} %</div>` +
    `<div class="small" id="diag-error-explained">${esc(explainErrorBefore(d))}</div>`;
  $('#diag-residual-summary').textContent = d.residual_tests && d.residual_tests.summary ? `Residual tests: ${d.residual_tests.summary}` : '';
  const score = d.score_pass || [];
  $('#diag-score').innerHTML = score.length ? '<h3>Score test of every candidate (before refitting)</h3>' +
    '<table class="data"><thead><tr><th scope="col">rank</th><th scope="col">effect</th><th scope="col">LM statistic [-]</th>' +
    '<th scope="col">dof [-]</th><th scope="col">p-value [-]</th></tr></thead><tbody>' +
    score.map((q) => `<tr><td class="num">${q.rank ?? ''}</td><td>${esc(q.effect)}</td>` + (q.skipped
      ? `<td colspan="3" class="muted small">skipped: ${esc(q.skipped)}</td></tr>`
      : `<td class="num">${num(q.lm)}</td><td class="num">${q.dof ?? ''}</td><td class="num">${pval(q.p_value)}</td></tr>`)).join('') +
    '</tbody></table>' : '';
  const cards = $('#diag-cards');
  cards.innerHTML = '';
  (d.ranking || []).forEach((r, i) => {
    const card = document.createElement('article');
    card.className = `card${r.effect === d.verdict ? ' top' : ''}`;
    card.id = `card-${r.effect}`;
    card.dataset.effect = r.effect;
    // the server's badges (pneucore/analysis/shown.py), each checked against the figures on
    // this card: no "significant" beside a p-value above the level, none beside a rising error
    const badges = (r.badges || []).map((b) => `<span class="badge${b.kind === 'warning' ? ' badge-warn' : ''}" data-badge="${esc(b.name)}" title="${esc(b.why || '')}">${esc(b.name)}</span>`).join(' ');
    const params = Object.entries(r.params || {}).map(([k, p]) => {
      // shown in the page's unit system (static/units.js)
      const u = typeof unitShow === 'function' ? unitShow(p.unit) : { unit: p.unit, scale: 1, offset: 0 };
      const v = (x) => (typeof x === 'number' ? (x - u.offset) / u.scale : x);
      // a parameter of the effect's smaller form, held off (not fitted: a stand-in, r.stand_in)
      if (p.held) return `<tr><th scope="row">${esc(k)}</th><td class="num">${num(v(p.value))} ${esc(prettyUnit(u.unit || ''))} (held off)</td><td class="num">–</td><td></td></tr>`;
      return `<tr><th scope="row">${esc(k)}</th><td class="num">${num(v(p.value))} ± ${num(p.stderr / u.scale, 2)} ${esc(prettyUnit(u.unit || ''))}</td>` +
        `<td class="num">${p.ci95 ? `[${num(v(p.ci95[0]))}, ${num(v(p.ci95[1]))}]` : '–'}</td>${p.at_bound ? '<td class="warn">at bound</td>' : '<td></td>'}</tr>`;
    }).join('');
    card.innerHTML = `<header><span class="rank">#${i + 1}</span> <b>${esc(r.effect)}</b> ${badges}</header>` +
      `<p class="small muted">${esc(r.description || '')}</p>` +
      '<dl class="evidence">' +
      `<dt>Overall error</dt><dd><span class="err-before">${pct(r.error_before != null ? r.error_before : before)} %</span> → <b class="err-after">${pct(r.error_after_overall)} %</b></dd>` +
      `<dt>ΔBIC</dt><dd>${num(r.delta_bic, 4)}</dd><dt>p-value (LR test)</dt><dd>${pval(r.p_value)}</dd>` +
      (r.effective_samples != null && r.n_samples ? `<dt title="Samples counted by the LR test and BIC: each residual series weighs n / tau, tau its integrated autocorrelation time (coloured noise carries less information than white)">effective samples</dt>` +
        `<dd class="eff-samples">${Math.round(r.effective_samples)} of ${r.n_samples}</dd>` : '') + '</dl>' +
      (params ? `<table class="data params"><thead><tr><th scope="col">parameter</th><th scope="col">value ± std. error</th><th scope="col">95 % CI</th><th></th></tr></thead><tbody>${params}</tbody></table>` : '') +
      `<p class="explanation">${esc(r.explanation || '')}</p>` + changesTable(r.changes, `Adding ${r.effect} changes ${(r.changes || []).length} value(s) of the model`) +
      // one "add" per effect: the verdict's is the findings' button above (static/findings.js),
      // which takes the whole next model (with its recalibration)
      (r.effect === d.verdict && d.model
        ? `<p class="muted small taken-above">The verdict: add it with “Add ${esc(r.effect)}” under the verdict above.</p>`
        : `<button type="button" class="add-effect-btn" id="add-${esc(r.effect)}" data-effect="${esc(r.effect)}"` +
          `${r.model ? '' : ' disabled'} title="Take the refitted model (current model + ${esc(r.effect)}) as the new current model">Add ${esc(r.effect)} to the model</button>`);
    cards.appendChild(card);
  });
}
/** Why the diagnosis's "error before" is not the comparison's error: the diagnosis first refits
 * the uncertain base parameters (the null model), and every candidate is weighed against that.
 * The line names the refitted values that moved, and says they come with whatever is added. */
function explainErrorBefore(d) {
  const start = d.error_start ? d.error_start.overall : null;
  const before = d.error_before ? d.error_before.overall : null;
  if (start == null || before == null) return '';
  const moved = (d.refitted || []).filter((q) => typeof q.before === 'number' && typeof q.after === 'number' &&
    Math.abs(q.after - q.before) > (q.stderr || 0) && q.after !== q.before);
  if (Math.abs(start - before) <= 1e-4 * Math.max(start, 1e-12)) {
    return `Error before is your model's own error (${pct(start)} %)${moved.length ? '' : ': no base parameter moved'}.`;
  }
  if (!moved.length) {
    // the null refit moved the uncertain base values, and the fit with the effect brought them
    // back to the user's (they took up part of what was missing): the finding keeps them
    const paths = (d.uncertain || []).filter((p) => !String(p).startsWith('effects.'));
    return `Your model as given: ${pct(start)} % (the comparison's error). "Error before" (${pct(before)} %) is the ` +
      `best it reaches with the base parameters left uncertain${paths.length ? ` (${paths.join(', ')})` : ''} refitted ` +
      'and no effect added: each effect is weighed against that. Fitted with the effect, those values came back to ' +
      'yours, so a finding changes only what its card lists.';
  }
  const show = (q) => {
    const u = typeof unitShow === 'function' ? unitShow(q.unit) : { unit: q.unit, scale: 1, offset: 0 };
    const v = (x) => num((x - u.offset) / u.scale);
    return `${q.label || q.path} ${v(q.before)} → ${v(q.after)}${u.unit && u.unit !== '-' ? ` ${prettyUnit(u.unit)}` : ''}`;
  };
  return `Your model as given: ${pct(start)} % (the comparison's error). The diagnosis first refits the base parameters ` +
    `you left uncertain (${moved.map(show).join('; ')}), which alone gives ${pct(before)} %: that is "error before", ` +
    'against which each effect is weighed. Adding a finding takes these refitted values with it (listed in its changes)' +
    ((d.recalibrate || []).length ? '; "Apply the recalibration" takes them alone.' : '.');
}
/** Every parameter taking a candidate would change, before it is taken: the effect's own and
 * the base parameters recalibrated with it (before → after, in the page's units). */
function changesTable(changes, summary, open = false) {
  if (!changes || !changes.length) return '';
  const show = (x, u) => {
    if (typeof x !== 'number') return x == null ? '–' : esc(String(x));
    return num((x - u.offset) / u.scale);
  };
  const rows = changes.map((c) => {
    const u = c.kind === 'scaled' ? { unit: '× (scale)', scale: 1, offset: 0 }
      : (typeof unitShow === 'function' ? unitShow(c.unit) : { unit: c.unit, scale: 1, offset: 0 });
    return `<tr data-path="${esc(c.path)}"><th scope="row">${esc(c.path)}</th><td class="num">${show(c.before, u)}</td>` +
      `<td class="num">${show(c.after, u)}</td><td>${esc(prettyUnit(u.unit || ''))}</td></tr>`;
  }).join('');
  return `<details class="changes"${open ? ' open' : ''}><summary>${esc(summary)}</summary>` +
    '<table class="data"><thead><tr><th scope="col">parameter</th><th scope="col">now</th><th scope="col">after</th><th scope="col">unit</th></tr></thead>' +
    `<tbody>${rows}</tbody></table></details>`;
}
async function adoptEffect(ev) {
  const btn = ev.target.closest('.add-effect-btn');
  if (!btn || !S.diag) return;
  const r = (S.diag.result.ranking || []).find((q) => q.effect === btn.dataset.effect);
  if (!r || !r.model) return;
  clearErrors();
  await busy(btn, async () => {
    try {
      await ensureSession();   // the model as it is on the experiments as they stand, first
      S.model = clone(r.model);
      renderModel();
      const params = {};
      for (const [k, p] of Object.entries(r.params || {})) params[k] = p.value;
      setStatus(`Adding ${r.effect} and recording a new model version…`, 'busy');
      const s = await recordVersion(r.effect, params);
      await runCompare({ keepErrors: true, noSession: true });
      const v = s.versions;
      const last = v[v.length - 1];
      const prev = v[v.length - 2];
      setStatus(`${r.effect} added (version ${last.version}): overall error ${pct(prev && prev.overall)} % → ${pct(last.overall)} %.`, 'ok');
      // the other cards were refitted on the previous model: adding one now would drop this effect
      S.diag.stale = true;
      $$('.add-effect-btn').forEach((b) => { b.disabled = true; b.dataset.keepDisabled = 'true'; });
      btn.textContent = `${r.effect} added`;
      const note = document.createElement('div');
      note.className = 'stale-note';
      note.textContent = `The model changed (+ ${r.effect}): run Diagnose again to rank the remaining effects on the new model.`;
      $('#diag-verdict').appendChild(note);
    } catch (e) { showApiError(e, `Adding ${r.effect}`); }
  });
}
