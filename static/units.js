'use strict';
/* One unit system for the page's inputs, with a switch in the header: SI, or engineering
 * (bar absolute or gauge, mm, cm³, L/min ANR). The systems and the SI unit of every model
 * and scenario field come from GET /api/units; an input shows (SI - offset) / scale, its
 * label the shown unit. The choice is kept in localStorage. The ambient pressure itself is
 * always shown absolute (gauge would make it 0). */

const UNITS = { api: null, system: localStorage.getItem('pneucore.units') || localStorage.getItem('pneucore.spec.units') || 'engineering' };

function prettyUnitText(u) { return String(u).replace(/\^3/g, '³').replace(/\^2/g, '²'); }

function shownUnit(field) {
  const si = UNITS.api.fields[field];
  if (si === undefined) return null;
  const sys = UNITS.api.systems[UNITS.system] || UNITS.api.systems.si;
  let d = sys.units[si];
  if (!d) return { unit: si, scale: 1, offset: 0 };
  if (d.offset === 'gauge') {
    if (field === 'model.ambient.pressure') return { unit: 'bar abs', scale: d.scale, offset: 0 };
    d = Object.assign({}, d, { offset: pAtm() });
  }
  return d;
}

/** How a value in SI unit `si` is shown: {unit, scale, offset}; display = (SI - offset) / scale. */
function unitShow(si) {
  const none = { unit: si, scale: 1, offset: 0 };
  if (!UNITS.api || !si) return none;
  const sys = UNITS.api.systems[UNITS.system] || UNITS.api.systems.si;
  const d = sys.units[si];
  if (!d) return none;
  return d.offset === 'gauge' ? Object.assign({}, d, { offset: pAtm() }) : d;
}

function applyUnits() {
  if (!UNITS.api) return;
  for (const el of $$('input[data-field]')) {
    if (el.type !== 'number') continue;
    const d = shownUnit(normField(el.dataset.field));
    if (!d) continue;
    el.dataset.scale = String(d.scale);
    el.dataset.offset = String(d.offset);
    const label = el.id ? $(`label[for="${CSS.escape(el.id)}"]`) : null;
    if (label) label.textContent = label.textContent.replace(/\[[^\]]*\]\s*$/, `[${prettyUnitText(d.unit)}]`);
  }
  // the valve tables' conductance unit follows the system (its own selector still overrides)
  const cSel = $('#valve-c-unit');
  if (cSel && typeof S !== 'undefined') { S.cUnit = UNITS.system === 'si' ? 'si' : 'dm3'; cSel.value = S.cUnit; }
  if (typeof renderModel === 'function') renderModel();
  if (typeof renderScenario === 'function') renderScenario();
  if (typeof renderDiagnosis === 'function' && S.diag) renderDiagnosis();
  // the plots follow the same system (app.js plotUnit)
  if (typeof plotSimulation === 'function') plotSimulation();
  if (typeof renderCompare === 'function' && S.compare) renderCompare();
  if (typeof renderStudyResults === 'function' && S.study && S.study.res) renderStudyResults();
  if (typeof applySizingUnits === 'function') applySizingUnits();
  if (typeof HEAT !== 'undefined' && HEAT.redraw) HEAT.redraw();
  if (typeof plotEmptyCompare === 'function' && typeof S !== 'undefined' && !S.compare) plotEmptyCompare();
  if (typeof applyFrictionUnits === 'function') applyFrictionUnits();
  if (typeof applyCatalogueUnits === 'function') applyCatalogueUnits();
  if (typeof applyControlUnits === 'function') applyControlUnits();
  if (typeof renderStudyRows === 'function' && typeof S !== 'undefined' && S.study && S.study.rows) renderStudyRows();
  if (typeof renderCalOptions === 'function' && typeof CAL !== 'undefined' && CAL.options.length) renderCalOptions();
  if (typeof renderCalReport === 'function' && typeof CAL !== 'undefined' && CAL.result) renderCalReport();
  document.body.dataset.units = UNITS.system;
}

async function initUnits() {
  // the header's height, so that a panel scrolled to is not hidden under it (app.css)
  const setHeader = () => document.documentElement.style.setProperty('--header-h', `${$('#top').offsetHeight + 8}px`);
  setHeader();
  window.addEventListener('resize', setHeader);
  try {
    UNITS.api = await fetchUnits();   // app.js: one request for the page
  } catch (e) { showApiError(e, 'Loading the unit systems'); return; }
  const sel = $('#unit-system');
  for (const [name, s] of Object.entries(UNITS.api.systems)) {
    const o = document.createElement('option');
    o.value = name; o.textContent = s.label;
    sel.appendChild(o);
  }
  if (!UNITS.api.systems[UNITS.system]) UNITS.system = 'engineering';
  sel.value = UNITS.system;
  sel.addEventListener('change', () => {
    UNITS.system = sel.value;
    localStorage.setItem('pneucore.units', UNITS.system);
    applyUnits();
  });
  // apply once the page holds its model and scenario
  const wait = setInterval(() => { if (document.body.dataset.ready) { clearInterval(wait); applyUnits(); } }, 50);
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', initUnits); else initUnits();
