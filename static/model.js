/* pneucore page: the model panel (view "Model & circuit"): the jack, supply, valve tables, friction
 * map (POST /api/friction/preview), effects, presets and model JSON in and out.
 *
 * A classic script loaded before app.js (index.html); it only declares functions and constants,
 * so it uses app.js's S, api, plot, esc, ... helpers at call time. */
'use strict';

/* ------------------------------------------------------------------ model panel */
function fieldInputs(prefix) { return $$(`[data-field^="${prefix}"]`).filter((e) => /^(INPUT|SELECT|TEXTAREA)$/.test(e.tagName)); }

function renderModel() {
  const m = S.model;
  if (!m) return;
  $('#model-name').textContent = m.name ? `${m.name}${m.description ? ' — ' + m.description : ''}` : '';
  for (const el of fieldInputs('model.')) {
    if (el.closest('#valve-tables') || el.closest('#effects-list') || el.closest('#friction-rows')) continue;
    writeInput(el, getPath({ model: m }, parsePath(el.dataset.field)));
  }
  $('#valve-kind').textContent = (m.valve && m.valve.kind) || '?';
  renderValveTables();
  renderFriction();
  renderEffects();
  plotValve();
  plotFriction();
  if (typeof showChamberB === 'function' && typeof RIG !== 'undefined') showChamberB(RIG.lastChamberB);
  if (typeof scheduleCalReload === 'function') scheduleCalReload();   // static/calibrate.js
}
function writeInput(el, v) {
  if (el.type === 'checkbox') el.checked = !!v;
  // a field left at its default is absent from the model's JSON: the select shows the default
  else if (el.tagName === 'SELECT') el.value = v == null ? (el.dataset.default || '') : String(v);
  else el.value = displayValue(typeof v === 'number' ? v - Number(el.dataset.offset || 0) : v, Number(el.dataset.scale || 1));
}
function readInput(el) {
  if (el.type === 'checkbox') return el.checked;
  if (el.dataset.text) return el.value;   // a name or a description: text, even when it looks like a number
  if (el.tagName === 'SELECT') return el.value;
  const raw = el.value.trim();
  if (raw === '') return null;
  const v = Number(raw);
  if (!Number.isFinite(v)) return raw;  // let the API name the problem next to the field
  const scale = Number(el.dataset.scale || 1);
  const offset = Number(el.dataset.offset || 0);   // gauge display (static/units.js)
  return (scale === 1 ? v : +(v * scale).toPrecision(12)) + offset;
}
function onModelInput(ev) {
  const el = ev.target;
  if (!el.dataset || !el.dataset.field || !el.dataset.field.startsWith('model.')) return;
  const parts = parsePath(el.dataset.field).slice(1);
  rememberModelOrigin();
  const value = readInput(el);
  if (value === null) {
    // an emptied field is the default again (absent from the JSON), not a null the service
    // would refuse as "not a valid number"
    const parent = getPath(S.model, parts.slice(0, -1));
    if (parent && typeof parent === 'object') delete parent[parts[parts.length - 1]];
  } else setPath(S.model, parts, value);
  clearFieldError(el);
  markModelEdited(parts[0]);
  if (el.dataset.field === 'model.valve.b_chamber') setChamberB(value);
  if (typeof scheduleCalReload === 'function') scheduleCalReload();   // static/calibrate.js
  plotValve();
  plotFriction();
  markStaleComparison();
  if (typeof refreshCircuit === 'function') refreshCircuit();   // static/circuit.js: fields and schematic
}
/** Chamber B of a 3/2 valve set to ``mode``: the fields of the other modes dropped (a
 * restriction's conductance left behind made the service refuse "vented"), the held pressure
 * set where given, the description's words about chamber B brought up to date, the fields
 * shown again. */
