/* The diagnosis's findings, two kinds apart: mis-set base parameters and missing effects.
 *
 * Loaded after app.js (same global scope: S, esc, num, pct, api helpers). It wraps
 * renderDiagnosis() to add a findings box above the ranked cards:
 *   "mis-set: heat coefficient 25 -> 41 W/(m^2 K)"   [Apply the recalibration]
 *   "missing: piston_leakage ..."                     [Add piston_leakage (with the recalibration)]
 *   "remaining: 0.08 % (noise floor 0.08 %)" or "outside the catalog: <signature>"
 *   "initial state, not recorded: <experiment> p_a 3.1e5 Pa (the replay assumed 1e5)"
 * with a mis-set parameter confounded with others marked "only in combination with ...",
 * and for effects it cannot tell apart the note naming the experiment that would separate them.
 * and wraps renderHistory() to draw the noise floor under the falling error.
 * Every text from the server goes through esc() or textContent.
 */
(function () {
  'use strict';
  const origRenderDiagnosis = window.renderDiagnosis;
  const origRenderHistory = window.renderHistory;

  function line(kind, html) {
    const li = document.createElement('li');
    li.className = `finding ${kind}`;
    li.innerHTML = html;
    return li;
  }

  function renderFindings() {
    const d = S.diag && S.diag.result;
    const box = document.getElementById('diag-findings') || document.createElement('div');
    box.id = 'diag-findings';
    box.className = 'findings';
    box.innerHTML = '';
    if (!d) return;
    const ul = document.createElement('ul');
    ul.className = 'findings-list';
    (d.initial_state || []).forEach((r) => {
      ul.appendChild(line('initial', `<span class="kind">initial state, not recorded:</span> ` +
        `<span class="what">${esc(r.experiment || '')} ${esc(r.label || r.path)}</span> ` +
        `${num(r.after, 3)} ${esc(r.unit || '')} <span class="muted small">(the replay assumed ${num(r.before, 3)}; ` +
        `fitted on the samples before the first command change, not a model parameter)</span>`));
    });
    const labelOf = {};
    (d.recalibrate || []).forEach((r) => { labelOf[r.path] = r.label || r.path; });
    (d.recalibrate || []).forEach((r) => {
      const group = (r.confounded_with || []).map((p) => esc(labelOf[p] || p));
      ul.appendChild(line('misset', `<span class="kind">mis-set:</span> <span class="what">${esc(r.label || r.path)}</span> ` +
        `${num(r.before, 3)} → <b>${num(r.after, 3)}</b> ${esc(r.unit || '')} <span class="muted small">(± ${num(r.stderr, 2)}; ${esc(r.path)})</span>` +
        (group.length ? ` <span class="confounded">only in combination with ${group.join(', ')}: these experiments ` +
          'identify the joint change, not its split</span>' : '')));
    });
    if (d.verdict) {
      const top = (d.ranking || []).find((q) => q.effect === d.verdict) || {};
      ul.appendChild(line('missing', `<span class="kind">missing:</span> <b class="what">${esc(d.verdict)}</b> ` +
        `<span class="muted small">${esc(top.description || '')}</span>`));
    }
    (d.alternatives || []).forEach((a) => {
      ul.appendChild(line('alternative', `<span class="kind">cannot tell apart:</span> ${esc(a.note || a.effect || a.path)}`));
    });
    const rem = d.remaining || {};
    if (rem.error != null) {
      const txt = rem.outside_catalog ? `<span class="kind">outside the catalog:</span> ${esc(rem.description || '')}`
        : `<span class="kind">remaining:</span> error ${pct(rem.error)} % (noise floor ${pct(rem.noise_floor)} %)` +
          (rem.at_floor ? ' — at the noise floor' : (rem.description ? ` — ${esc(rem.description)}` : ''));
      ul.appendChild(line(rem.outside_catalog ? 'outside' : 'remaining', txt));
    }
    if (!ul.children.length) ul.appendChild(line('none', 'Nothing mis-set and nothing missing that these experiments can show.'));
    box.appendChild(ul);
    const actions = document.createElement('div');
    actions.className = 'row actions';
    const given = (S.diag && S.diag.model) || S.model;
    if ((d.recalibrate || []).length && d.base_model) {
      // every value the recalibration changes, listed before it is applied, one box each: an
      // impossible, implausible or known value is left unticked (issue 39: "2 parameters"
      // announced, 7 values changed, among them the ones the message called implausible)
      const changes = d.recalibration_changes || [];
      const b = document.createElement('button');
      b.type = 'button';
      b.id = 'btn-apply-recalibration';
      b.title = 'Take the ticked values of the recalibration into the current model';
      actions.appendChild(b);
      if (changes.length) {
        box.insertAdjacentHTML('beforeend', choiceTable(changes, 'diag-recalibration-changes',
          `“Apply the recalibration” changes the ticked values of ${changes.length} (untick any to keep it as it is)`));
        const tbl = box.lastElementChild;
        const label = () => { const n = chosenCount(tbl); b.textContent = `Apply the recalibration (${n} value${n === 1 ? '' : 's'})`; b.disabled = n === 0; };
        tbl.addEventListener('change', label);
        label();
        b.addEventListener('click', () => apply(b, chosenModel(d.base_model, given, changes, tbl), null, {}, `recalibration (${chosenPaths(changes, tbl)})`));
      } else {
        b.textContent = `Apply the recalibration (${d.recalibrate.length} parameter${d.recalibrate.length > 1 ? 's' : ''})`;
        b.addEventListener('click', () => apply(b, d.base_model, null, {}, 'recalibration'));
      }
    }
    if (d.verdict && d.model) {
      const b = document.createElement('button');
      b.type = 'button';
      b.className = 'primary';
      b.id = 'btn-apply-findings';
      b.textContent = `Add ${d.verdict}${(d.recalibrate || []).length ? ' with the recalibration' : ''}`;
      const top = (d.ranking || []).find((q) => q.effect === d.verdict) || {};
      const params = {};
      for (const [k, p] of Object.entries(top.params || {})) params[k] = p.value;
      actions.appendChild(b);
      // everything the button changes, listed before it is pressed, one box each: the effect,
      // the recalibration and any other value the next model moves; a flagged value unticked
      const changes = d.changes || [];
      let tbl = null;
      if (changes.length) {
        box.insertAdjacentHTML('beforeend', choiceTable(changes, 'diag-findings-changes', `“${b.textContent}” changes the ticked values of ${changes.length}`));
        tbl = box.lastElementChild;
      }
      b.addEventListener('click', () => apply(b, tbl ? chosenModel(d.model, given, changes, tbl) : d.model, d.verdict, params, d.verdict));
    }
    box.appendChild(actions);
    const verdict = document.getElementById('diag-verdict');
    verdict.appendChild(box);
  }

  /** A table of changes with a box per value: ticked unless flagged (impossible, implausible,
   * declared known), the flag's reason beside it. */
  function choiceTable(changes, id, summary) {
    const show = (x, u) => (typeof x !== 'number' ? (x == null ? '–' : esc(String(x))) : num((x - u.offset) / u.scale));
    const rows = changes.map((c, i) => {
      const u = c.kind === 'scaled' ? { unit: '× (scale)', scale: 1, offset: 0 }
        : (typeof unitShow === 'function' ? unitShow(c.unit) : { unit: c.unit, scale: 1, offset: 0 });
      const flagged = c.flag != null;
      return `<tr data-path="${esc(c.path)}"${flagged ? ` class="flag-${esc(c.flag)}"` : ''}><td><input type="checkbox" data-index="${i}"${flagged ? '' : ' checked'} aria-label="apply ${esc(c.path)}"></td>` +
        `<th scope="row">${esc(c.path)}</th><td class="num">${show(c.before, u)}</td><td class="num">${show(c.after, u)}</td><td>${esc(prettyUnit(u.unit || ''))}</td>` +
        `<td class="small${flagged ? ' warn' : ''}">${flagged ? `${esc(c.flag)}: ${esc(c.why || '')}` : ''}</td></tr>`;
    }).join('');
    const n = changes.filter((c) => c.flag != null).length;
    return `<details class="changes" id="${id}"${n ? ' open' : ''}><summary>${esc(summary)}${n ? ` — ${n} flagged, left unticked` : ''}</summary>` +
      '<table class="data"><thead><tr><th scope="col">apply</th><th scope="col">parameter</th><th scope="col">now</th><th scope="col">after</th><th scope="col">unit</th><th scope="col">note</th></tr></thead>' +
      `<tbody>${rows}</tbody></table></details>`;
  }
  function chosenCount(tbl) { return tbl.querySelectorAll('input[type=checkbox]:checked').length; }
  function chosenPaths(changes, tbl) {
    return [...tbl.querySelectorAll('input[type=checkbox]:checked')].map((x) => changes[Number(x.dataset.index)].path).join(', ') || 'nothing';
  }
  /** ``target`` with every unticked change of ``tbl`` put back to ``given``'s value. */
  function chosenModel(target, given, changes, tbl) {
    const m = clone(target);
    tbl.querySelectorAll('input[type=checkbox]').forEach((box) => {
      if (box.checked) return;
      const c = changes[Number(box.dataset.index)];
      const parts = c.path.split('.');
      if (parts[0] === 'effects' && parts.length === 2 && c.kind === 'added') { delete m.effects[parts[1]]; return; }
      const old = getPath(given, parts);
      if (old === undefined) {
        const parent = getPath(m, parts.slice(0, -1));
        if (parent && typeof parent === 'object') delete parent[parts[parts.length - 1]];
      } else setPath(m, parts, clone(old));
    });
    return m;
  }

  async function apply(btn, model, added, params, what) {
    clearErrors();
    await busy(btn, async () => {
      try {
        // the session on the experiments as they stand first, with the model as it is: the
        // "before" of the message below is then that model on these experiments
        await ensureSession();
        S.model = clone(model);
        renderModel();
        setStatus(`Applying the ${what} and recording a new model version…`, 'busy');
        const s = await recordVersion(added, params);
        await runCompare({ keepErrors: true, noSession: true });
        const v = s.versions;
        setStatus(`Applied the ${what} (version ${v[v.length - 1].version}): overall error ` +
          `${pct(v[v.length - 2] && v[v.length - 2].overall)} % → ${pct(v[v.length - 1].overall)} %.`, 'ok');
        S.diag.stale = true;
        document.querySelectorAll('#diag-findings button, .add-effect-btn').forEach((b) => { b.disabled = true; b.dataset.keepDisabled = 'true'; });
        const note = document.createElement('div');
        note.className = 'stale-note';
        note.textContent = `The model changed (${what} applied): run Diagnose again for the next round.`;
        document.getElementById('diag-verdict').appendChild(note);
      } catch (e) { showApiError(e, `Applying the ${what}`); }
    });
  }

  function drawFloor() {
    const d = S.diag && S.diag.result;
    const div = document.getElementById('history-plot');
    const floor = d && d.remaining ? d.remaining.noise_floor : null;
    if (!div || !div.data) return;
    const old = div.data.map((t, i) => (t.name === 'noise floor' ? i : -1)).filter((i) => i >= 0);
    if (old.length) Plotly.deleteTraces(div, old);
    if (floor == null || !(floor > 0)) return;
    const n = (div.data[0] && div.data[0].x) ? div.data[0].x.length : 1;
    Plotly.addTraces(div, [{ x: [-0.4, Math.max(n - 1, 1) + 0.6], y: [floor * 100, floor * 100], mode: 'lines', name: 'noise floor',
      line: { color: '#2ca02c', dash: 'dash', width: 1.5 }, hovertemplate: 'noise floor: %{y:.3f} %<extra></extra>' }]);
  }

  window.renderDiagnosis = function () {
    origRenderDiagnosis();
    renderFindings();
    drawFloor();
  };
  window.renderHistory = function () {
    origRenderHistory();
    drawFloor();
  };
}());
