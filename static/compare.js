/* pneucore page: the comparison (view "Compare"): POST /api/compare on the selected experiments, the
 * overlay of measured and simulated signals and the residual plots.
 *
 * A classic script loaded before app.js (index.html); it only declares functions and constants,
 * so it uses app.js's S, api, plot, esc, ... helpers at call time. */
'use strict';

function plotEmptyCompare() {
  plot('compare-plot', [], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`pressure [${plotUnit('Pa').label}]`),
    yaxis2: axis(`position x [${plotUnit('m').label}]`, { overlaying: 'y', side: 'right', showgrid: false, mirror: false }), annotations: emptyNote('Pick a dataset, then Compare') }));
  plot('residual-plot', [], baseLayout({ xaxis: axis('time t [s]'), yaxis: axis(`pressure residual [${diffLabel('Pa')}]`),
    yaxis2: axis(`position residual [${plotUnit('m').label}]`, { overlaying: 'y', side: 'right', showgrid: false, mirror: false }), annotations: emptyNote('Residuals appear after a comparison') }));
}
async function runCompare(opts = {}) {
  if (!opts.keepErrors) clearErrors();
  if (!S.experiments.length) { fieldError('experiments', 'select a dataset or a sample first'); setStatus('Compare: no dataset selected.', 'error'); return null; }
  setStatus('Comparing the model with the measurement…', 'busy');
  return busy($('#btn-compare'), async () => {
    try {
      const exps = clone(S.experiments);
      const res = await api('POST', '/api/compare', { model: S.model, experiments: exps, heat_models: false });
      S.compare = { result: res, experiments: exps, model: JSON.stringify(S.model) };
      await Promise.all(exps.map((e) => measured(e.dataset_id)));
      renderCompare();
      // the session first, then "done": a status that says done with the session still being
      // started let a reader (a test under load) find no session yet
      if (!opts.noSession) await ensureSession();
      setStatus(`Comparison done: overall error ${pct(res.overall)} % (noise floor about ${pct(floorOf(res.noise_floor))} %).`, 'ok');
      return res;
    } catch (e) { showApiError(e, 'Comparison', (f) => (f.startsWith('experiments') ? 'experiments' : f)); return null; }
  });
}
/** The overall noise floor from the per-signal ones: the RMS, as the service forms the overall
 * error and the diagnosis its floor (one figure on the page, the one the messages quote). */
function floorOf(o) { const v = Object.values(o || {}).filter((x) => typeof x === 'number'); return v.length ? Math.sqrt(v.reduce((a, b) => a + b * b, 0) / v.length) : null; }
function renderCompare() {
  const { result: c, experiments: exps } = S.compare;
  const signals = Object.keys(c.errors);
  // error per signal: all experiments, then each experiment, then the noise floor
  let h = '<table id="error-table-data" class="data"><thead><tr><th scope="col">signal</th><th scope="col">all experiments</th>';
  h += c.experiments.map((e) => `<th scope="col">${esc(e.name)}</th>`).join('') + '<th scope="col">noise floor</th></tr></thead><tbody>';
  for (const s of signals) {
    h += `<tr><th scope="row">${esc(s)}</th><td class="num" data-signal="${esc(s)}">${pct(c.errors[s])}</td>`;
    h += c.experiments.map((e) => `<td class="num">${e.errors && e.errors[s] != null ? pct(e.errors[s]) : '–'}</td>`).join('');
    h += `<td class="num muted">${pct(c.noise_floor && c.noise_floor[s])}</td></tr>`;
  }
  h += `<tr class="total"><th scope="row">overall</th><td class="num" data-signal="overall">${pct(c.overall)}</td>`;
  h += c.experiments.map((e) => `<td class="num">${pct(e.overall)}</td>`).join('') + `<td class="num muted">${pct(floorOf(c.noise_floor))}</td></tr></tbody></table>`;
  $('#error-table').innerHTML = h;
  // per phase (Table 2 layout: phases as rows, signals as columns)
  const phaseRows = [...Object.entries(c.phases || {}), ...Object.entries(c.piston_phases || {})];
  let p = '<table id="phase-table-data" class="data"><thead><tr><th scope="col">phase</th>' +
    signals.map((s) => `<th scope="col">${esc(s)}</th>`).join('') + '<th scope="col">overall</th></tr></thead><tbody>';
  for (const [name, row] of phaseRows) {
    p += `<tr><th scope="row">${esc(name)}</th>` + signals.map((s) => `<td class="num">${pct(row[s])}</td>`).join('') +
      `<td class="num"><b>${pct(row.overall)}</b></td></tr>`;
  }
  $('#phase-table').innerHTML = p + '</tbody></table>';
  renderPhaseExplanations(c.phase_explanations || {}, phaseRows.map(([name]) => name));
  $('#compare-summary').innerHTML = `Overall error <b id="compare-overall">${pct(c.overall)} %</b> over ${c.experiments.length} experiment(s); ` +
    `model <i>${esc(S.model.name || 'custom')}</i>${Object.keys(S.model.effects || {}).length ? ' + ' + esc(Object.keys(S.model.effects).join(' + ')) : ''}.` +
    (c.hints || []).map((h) => `<p class="context-hint warn" data-kind="${esc(h.kind)}">Check the context: ${esc(h.message)}</p>`).join('');
  // worst windows
  $('#failure-windows').innerHTML = (c.failure_windows || []).map((w, i) =>
    `<li><span class="win-tag">#${i + 1}</span> ${esc(w.description || `${w.experiment}: ${w.signal} ${w.t_start}-${w.t_end} s`)}` +
    `${w.share != null ? ` <span class="muted">(${pct(w.share, 0)} % of the residual energy)</span>` : ''}</li>`).join('') ||
    '<li class="muted">No window stands out.</li>';
  plotCompare(c, exps);
  plotResiduals(c);
  if (typeof plotCompareBench === 'function') plotCompareBench(c, exps);   // F and q (static/identify.js)
  markStaleComparison();
}
/** Why each phase's error stands above the noise (offset, drift, lag) or that it is within it,
 * one line per phase in the table's order; the service's words, set as plain text. */