function setChamberB(mode, pressure) {
  const v = S.model.valve;
  v.b_chamber = mode;
  if (mode !== 'restriction') { delete v.b_chamber_conductance; delete v.b_chamber_critical_ratio; }
  if (mode !== 'held') delete v.b_chamber_pressure;
  else if (typeof pressure === 'number') v.b_chamber_pressure = pressure;
  const words = { held: v.b_chamber_pressure ? `chamber B held at ${(v.b_chamber_pressure / 1e5).toPrecision(3)} bar abs` : 'chamber B at half the supply pressure',
    vented: 'chamber B vented to the ambient', closed: 'chamber B closed (an air spring)', restriction: 'chamber B vented through a restriction' };
  if (S.model.description) {
    S.model.description = S.model.description.replace(/chamber B (?:held )?at half (?:the )?supply(?: pressure)?|chamber B held at [0-9.]+ bar abs|chamber B vented to the ambient|chamber B closed \(an air spring\)|chamber B vented through a restriction/gi, words[mode] || `chamber B ${mode}`);
  }
  for (const el of fieldInputs('model.valve.b_chamber')) writeInput(el, getPath({ model: S.model }, parsePath(el.dataset.field)));
  $('#model-name').textContent = S.model.name ? `${S.model.name}${S.model.description ? ' — ' + S.model.description : ''}` : '';
  plotValve();
  markStaleComparison();
  if (typeof refreshCircuit === 'function') refreshCircuit();
}
/** A preset's (or a design's) description no longer describes a model whose jack, valve,
 * supply or friction was changed ("12 mm double rod, 250 mm stroke" after the stroke changed):
 * it is dropped and the name marked edited (once). */
function physicalModelKey(m) { const c = Object.assign({}, m); delete c.name; delete c.description; return JSON.stringify(c); }
/** The loaded model's name, description and physics, before its first edit (a model loaded
 * anew is another object: its own origin). */
function rememberModelOrigin() {
  const m = S.model;
  if (!m || (S.modelOrigin && S.modelOrigin.ref === m)) return;
  S.modelOrigin = { ref: m, name: m.name, description: m.description, key: physicalModelKey(m) };
}
function markModelEdited(section) {
  const m = S.model;
  if (!m || !['jack', 'valve', 'supply', 'ambient', 'friction', 'heat', 'gas'].includes(section)) return;
  const o = S.modelOrigin && S.modelOrigin.ref === m ? S.modelOrigin : null;
  if (o && physicalModelKey(m) === o.key) {      // edited back: the preset's text is true again
    m.name = o.name;
    m.description = o.description;
  } else {
    m.description = '';
    if (m.name && !/\(edited\)$/.test(m.name)) m.name = `${m.name} (edited)`;
  }
  $('#model-name').textContent = m.name || '';
  const nameInput = $('#model-name-input');
  if (nameInput) nameInput.value = m.name || '';
}
/** A comparison on screen that was made with another model says so (it is kept for reference,
 * not silently taken for the current model's). */
function markStaleComparison() {
  const box = $('#compare-summary');
  if (!box || !S.compare || !S.compare.model) return;
  const stale = S.compare.model !== JSON.stringify(S.model);
  box.classList.toggle('stale', stale);
  let note = $('#compare-stale');
  if (stale && !note) {
    note = document.createElement('p');
    note.id = 'compare-stale';
    note.className = 'stale-note';
    note.textContent = 'The model changed since this comparison: these errors and plots are the previous model\'s. Compare again.';
    box.prepend(note);
  } else if (!stale && note) note.remove();
}
function clearFieldError(el) {
  el.classList.remove('invalid');
  el.removeAttribute('aria-invalid');
  const holder = el.closest('.field');
  const slot = holder && $(':scope > .field-error', holder);
  if (slot && !$$('.invalid', holder).length) { slot.textContent = ''; slot.removeAttribute('data-error-for'); }
}

