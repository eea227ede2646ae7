'use strict';
/* A rig's record as it comes (panel 4): the chosen dataset plotted as soon as it is chosen or
 * uploaded (several chosen together: drawn in one plot, one line style each); for a record without a valve command (no u column), a command proposed from its
 * pressure's edges (POST /api/datasets/{id}/propose-command) drawn over the data in an editable
 * box: what the box holds is the experiment's scenario.command, sent with every analysis, and
 * the page says where it came from. Known values (panel 5): parameter paths the fits never move.
 * User text is inserted with textContent / esc(). */

const RIG = { commands: {}, sources: {} };   // dataset id -> [[t, u], ...] / 'proposed' | 'edited'

function commandText(cmd) { return cmd.map(([t, u]) => `${t} ${u}`).join('\n'); }

function parseCommandText(text) {
  const out = [];
  const lines = text.split('\n');
  for (let i = 0; i < lines.length; i++) {
    const s = lines[i].trim();
    if (!s) continue;
    const parts = s.split(/[\s,;]+/).map(Number);
    if (parts.length !== 2 || !parts.every(Number.isFinite)) throw new Error(`line ${i + 1}: expected "t u" (time [s], command [-])`);
    out.push(parts);
  }
  if (!out.length) throw new Error('the command is empty: give at least one "t u" line');
  return out;
}

/** The experiments with the command of each record that has none (beside the context stored
 * with the dataset: an experiment's own scenario replaces the stored one). */
function applyCommands() {
  for (const e of S.experiments) {
    const cmd = RIG.commands[e.dataset_id];
    if (!cmd) continue;
    const info = (S.datasets || []).find((d) => d.id === e.dataset_id);
    e.scenario = Object.assign({}, (info && info.scenario) || {}, e.scenario || {}, { command: cmd });
  }
}

/** The traces of one record: its measured signals and its command (measured, or the one
 * proposed or entered); ``label`` (a dataset's name) and ``dash`` tell records apart when
 * several are drawn together. */
function datasetTraces(id, meas, cmd, label = '', dash = 'solid') {
  const traces = [];
  const name = (what) => (label ? `${label}: ${what}` : what);
  const group = label ? { legendgroup: id } : {};
  for (const sig of ['p_a', 'p_b', 'x', 'v', 'T_a', 'T_b']) {
    if (!meas[sig]) continue;
    const row = sig.startsWith('p') ? 'y' : (sig === 'x' || sig === 'v' ? 'y2' : 'y3');
    traces.push({ x: meas.t, y: toDisplay(sig, meas[sig]), yaxis: row, mode: 'lines', name: name(`${sig} measured`),
      line: { color: SIG_COLORS[sig] || '#555', width: 1.2, dash }, ...group });
  }
  const u = cmd ? null : meas.u;
  if (cmd) {
    const tEnd = meas.t[meas.t.length - 1];
    const xs = [], ys = [];
    cmd.forEach(([t, v], k) => { const t1 = k + 1 < cmd.length ? cmd[k + 1][0] : tEnd; xs.push(t, t1); ys.push(v, v); });
    traces.push({ x: xs, y: ys, yaxis: 'y3', mode: 'lines', name: name(`u ${RIG.sources[id] || 'proposed'}`), line: { color: '#ff7f0e', width: 1.6, dash }, ...group });
  } else if (u) {
    traces.push({ x: meas.t, y: u, yaxis: 'y3', mode: 'lines', name: name('u measured'), line: { color: '#ff7f0e', width: 1.2, dash }, ...group });
  }
  return traces;
}

function plotDataset(id, meas, cmd) { plotDatasetTraces(datasetTraces(id, meas, cmd)); }

/** Several records chosen together (a rig's tests): drawn in one plot, one line style each. */
function plotDatasets(list, meass) {
  const dashes = ['solid', 'dot', 'dash', 'dashdot', 'longdash'];
  plotDatasetTraces(list.flatMap((d, k) => datasetTraces(d.id, meass[k], RIG.commands[d.id] || null, d.name, dashes[k % dashes.length])));
}

function plotDatasetTraces(traces) {
  // three stacked axes: tall enough, and short titles, for each title to stay within its own
  // axis (issue 39: the pressure's and the position's titles ran into each other)
  const layout = baseLayout({ height: 480, margin: { l: 64, r: 20, t: 30, b: 46 } });
  layout.xaxis = axis('time t [s]', { anchor: 'y3' });
  layout.yaxis = axis(`p [${plotUnit('Pa').label}]`, { domain: [0.66, 1] });
  layout.yaxis2 = axis(`x [${plotUnit('m').label}]`, { domain: [0.33, 0.6] });
  layout.yaxis3 = axis('u [-]', { domain: [0, 0.27] });
  plot('dataset-plot', traces, layout);
}

