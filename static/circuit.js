'use strict';
/* The circuit panel (loaded after app.js, schematic.js and units.js; uses their S, catalog,
 * renderEffects, markStaleComparison, unitShow, prettyUnit, displayValue, drawSchematic).
 *
 * One column of fields per port (A: the end at x = 0, B: x = stroke) for the circuit's per-port
 * effects (tube, meter-out and meter-in flow controls, end cushion: every catalog parameter
 * named <stem>_a / <stem>_b), and the common ones (exhaust silencer, return spring); the
 * mounting angle is the jack's field. The fields are built from the effect catalog
 * (GET /api/effects: names, units, defaults, "off" values), so a parameter added there shows up
 * here. Typing a value into an effect the model lacks adds it, every other parameter at its
 * "off" value (its default where it has none): the model is the base model but for that value;
 * when every parameter with an "off" value is back at it, the effect is removed (a parameter
 * with no "off" value, a bore or a critical ratio, is disabled while its effect is absent). Each value
 * shows in the page's unit system (static/units.js).
 *
 * The schematic (static/schematic.js) is redrawn from S.model on every change of the model
 * (app.js calls refreshCircuit from onModelInput and renderEffects).
 */

const CIRCUIT_PORT_EFFECTS = [['tubing', 'Tube'], ['meter_out_throttle', 'Meter-out'], ['meter_in_throttle', 'Meter-in'], ['end_cushion', 'Cushion']];
const CIRCUIT_COMMON_EFFECTS = [['exhaust_silencer', 'Silencer'], ['return_spring', 'Return spring']];
const CIRCUIT = { built: null };   // the unit system and catalog the fields were built for

function circuitShow(si) {
  return typeof unitShow === 'function' ? unitShow(si) : { unit: si, scale: 1, offset: 0 };
}
function circuitOff(p) { return p.off === null || p.off === undefined ? p.default : p.off; }

function circuitField(grid, effect, label, p, stem) {
  const d = circuitShow(p.unit);
  const id = `circ-${effect}-${p.name}`;
  const div = document.createElement('div');
  div.className = 'field';
  const lab = document.createElement('label');
  lab.htmlFor = id;
  lab.title = p.description || '';
  lab.textContent = `${label} ${stem} [${prettyUnit(d.unit)}]`;
  const input = document.createElement('input');
  input.id = id;
  input.type = 'number';
  input.step = 'any';
  input.dataset.circuit = `${effect}.${p.name}`;
  input.dataset.scale = String(d.scale);
  input.placeholder = p.off === null || p.off === undefined ? '' : 'off';
  const err = document.createElement('span');
  err.className = 'field-error';
  err.setAttribute('role', 'alert');
  div.append(lab, input, err);
  grid.appendChild(div);
}

function circuitGroup(box, id, title) {
  const g = document.createElement('div');
  g.className = 'circuit-group';
  g.id = id;
  const h = document.createElement('h4');
  h.textContent = title;
  const grid = document.createElement('div');
  grid.className = 'grid';
  g.append(h, grid);
  box.appendChild(g);
  return grid;
}

function buildCircuitPanel() {
  const box = document.getElementById('circuit-fields');
  box.replaceChildren();
  for (const [end, where] of [['a', 'Port A (the end at x = 0)'], ['b', 'Port B (the end at x = stroke)']]) {
    const grid = circuitGroup(box, `circuit-port-${end}`, where);
    for (const [name, label] of CIRCUIT_PORT_EFFECTS) {
      const cat = catalog(name);
      if (!cat) continue;
      for (const p of cat.parameters) {
        if (p.name.endsWith(`_${end}`)) circuitField(grid, name, label, p, p.name.slice(0, -2));
      }
    }
  }
  const grid = circuitGroup(box, 'circuit-common', 'Both ports and the piston');
  for (const [name, label] of CIRCUIT_COMMON_EFFECTS) {
    const cat = catalog(name);
    if (cat) for (const p of cat.parameters) circuitField(grid, name, label, p, p.name);
  }
  // a per-port effect's parameter of neither port (e.g. a cushion's capacity) goes here too
  for (const [name, label] of CIRCUIT_PORT_EFFECTS) {
    const cat = catalog(name);
    if (cat) for (const p of cat.parameters) if (!/_[ab]$/.test(p.name)) circuitField(grid, name, label, p, p.name);
  }
  CIRCUIT.built = `${typeof UNITS !== 'undefined' ? UNITS.system : 'si'}|${S.effects.map((e) => e.name).join(',')}`;
}