function renderValveTables() {
  const box = $('#valve-tables');
  const ports = (S.model.valve && S.model.valve.ports) || {};
  const cu = C_UNITS[S.cUnit];
  box.innerHTML = '';
  for (const [edge, t] of Object.entries(ports)) {
    const div = document.createElement('div');
    div.className = 'edge field';
    div.dataset.field = `model.valve.ports.${edge}`;
    div.id = `edge-${edge}`;
    const e = esc(edge);   // a port name comes from the user's model JSON
    const rows = (t.opening || []).map((_, i) => {
      const cell = (col, scale, unit) => {
        const id = `edge-${e}-${col}-${i}`;
        const v = t[col] ? t[col][i] : null;
        return `<td><label class="sr-only" for="${id}">${e} ${col} row ${i + 1} [${unit}]</label>` +
          `<input id="${id}" type="number" step="any" data-field="model.valve.ports.${e}.${col}[${i}]" data-scale="${scale}" value="${esc(displayValue(v, scale))}"></td>`;
      };
      return `<tr>${cell('opening', 1, '-')}${cell('C', cu.scale, cu.label)}${cell('b', 1, '-')}` +
        `<td><button type="button" class="icon del-row" data-edge="${e}" data-row="${i}" title="Remove row ${i + 1}" aria-label="Remove row ${i + 1} of ${e}">×</button></td></tr>`;
    }).join('');
    div.innerHTML = `<div class="edge-head"><span class="swatch" style="background:${EDGE_COLORS[edge] || '#555'}"></span><b>${esc(edge)}</b>` +
      `<button type="button" class="icon add-row" data-edge="${e}" title="Add a row" aria-label="Add a row to ${e}">+ row</button></div>` +
      `<table class="edge-table"><thead><tr><th>opening [-]</th><th>C [${cu.label}]</th><th>b [-]</th><th></th></tr></thead><tbody>${rows}</tbody></table>` +
      '<span class="field-error" role="alert"></span>';
    box.appendChild(div);
  }
}
function editValveRows(ev) {
  const btn = ev.target.closest('button');
  if (!btn) return;
  const t = S.model.valve.ports[btn.dataset.edge];
  if (!t) return;
  const cols = ['opening', 'C', 'b', 'm'].filter((c) => Array.isArray(t[c]));
  if (btn.classList.contains('add-row')) {
    const n = t.opening.length;
    const last = n ? t.opening[n - 1] : 0;
    for (const c of cols) t[c].push(n ? t[c][n - 1] : (c === 'b' ? 0.3 : c === 'm' ? 0.5 : 0));
    t.opening[n] = n ? +Math.min(last + 0.05, last < 0 ? 0 : 1.5).toFixed(4) : 0;
  } else if (btn.classList.contains('del-row')) {
    const i = Number(btn.dataset.row);
    for (const c of cols) t[c].splice(i, 1);
  } else return;
  renderValveTables();
  plotValve();
}
function plotValve() {
  const ports = (S.model && S.model.valve && S.model.valve.ports) || {};
  const cu = C_UNITS[S.cUnit];
  const traces = [];
  for (const [edge, t] of Object.entries(ports)) {
    const color = EDGE_COLORS[edge] || '#555';
    const op = (t.opening || []).map(Number);
    traces.push({ x: op, y: (t.C || []).map((c) => Number(c) / cu.scale), name: `C ${edge}`, mode: 'lines+markers', line: { color }, marker: { size: 5 } });
    traces.push({ x: op, y: (t.b || []).map(Number), name: `b ${edge}`, yaxis: 'y2', mode: 'lines+markers', line: { color, dash: 'dot' }, marker: { size: 4, symbol: 'square' } });
  }
  plot('valve-plot', traces, baseLayout({
    height: 260, title: { text: 'Edge conductance C and critical ratio b vs opening', font: { size: 12 }, x: 0.01, y: 0.98 },
    margin: { l: 64, r: 56, t: 58, b: 44 }, legend: { orientation: 'h', y: 1.03, yanchor: 'bottom', x: 0, font: { size: 10 }, bgcolor: 'rgba(255,255,255,0)' },
    xaxis: axis('spool opening u [-]'), yaxis: axis(`C [${cu.label}]`, { rangemode: 'tozero' }),
    yaxis2: axis('b [-]', { overlaying: 'y', side: 'right', range: [0, 1], tickmode: 'linear', dtick: 0.2, showgrid: false, mirror: false }),
    hovermode: 'closest',
  }));
}

function renderFriction() {
  const f = S.model.friction || (S.model.friction = {});
  f.extend = f.extend || {};
  const same = f.retract == null;
  $('#fric-retract-same').checked = same;
  const body = $('#friction-rows');
  body.innerHTML = FRICTION_COEFFS.map(([k, label]) => {
    const unit = paramUnit(`friction.extend.${k}`) || '?';
    const cell = (set) => {
      const id = `fric-${set}-${k}`;
      const src = set === 'retract' && same ? f.extend : f[set];
      const v = src ? src[k] : null;
      return `<td><div class="field"><label class="sr-only" for="${id}">${set} ${k} [${unit}]</label>` +
        `<input id="${id}" type="number" step="any" data-field="model.friction.${set}.${k}" value="${esc(displayValue(v, 1))}"` +
        `${set === 'retract' && same ? ' disabled' : ''}><span class="field-error" role="alert"></span></div></td>`;
    };
    return `<tr><th scope="row">${esc(label)} [${esc(unit)}]</th>${cell('extend')}${cell('retract')}</tr>`;
  }).join('');
}
/** The friction map's pressures as typed, in the page's pressure unit (FRICTION.unit: the one
 * the text was written in), and in SI (Pa abs). */