async function showDatasetData(list) {
  const box = $('#dataset-command-box');
  const plotEl = $('#dataset-plot');
  box.hidden = true;
  if (!list.length) { plotEl.hidden = true; return; }
  if (list.length > 1) {
    let meass;
    try { meass = await Promise.all(list.map((d) => measured(d.id))); } catch (e) { return; }
    const ids = list.map((d) => d.id);
    if (JSON.stringify(selectedDatasets().map((d) => d.id)) !== JSON.stringify(ids)) return;   // chosen again meanwhile
    plotEl.hidden = false;
    plotDatasets(list, meass);
    return;
  }
  const d = list[0];
  let meas;
  try { meas = await measured(d.id); } catch (e) { return; }
  if (($('#dataset-select').value || '') !== `ds:${d.id}` && !($('#dataset-select').value || '').startsWith('sample:')) return;
  plotEl.hidden = false;
  if (meas.u) { plotDataset(d.id, meas, null); return; }
  if (!RIG.commands[d.id]) {
    try {
      const p = await api('POST', `/api/datasets/${encodeURIComponent(d.id)}/propose-command`, {});
      RIG.commands[d.id] = p.command;
      RIG.sources[d.id] = 'proposed';
      RIG.chamberB = RIG.chamberB || {};
      RIG.chamberB[d.id] = p.chamber_b || null;
      $('#dataset-command-note').textContent = `The record has no valve command (u). Proposed from ${p.signal}: ${p.note}.`;
    } catch (e) {
      RIG.commands[d.id] = [[0, 0]];
      RIG.sources[d.id] = 'edited';
      $('#dataset-command-note').textContent = 'The record has no valve command (u) and none could be proposed: enter it below.';
    }
  }
  $('#dataset-command').value = commandText(RIG.commands[d.id]);
  $('#dataset-command').dataset.datasetId = d.id;
  $('#dataset-command-source').textContent = RIG.sources[d.id] === 'proposed'
    ? 'command source: proposed from the pressure edges (edit to correct it)' : 'command source: entered on this page';
  box.hidden = false;
  showChamberB((RIG.chamberB || {})[d.id]);
  applyCommands();
  plotDataset(d.id, meas, RIG.commands[d.id]);
}

/** Chamber B's state proposed from the record (issue 39), for a 3/2 valve: shown beside the
 * command with a button that sets it on the model; the model's field shows the choice. */
function showChamberB(cb) {
  const el = $('#dataset-chamber-b');
  if (!el) return;
  RIG.lastChamberB = cb;   // shown again when the model changes (renderModel)
  const kind = S.model && S.model.valve && S.model.valve.kind;
  if (!cb || !cb.b_chamber || kind !== '3/2') { el.hidden = true; return; }
  const now = (S.model.valve.b_chamber || 'held');
  $('#dataset-chamber-b-text').textContent = `Chamber B of the 3/2 valve: ${cb.b_chamber} proposed` +
    `${cb.sure ? '' : ' (likely)'}: ${cb.why}. The model has it ${now}.`;
  const btn = $('#btn-chamber-b');
  btn.textContent = `Set chamber B ${cb.b_chamber}`;
  btn.disabled = now === cb.b_chamber;
  btn.onclick = () => {
    setChamberB(cb.b_chamber, cb.b_chamber_pressure);
    showChamberB(cb);
  };
  el.hidden = false;
}

function onCommandEdit() {
  const ta = $('#dataset-command');
  const id = ta.dataset.datasetId;
  if (!id) return;
  clearFieldError(ta);
  try {
    RIG.commands[id] = parseCommandText(ta.value);
    RIG.sources[id] = 'edited';
    $('#dataset-command-source').textContent = 'command source: entered on this page';
    applyCommands();
    if (S.measured[id]) plotDataset(id, S.measured[id], RIG.commands[id]);
  } catch (e) {
    fieldError('experiments.command', e.message, ta);
  }
}

/** Known values of panel 5: parameter paths, comma- or space-separated. */
function knownPaths() {
  const el = $('#diag-known');
  return el ? el.value.split(/[\s,;]+/).filter(Boolean) : [];
}

function wireRigData() {
  $('#dataset-command').addEventListener('change', onCommandEdit);
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', wireRigData); else wireRigData();