function renderPhaseExplanations(ex, order) {
  const box = $('#phase-explanations');
  if (!box) return;
  box.replaceChildren(...order.filter((name) => ex[name]).map((name) => {
    const li = document.createElement('li');
    li.dataset.phase = name;
    li.className = ex[name].within_noise ? 'muted' : 'warn';
    li.textContent = ex[name].message;
    return li;
  }));
}
/** A stacked layout with one row per experiment, each with a left and an overlaying right axis. */
function stackedLayout(n, left, right, titles, extra = {}) {
  const layout = baseLayout(Object.assign({ height: Math.max(300, 250 * n + 70), hovermode: 'x', margin: { l: 64, r: 64, t: 50, b: 86 } }, extra));
  // the legend goes under the plot: above it, it covered the first subplot's title
  layout.legend = Object.assign({}, layout.legend, { y: 0, yref: 'container', yanchor: 'bottom', x: 0, xanchor: 'left' });
  const gap = 0.12;
  const h = (1 - gap * (n - 1)) / n;
  const rows = [];
  layout.annotations = [];
  for (let i = 0; i < n; i++) {
    const top = 1 - i * (h + gap);
    const dom = [Math.max(0, top - h), top];
    const xi = i === 0 ? '' : String(i + 1);
    const yi = i === 0 ? '' : String(2 * i + 1);
    const y2i = String(2 * i + 2);
    layout[`xaxis${xi}`] = axis('time t [s]', { anchor: `y${yi}`, domain: [0, 1], matches: i ? 'x' : undefined });
    layout[`yaxis${yi}`] = axis(left, { domain: dom, anchor: `x${xi}` });
    layout[`yaxis${y2i}`] = axis(right, { overlaying: `y${yi}`, side: 'right', anchor: `x${xi}`, showgrid: false, mirror: false, tickmode: 'auto', nticks: 6 });
    layout.annotations.push({ text: `<b>${esc(titles[i])}</b>`, xref: 'paper', yref: 'paper', x: 0, y: top, yanchor: 'bottom', xanchor: 'left', showarrow: false, font: { size: 11 }, yshift: 2 });
    rows.push({ x: `x${xi}`, y: `y${yi}`, y2: `y${y2i}`, domain: dom });
  }
  return { layout, rows };
}
const SIG_COLORS = { p_a: '#1f77b4', p_b: '#d62728', x: '#2ca02c', v: '#9467bd', T_a: '#17becf', T_b: '#e377c2' };
/** Measured signals beside simulated ones: a light tone of each signal's colour */
const MEAS_COLORS = { p_a: '#9ec5e8', p_b: '#f0a3a4', x: '#a3d9a3', v: '#cdb8e0', T_a: '#9ae3ea', T_b: '#f3c1e4' };
/** Above this many samples a measured signal is drawn as a thin line, not dots [-] */
const MEASURED_DOTS_MAX = 2000;
const SIG_SI = { p_a: 'Pa', p_b: 'Pa', p_s: 'Pa', x: 'm', v: 'm/s' };
/** Signals the comparison's two axes hold (pressures; position, velocity, temperatures): the rod
 * force F [N] and the flows q_a, q_b, q_s [kg/s] have a plot of their own (identify.js) */