function parseFrictionPressures() {
  const raw = $('#friction-pressures').value;
  const d = FRICTION.unit || frictionPressureUnit();
  const out = [];
  for (const tok of raw.split(/[,;]+/).map((s) => s.trim()).filter(Boolean)) {
    const [a, b] = tok.split('/').map((s) => Number(s.trim()));
    if (!Number.isFinite(a) || (tok.includes('/') && !Number.isFinite(b))) return { error: `"${tok}" is not a pressure in ${d.unit}` };
    out.push([a, tok.includes('/') ? b : a]);
  }
  const pairs = out.length ? out : [[(101300 - d.offset) / d.scale, (101300 - d.offset) / d.scale]];
  return { pairs, si: pairs.map(([a, b]) => [a * d.scale + d.offset, b * d.scale + d.offset]), unit: d.unit };
}
function frictionPressureUnit() {
  const d = typeof unitShow === 'function' ? unitShow('Pa') : { unit: 'Pa', scale: 1, offset: 0 };
  return { unit: d.unit, scale: d.scale || 1, offset: d.offset || 0 };
}
/** The friction map's pressures rewritten in the newly chosen unit, its label too. */
function applyFrictionUnits() {
  const el = $('#friction-pressures');
  if (!el) return;
  const p = parseFrictionPressures();
  const now = frictionPressureUnit();
  if (!p.error) {
    const show = (v) => String(+((v - now.offset) / now.scale).toPrecision(6));
    el.value = p.si.map(([a, b]) => (a === b ? show(a) : `${show(a)}/${show(b)}`)).join(', ');
  }
  FRICTION.unit = now;
  const lab = $('label[for="friction-pressures"]');
  if (lab) lab.textContent = lab.textContent.replace(/\[[^\]]*\]/, `[${prettyUnitText(now.unit)}]`);
  plotFriction();
}
// unit: the friction map text's pressure unit (the HTML's bar abs until the unit system applies)
const FRICTION = { timer: null, seq: 0, waiters: [], unit: { unit: 'bar abs', scale: 1e5, offset: 0 } };
/** Redraw the friction map once typing pauses; the promise settles when the map is drawn
 *  (or refused). Every call in the pause shares the one request. */
function plotFriction() {
  clearTimeout(FRICTION.timer);
  const done = new Promise((resolve) => FRICTION.waiters.push(resolve));
  FRICTION.timer = setTimeout(async () => {
    const waiters = FRICTION.waiters.splice(0);
    try { await drawFriction(); } finally { waiters.forEach((w) => w()); }
  }, FRICTION_DEBOUNCE_MS);
  return done;
}
/** The friction force map from the service: the model's own law (Eq. 18-20 with the Stribeck,
 *  pressure and quadrant effects it has); at v = 0 the stick band between the static limits. */
async function drawFriction() {
  if (!S.model) return;
  const parsed = parseFrictionPressures();
  const slot = $('#friction-pressures').closest('.field').querySelector('.field-error');
  slot.textContent = parsed.error || '';
  if (parsed.error) return;
  const seq = ++FRICTION.seq;
  let res;
  try {
    res = await api('POST', '/api/friction/preview', {
      model: S.model, pressures: parsed.si.map(([a, b]) => ({ p_a: a, p_b: b })),
    });
  } catch (e) {
    if (seq !== FRICTION.seq) return;
    const d = e instanceof ApiError && Array.isArray(e.detail) && e.detail[0];
    slot.textContent = `friction map not drawn: ${d ? `${d.field || 'request'}: ${d.msg}` : (e.message || e)}`;
    return;
  }
  if (seq !== FRICTION.seq) return;   // a newer request is on its way
  const palette = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2'];
  const VX = plotUnit('m/s');
  const traces = res.curves.map((c, k) => {
    const [a, b] = parsed.pairs[k];
    const x = []; const y = [];
    res.velocities.forEach((v, i) => {
      if (v === 0 || c.force[i] == null) { x.push(0, 0); y.push(-c.static_retract, c.static_extend); return; }
      x.push(VX.val([v])[0]); y.push(c.force[i]);
    });
    const pu = prettyUnitText(parsed.unit);
    return { x, y, mode: 'lines', name: a === b ? `p = ${a} ${pu}` : `p_a ${a} / p_b ${b} ${pu}`, line: { color: palette[k % palette.length] } };
  });
  plot('friction-plot', traces, baseLayout({
    height: 260, title: { text: 'Friction force map (paper Fig. 4)', font: { size: 12 }, x: 0.01, y: 0.98 },
    margin: { l: 64, r: 20, t: 58, b: 44 }, legend: { orientation: 'h', y: 1.03, yanchor: 'bottom', x: 0, font: { size: 10 }, bgcolor: 'rgba(255,255,255,0)' },
    xaxis: axis(`piston velocity v [${VX.label}]`, { zeroline: true, zerolinecolor: '#bbb' }), yaxis: axis('friction force F [N]', { zeroline: true, zerolinecolor: '#bbb' }),
    hovermode: 'closest',
  }));
}
function onRetractSame() {
  const f = S.model.friction || (S.model.friction = {});
  if ($('#fric-retract-same').checked) f.retract = null;
  else f.retract = clone(f.extend || {});
  renderFriction();
  plotFriction();
}