/** The fields from S.model (the one being typed into is left alone) and the schematic. */
function refreshCircuit() {
  const box = document.getElementById('circuit-fields');
  if (!box || !S.model || !S.effects.length) return;
  const sig = `${typeof UNITS !== 'undefined' ? UNITS.system : 'si'}|${S.effects.map((e) => e.name).join(',')}`;
  if (CIRCUIT.built !== sig) buildCircuitPanel();
  const effs = S.model.effects || {};
  for (const el of box.querySelectorAll('input[data-circuit]')) {
    if (el === document.activeElement) continue;
    const [name, param] = el.dataset.circuit.split('.');
    const v = effs[name] ? effs[name][param] : undefined;
    el.value = v === undefined ? '' : displayValue(v, Number(el.dataset.scale));
    // a parameter with no "off" value (a bore, a critical ratio) alone cannot add its effect
    el.disabled = !effs[name] && !el.placeholder;
  }
  drawCircuitSchematic();
}

function drawCircuitSchematic() {
  const holder = document.getElementById('schematic');
  if (!holder || !S.model) return;
  // the SI unit of a parameter path, as the service gives it (GET /api/units)
  const unitOf = (path) => (S.units && ((S.units.parameters || {})[path] || (S.units.fields || {})[`model.${path}`])) || '';
  const show = (v, path) => {
    const si = unitOf(path);
    if (!si || si === '-') return String(+v.toPrecision(3));
    const d = circuitShow(si);
    return `${+((v - (d.offset || 0)) / d.scale).toPrecision(3)} ${prettyUnit(d.unit)}`;
  };
  holder.replaceChildren(drawSchematic(S.model, { show }));
}

function onCircuitInput(ev) {
  const el = ev.target.closest('input[data-circuit]');
  if (!el) return;
  const [name, param] = el.dataset.circuit.split('.');
  const cat = catalog(name);
  if (!cat) return;
  const meta = cat.parameters.find((p) => p.name === param);
  const effs = S.model.effects || (S.model.effects = {});
  const raw = el.value.trim();
  let v;
  if (raw === '') {
    if (!effs[name]) return;
    v = circuitOff(meta);
  } else {
    v = Number(raw);
    if (!Number.isFinite(v)) return;   // a number input holds a number or nothing
    const scale = Number(el.dataset.scale || 1);
    v = scale === 1 ? v : +(v * scale).toPrecision(12);
  }
  let changed = false;
  if (!effs[name]) {
    const params = {};
    for (const p of cat.parameters) params[p.name] = circuitOff(p);
    effs[name] = params;
    changed = true;
  }
  effs[name][param] = v;
  const withOff = cat.parameters.filter((p) => p.off !== null && p.off !== undefined);
  if (withOff.length && withOff.every((p) => effs[name][p.name] === p.off)) {
    delete effs[name];
    changed = true;
  }
  clearFieldError(el);
  if (changed) {
    renderEffects();   // the effect list shows it; calls refreshCircuit
    setStatus(effs[name] ? `Effect ${name} added from the circuit panel.` : `Effect ${name} removed: every port is off.`, 'ok');
  } else {
    const twin = document.getElementById(`eff-${name}-${param}`);
    if (twin) twin.value = displayValue(v, 1);
    drawCircuitSchematic();
  }
  markStaleComparison();
}

function initCircuit() {
  const box = document.getElementById('circuit-fields');
  if (box) box.addEventListener('input', onCircuitInput);
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', initCircuit); else initCircuit();