const onCompareAxes = (sig) => sig in SIG_SI || sig.startsWith('T');
/** A measured or simulated signal as the plots show it; `diff` for residuals (no gauge offset). */
function toDisplay(sig, arr, diff = false) {
  if (sig.startsWith('T')) return diff ? plotUnit('K').diff(arr) : plotUnit('K').val(arr);
  if (!SIG_SI[sig]) return arr;
  const u = plotUnit(SIG_SI[sig]);
  return diff ? u.diff(arr) : u.val(arr);
}
/** The unit of a difference of pressures: a gauge offset cancels, so 'bar g' reads 'bar'. */
function diffLabel(si) { return plotUnit(si).label.replace(/ (abs|g)$/, ''); }
function plotCompare(c, exps) {
  const n = c.experiments.length;
  const { layout, rows } = stackedLayout(n, `pressure [${plotUnit('Pa').label}]`, `position x [${plotUnit('m').label}]`, c.experiments.map((e) => e.name),
    { legend: { orientation: 'h', x: 0, y: 1.0, yanchor: 'bottom', yref: 'container' } });
  layout.legend = { orientation: 'h', x: 0.5, xanchor: 'center', y: 1, yanchor: 'top', yref: 'container', font: { size: 11 } };
  layout.margin.t = 56;
  const traces = [];
  const seen = new Set();
  const first = (g) => (seen.has(g) ? false : (seen.add(g), true));
  c.experiments.forEach((e, i) => {
    const meas = S.measured[exps[i] && exps[i].dataset_id] || {};
    for (const sig of Object.keys(e.simulated || {}).filter(onCompareAxes)) {
      const axisRef = sig.startsWith('p') ? rows[i].y : rows[i].y2;
      const color = SIG_COLORS[sig] || '#555';
      if (meas[sig]) {
        // measured: a light tone of the signal's colour, a thin line once the dots would merge
        // into one (issue 39: 10,000 dots read as a thick line of the simulation's colour)
        const many = meas.t.length > MEASURED_DOTS_MAX;
        traces.push({ x: meas.t, y: toDisplay(sig, meas[sig]), xaxis: rows[i].x, yaxis: axisRef, mode: many ? 'lines' : 'markers', name: `${sig} measured`,
          legendgroup: `${sig}m`, showlegend: first(`${sig}m`),
          ...(many ? { line: { color: MEAS_COLORS[sig] || '#aaa', width: 1 } } : { marker: { size: 3.5, color: MEAS_COLORS[sig] || '#aaa' } }) });
      }
      traces.push({ x: e.t, y: toDisplay(sig, e.simulated[sig]), xaxis: rows[i].x, yaxis: axisRef, mode: 'lines', name: `${sig} simulated`,
        legendgroup: `${sig}s`, showlegend: first(`${sig}s`), line: { color, width: 1.6, dash: 'dash' } });
    }
  });
  plot('compare-plot', traces, layout);
}
function plotResiduals(c, windows) {
  windows = windows || c.failure_windows || [];
  const n = c.experiments.length;
  const { layout, rows } = stackedLayout(n, `pressure residual [${diffLabel('Pa')}]`, `position residual [${plotUnit('m').label}]`, c.experiments.map((e) => e.name));
  layout.legend = { orientation: 'h', x: 0.5, xanchor: 'center', y: 1, yanchor: 'top', yref: 'container', font: { size: 11 } };
  layout.margin.t = 56;
  const traces = [];
  const seen = new Set();
  layout.shapes = [];
  c.experiments.forEach((e, i) => {
    for (const [sig, arr] of Object.entries(e.residuals || {}).filter(([sig]) => onCompareAxes(sig))) {
      traces.push({ x: e.t, y: toDisplay(sig, arr, true), xaxis: rows[i].x, yaxis: sig.startsWith('p') ? rows[i].y : rows[i].y2, mode: 'lines',
        name: `${sig} residual`, legendgroup: sig, showlegend: !seen.has(sig) && !!seen.add(sig), line: { color: SIG_COLORS[sig] || '#555', width: 1.2 } });
    }
    windows.forEach((w, k) => {
      if (w.experiment && w.experiment !== e.name) return;
      layout.shapes.push({ type: 'rect', xref: rows[i].x, yref: 'paper', x0: w.t_start, x1: w.t_end, y0: rows[i].domain[0], y1: rows[i].domain[1],
        fillcolor: '#ff9f1c', opacity: 0.22, line: { width: 0 }, layer: 'below' });
      layout.annotations.push({ text: `#${k + 1} ${esc(w.signal)}`, xref: rows[i].x, yref: 'paper', x: (w.t_start + w.t_end) / 2, y: rows[i].domain[1],
        yanchor: 'top', yshift: -12 * (k % 2), showarrow: false, font: { size: 10, color: '#a35a00' }, bgcolor: 'rgba(255,255,255,0.7)' });
    });
  });
  plot('residual-plot', traces, layout);
}