function catalog(name) { return S.effects.find((e) => e.name === name); }
function renderEffects() {
  const list = $('#effects-list');
  const effs = S.model.effects || (S.model.effects = {});
  const names = Object.keys(effs);
  list.innerHTML = names.length ? '' : '<p class="muted small">No extra effect: the paper\'s sixth-order model.</p>';
  for (const name of names) {
    const cat = catalog(name);
    const div = document.createElement('div');
    div.className = 'effect field';
    div.dataset.field = `model.effects.${name}`;
    div.id = `effect-${name}`;
    const params = Object.keys(effs[name]);
    const inputs = params.map((p) => {
      const meta = cat ? cat.parameters.find((q) => q.name === p) : null;
      const unit = meta ? meta.unit : '?';
      // shown in the page's unit system, as every other field (SI kept in the model)
      const d = meta && typeof unitShow === 'function' ? unitShow(unit) : { unit, scale: 1, offset: 0 };
      const sc = d.scale || 1, off = d.offset || 0;
      const v = effs[name][p];
      const id = esc(`eff-${name}-${p}`);
      return `<div class="field"><label for="${id}" title="${esc(meta ? meta.description : '')}">${esc(p)} [${esc(prettyUnitText(d.unit))}]</label>` +
        `<input id="${id}" type="number" step="any" data-field="model.effects.${esc(name)}.${esc(p)}" data-scale="${sc}" data-offset="${off}" value="${esc(displayValue(typeof v === 'number' ? v - off : v, sc))}">` +
        '<span class="field-error" role="alert"></span></div>';
    }).join('');
    div.innerHTML = `<div class="effect-head"><b>${esc(name)}</b> <span class="muted small">${esc(cat ? cat.description : 'not in the catalog')}</span>` +
      `<button type="button" class="icon remove-effect" id="remove-${esc(name)}" data-effect="${esc(name)}" aria-label="Remove ${esc(name)}">Remove</button></div>` +
      `<div class="grid">${inputs}</div><span class="field-error" role="alert"></span>`;
    list.appendChild(div);
  }
  const sel = $('#effect-add-select');
  const keep = sel.value;
  sel.innerHTML = S.effects.filter((e) => !(e.name in effs))
    .map((e) => `<option value="${esc(e.name)}">${esc(e.name)}${e.observable_in && !e.observable_in.includes('locked') ? ' (free piston only)' : ''}</option>`).join('');
  if ([...sel.options].some((o) => o.value === keep)) sel.value = keep;
  describeEffect();
  refreshStudyHints();
  if (typeof refreshCircuit === 'function') refreshCircuit();   // static/circuit.js: fields and schematic
}
function describeEffect() {
  const e = catalog($('#effect-add-select').value);
  $('#effect-desc').textContent = e ? `${e.description}. Signature: ${e.signature}. Parameters: ` +
    e.parameters.map((p) => `${p.name} [${p.unit}] (default ${num(p.default)})`).join(', ') : '';
}
function addEffect() {
  const e = catalog($('#effect-add-select').value);
  if (!e) return;
  const params = {};
  for (const p of e.parameters) params[p.name] = p.default;
  S.model.effects = S.model.effects || {};
  S.model.effects[e.name] = params;
  renderEffects();
  plotFriction();   // a friction effect (Stribeck, pressure, quadrant) changes the map
  setStatus(`Effect ${e.name} added with its default parameters; simulate or compare to see it.`, 'ok');
}
function removeEffect(ev) {
  const btn = ev.target.closest('.remove-effect');
  if (!btn) return;
  delete S.model.effects[btn.dataset.effect];
  renderEffects();
  plotFriction();
  setStatus(`Effect ${btn.dataset.effect} removed.`, 'info');
}

/** A model brought in as JSON (a file or pasted text): the model itself, or an export that
 * holds one under "model" (a fitted model, a refine or diagnosis answer); checked by the service
 * (POST /api/calibrate/parameters parses it with the API's own rules) before it replaces the
 * page's model, so a bad file names its field and leaves the current model alone. */
async function useModelJson(text, source) {
  clearErrors();
  let m;
  try { m = JSON.parse(text); } catch (e) {
    fieldError('model.json', `not valid JSON: ${e.message}`);
    setStatus(`${source}: not valid JSON (${e.message}).`, 'error');
    return false;
  }
  if (m && typeof m === 'object' && !m.jack && m.model && typeof m.model === 'object') m = m.model;
  if (!m || typeof m !== 'object' || Array.isArray(m)) {
    fieldError('model.json', 'a JSON object (a model) is expected');
    setStatus(`${source}: a JSON object (a model) is expected.`, 'error');
    return false;
  }
  try {
    await api('POST', '/api/calibrate/parameters', { model: m });
  } catch (e) {
    showApiError(e, `${source}: the model`);
    return false;
  }
  S.model = m;
  renderModel();
  renderEffects();
  markStaleComparison();
  setStatus(`Model ${m.name || '(unnamed)'} loaded from ${source}.`, 'ok');
  return true;
}
function downloadModel() {
  const name = (S.model.name || 'model').replace(/[^\w.-]+/g, '_');
  const url = URL.createObjectURL(new Blob([JSON.stringify(S.model, null, 1)], { type: 'application/json' }));
  const a = document.createElement('a');
  a.href = url;
  a.download = `${name}.json`;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

async function loadModelPreset(name) {
  const m = await api('GET', `/api/presets/${encodeURIComponent(name)}`);
  S.model = m;
  $('#model-preset').value = name;
  clearErrors();
  renderModel();
  markStaleComparison();
  modelDraft.markClean(m);   // static/draft.js: edits from here on are unsaved
  return m;
}

/* ------------------------------------------------------------------ catalogue valve */
/** The valve of the catalogue form (POST /api/valve/catalogue) into the model panel. */
async function useCatalogueValve(btn) {
  clearErrors();
  const fn = $('#cat-function').value;
  const fig = $('#cat-figure').value;
  const val = Number($('#cat-value').value);
  const b = Number($('#cat-b').value);
  // the form's units to the API's SI: C in dm³/(s bar), S in mm², times in ms
  const CU = typeof unitShow === 'function' ? unitShow('m^3/(s Pa)') : { scale: 1 };
  const supply = fig === 'C' ? { C: val * (CU.scale || 1), b }
    : fig === 'effective_area' ? { effective_area: val * 1e-6, b } : { [fig]: val, b };
  const body = { function: fn.replace('-bistable', ''), supply, bistable: fn.endsWith('-bistable'),
    on_time: Number($('#cat-on').value) * 1e-3, off_time: Number($('#cat-off').value) * 1e-3 };
  await busy(btn, async () => {
    try {
      const ans = await api('POST', '/api/valve/catalogue', body);
      rememberModelOrigin();
      S.model.valve = ans.valve;
      markModelEdited('valve');
      renderModel();
      setStatus(`Valve: ${ans.description}; ON ${num(body.on_time * 1e3, 3)} ms, OFF ${num(body.off_time * 1e3, 3)} ms.`, 'ok');
      $('#valve-catalogue').dataset.used = fn;
    } catch (e) { showApiError(e, 'Catalogue valve'); }
  });
}
function initCatalogueValve() {
  const b = document.getElementById('btn-catalogue-valve');   // app.js's $ is not loaded yet
  if (b) b.addEventListener('click', (ev) => useCatalogueValve(ev.target));
}
if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', initCatalogueValve); else initCatalogueValve();

/** The catalogue form's C option in the page's conductance unit. */
function applyCatalogueUnits() {
  const o = document.querySelector('#cat-figure option[value="C"]');
  if (o && typeof unitShow === 'function') o.textContent = `sonic conductance C [${prettyUnitText(unitShow('m^3/(s Pa)').unit)}]`;
}
