'use strict';
/* The circuit of a model drawn as an ISO 1219-1 schematic (an SVG element), from the model's
 * JSON alone: drawSchematic(model, opts) -> <svg>. Pure: it reads nothing else of the page and
 * writes nothing; every text of the model (names, kinds, effect names) becomes a text node,
 * never markup (document.createElementNS / textContent only).
 *
 * What is drawn, each as a group with an id and a <title> (ISO 1219-1 symbol named there):
 *   #schem-cylinder      double-acting cylinder (4/2 valve, or a 3/2 valve whose chamber B is
 *                        held or closed) or single-acting (3/2 valve, chamber B vented or vented
 *                        through a restriction); a rod on each side where rod_a > 0
 *   #schem-spring        the return_spring effect, in chamber B (its force points towards x = 0)
 *   #schem-cushion-a/-b  the end_cushion effect's ends (adjustable cushion: rectangle + arrow)
 *   #schem-valve         the directional valve by valve.kind: 4/2 or 3/2 boxes with flow arrows,
 *                        solenoid and spring return; another kind: one box naming it
 *   #schem-proportional  inside #schem-valve, when the valve is proportional (a port's table
 *                        gives C at more than two openings: it meters by opening, where a
 *                        switching valve's table is a step): ISO 1219-1's marking, two lines
 *                        parallel to the envelope's long sides ("infinite positioning") and the
 *                        proportional solenoid, an arrow through the solenoid (as described in
 *                        huadeonline.com "Proportional Valve Symbols Explained", citing ISO 1219-1)
 *   #schem-supply        the pneumatic pressure source on P, with its pressure
 *   #schem-exhaust       the exhaust on R, #schem-silencer when exhaust_silencer is on: a square
 *                        at 45 deg with its port on a corner, ISO 1219-1's shape of a conditioning
 *                        apparatus (CETOP RP 68 P symbol guide, after ISO 1219-1:1991: "square at
 *                        45 deg, conditioning apparatus, connections to corners"); the three lines
 *                        inside are this drawing's, the material found gives no inner detail
 *   #schem-tube-a/-b     the tubing effect on a port: a working line labelled length and bore
 *   #schem-meter-out-a/-b, #schem-meter-in-a/-b
 *                        one-way flow controls (throttle in parallel with a check valve; the
 *                        check valve's free flow towards the chamber for meter-out, away from
 *                        it for meter-in)
 *   #schem-b-vent, #schem-b-closed, #schem-b-held, #schem-b-restriction
 *                        chamber B's port on a 3/2 valve (valve.b_chamber)
 *   #schem-angle         the mounting angle (jack.mounting_angle, 0 horizontal, 90 rod up): the
 *                        cylinder, its spring and cushions are drawn rotated by it (#schem-jack,
 *                        about the cylinder's centre, the drawing made taller to hold it), the
 *                        angle marked from a horizontal through the centre, and g
 *   #schem-others        every other effect of the model, by name, as text
 *
 * The expected end_cushion shape (the effect is added by issue 23 item 4; drawn when present):
 * parameters per end with the suffix _a (the end at x = 0) and _b (x = stroke), e.g. length_a,
 * volume_a, conductance_a; an end is drawn when its length_{a,b} > 0, or, with no length
 * parameter, when any of its numeric _a/_b parameters is non-zero. Any unknown effect, or an
 * effect whose parameters are not the expected ones, is listed by name and never breaks the
 * drawing.
 *
 * opts.show(value, path) -> text formats a value in SI of the model's parameter `path` (e.g.
 * 'effects.tubing.length_a', 'supply.pressure'); the page gives it the unit of that path from
 * GET /api/units and shows it in its unit system (static/circuit.js). The default writes the
 * SI number alone: this module holds no unit.
 */

const SVG_NS = 'http://www.w3.org/2000/svg';
const SCHEM_W = 500;
const SCHEM_H = 420;
// the effects this module draws; any other effect is listed in #schem-others
const SCHEM_DRAWN = ['tubing', 'meter_out_throttle', 'meter_in_throttle', 'exhaust_silencer', 'return_spring', 'end_cushion'];
// chamber B of a 3/2 valve that leaves the cylinder single-acting (no air driving it back)
const SINGLE_ACTING_B = ['vented', 'restriction'];

// presentation attributes by class (attributes, not inline styles: the page's CSP and no
// edit of app.css); a line or path without a class is a working line
const SCHEM_PAINT = {
  'schem-open': { fill: 'none', stroke: '#222', 'stroke-width': 1.3 },
  'schem-fill': { fill: '#222', stroke: 'none' },
  'schem-enclosure': { fill: 'none', stroke: '#555', 'stroke-width': 0.9, 'stroke-dasharray': '6 2 1 2' },
  'schem-dashed': { stroke: '#888', 'stroke-width': 1, 'stroke-dasharray': '3 3' },
  'schem-axis': { stroke: '#222', 'stroke-width': 1.6 },
  'schem-tube-line': { stroke: '#1f5fa8', 'stroke-width': 3 },
  'schem-label': { fill: '#222', 'font-size': 11, 'font-family': 'sans-serif', stroke: 'none' },
};
function schemEl(tag, attrs, parent) {
  const e = document.createElementNS(SVG_NS, tag);
  const a = Object.assign({}, attrs || {});
  const cls = String(a.class || '').split(/\s+/).find((c) => SCHEM_PAINT[c]);
  const paint = cls ? SCHEM_PAINT[cls] : ((tag === 'line' || tag === 'path') ? { fill: 'none', stroke: '#222', 'stroke-width': 1.3 } : {});
  for (const [k, v] of Object.entries(Object.assign({}, paint, a))) e.setAttribute(k, String(v));
  if (parent) parent.appendChild(e);
  return e;
}
function schemText(parent, x, y, text, attrs = {}) {
  const t = schemEl('text', Object.assign({ x, y, class: 'schem-label' }, attrs), parent);
  t.textContent = String(text);
  return t;
}
function schemGroup(parent, id, title, cls = '') {
  const g = schemEl('g', { id, class: `schem-symbol ${cls}`.trim() }, parent);
  schemEl('title', {}, g).textContent = title;
  return g;
}
function schemLine(parent, x1, y1, x2, y2, attrs = {}) {
  return schemEl('line', Object.assign({ x1, y1, x2, y2 }, attrs), parent);
}
function schemPath(parent, d, attrs = {}) { return schemEl('path', Object.assign({ d }, attrs), parent); }
function schemNum(x) { return typeof x === 'number' && Number.isFinite(x) ? x : null; }
function schemDefaultShow(v) { return String(+v.toPrecision(3)); }

/** An arrow head at (x, y) pointing along (dx, dy) (unit vector), filled. */
function schemArrowHead(parent, x, y, dx, dy, size = 5) {
  const px = -dy;
  const py = dx;
  const bx = x - dx * size;
  const by = y - dy * size;
  schemPath(parent, `M${x},${y} L${bx + px * size * 0.5},${by + py * size * 0.5} L${bx - px * size * 0.5},${by - py * size * 0.5} Z`,
    { class: 'schem-fill' });
}
/** A flow arrow inside a valve box, from (x1, y1) to (x2, y2). */
function schemFlow(parent, x1, y1, x2, y2) {
  schemLine(parent, x1, y1, x2, y2);
  const L = Math.hypot(x2 - x1, y2 - y1);
  schemArrowHead(parent, x2, y2, (x2 - x1) / L, (y2 - y1) / L);
}
/** A blocked port inside a valve box: a T at (x, y), the stem going `dir` (+1 down, -1 up). */
function schemBlocked(parent, x, y, dir) {
  schemLine(parent, x, y, x, y + 8 * dir);
  schemLine(parent, x - 5, y + 8 * dir, x + 5, y + 8 * dir);
}
/** A spring (zigzag) from (x1, y) to (x2, y), amplitude a. */
function schemZigzag(parent, x1, y, x2, a, n = 8, attrs = {}) {
  let d = `M${x1},${y}`;
  for (let i = 1; i <= n; i++) d += ` L${x1 + ((x2 - x1) * i) / n},${y + (i === n ? 0 : (i % 2 ? -a : a))}`;
  return schemPath(parent, d, Object.assign({ class: 'schem-open' }, attrs));
}
/** An open (pneumatic) exhaust triangle, apex down, its top at (x, y). */
function schemExhaustTriangle(parent, x, y) {
  schemPath(parent, `M${x - 6},${y} L${x + 6},${y} L${x},${y + 9} Z`, { class: 'schem-open' });
}
/** A throttle (restriction) on a vertical line centred at (x, y): two arcs facing each other,
 * with the adjustability arrow when `adjustable`. */
function schemThrottle(parent, x, y, adjustable = true) {
  schemPath(parent, `M${x - 5},${y - 9} Q${x + 1},${y} ${x - 5},${y + 9}`, { class: 'schem-open' });
  schemPath(parent, `M${x + 5},${y - 9} Q${x - 1},${y} ${x + 5},${y + 9}`, { class: 'schem-open' });
  if (adjustable) {
    schemLine(parent, x - 9, y + 9, x + 8, y - 8);
    schemArrowHead(parent, x + 9, y - 9, Math.SQRT1_2, -Math.SQRT1_2, 4);
  }
}
/** A check valve on a vertical line centred at (x, y): ball in a V seat; free flow upward
 * when `freeUp` (the seat's apex below the ball), downward otherwise. */
function schemCheck(parent, x, y, freeUp) {
  const s = freeUp ? 1 : -1;   // +1: apex below
  schemPath(parent, `M${x - 6},${y - 3 * s} L${x},${y + 7 * s} L${x + 6},${y - 3 * s}`, { class: 'schem-open schem-check-seat', 'data-apex-y': y + 7 * s });
  schemEl('circle', { cx: x, cy: y - 3 * s, r: 4, class: 'schem-open schem-check-ball' }, parent);
}
/** The ISO 1219-1 one-way flow control on the vertical line x between y1 and y2 (y1 above). */
function schemFlowControl(parent, x, yc, freeUp) {
  schemLine(parent, x, yc - 24, x, yc - 14);
  schemLine(parent, x, yc + 14, x, yc + 24);
  schemLine(parent, x - 10, yc - 14, x + 10, yc - 14);
  schemLine(parent, x - 10, yc + 14, x + 10, yc + 14);
  schemLine(parent, x - 10, yc - 14, x - 10, yc - 9);
  schemLine(parent, x - 10, yc + 9, x - 10, yc + 14);
  schemThrottle(parent, x - 10, yc);
  schemLine(parent, x + 10, yc - 14, x + 10, yc - 9);
  schemLine(parent, x + 10, yc + 9, x + 10, yc + 14);
  schemCheck(parent, x + 10, yc, freeUp);
  schemEl('rect', { x: x - 20, y: yc - 20, width: 40, height: 40, class: 'schem-enclosure' }, parent);
}

/** Which ends of the cylinder have a cushion, from the end_cushion effect (see the header). */
function schemCushionEnds(p) {
  const ends = [];
  if (!p || typeof p !== 'object') return ends;
  for (const end of ['a', 'b']) {
    const len = schemNum(p[`length_${end}`]);
    if (len !== null) { if (len > 0) ends.push(end); continue; }
    const any = Object.entries(p).some(([k, v]) => k.endsWith(`_${end}`) && schemNum(v) !== null && v !== 0);
    if (any) ends.push(end);
  }
  return ends;
}
/** A proportional valve: a port's table gives its conductance at more than two openings. */
function schemProportional(valve) {
  const ports = valve && typeof valve.ports === 'object' && valve.ports ? valve.ports : {};
  return Object.values(ports).some((p) => p && Array.isArray(p.opening) && p.opening.length > 2);
}
/** A point (x, y) rotated by th [rad] counter-clockwise on the page about (ox, oy). */
function schemRotate(x, y, ox, oy, th) {
  const c = Math.cos(th); const s = Math.sin(th);
  return [ox + (x - ox) * c + (y - oy) * s, oy - (x - ox) * s + (y - oy) * c];
}
function schemPortOn(p, key) { return !!p && typeof p === 'object' && (schemNum(p[key]) || 0) > 0; }

/**
 * The model's circuit as an ISO 1219-1 schematic.
 *
 * @param {object} model  the model as the API takes it (jack, valve, supply, effects, ...)
 * @param {object} [opts] {show(value, parameterPath) -> text}
 * @returns {SVGSVGElement} the drawing, with data-valve, data-cylinder and data-effects set
 */
function drawSchematic(model, opts = {}) {
  const show = (v, path) => (schemNum(v) === null ? '?' : (opts.show || schemDefaultShow)(v, path));
  const m = model && typeof model === 'object' ? model : {};
  const jack = m.jack || {};
  const valve = m.valve || {};
  const effects = m.effects && typeof m.effects === 'object' ? m.effects : {};
  const kind = typeof valve.kind === 'string' ? valve.kind : '?';
  const bMode = typeof valve.b_chamber === 'string' ? valve.b_chamber : 'held';
  const threeWay = kind === '3/2';
  const singleActing = threeWay && SINGLE_ACTING_B.includes(bMode);
  const proportional = schemProportional(valve);
  const ang = Math.max(-90, Math.min(90, schemNum(jack.mounting_angle) || 0));
  const th = (ang * Math.PI) / 180;

  const svg = schemEl('svg', {
    xmlns: SVG_NS, viewBox: `0 0 ${SCHEM_W} ${SCHEM_H}`, class: 'schematic', role: 'img',
    'data-valve': kind, 'data-cylinder': singleActing ? 'single-acting' : 'double-acting',
    'data-effects': Object.keys(effects).join(' '), 'data-proportional': String(proportional),
    'data-angle': String(ang),
  });
  schemEl('title', {}, svg).textContent = `Circuit (ISO 1219-1): ${kind} valve, ${singleActing ? 'single' : 'double'}-acting cylinder` +
    (Object.keys(effects).length ? `, effects: ${Object.keys(effects).join(', ')}` : '');

  // ---------------------------------------------------------------- cylinder, at the mounting angle
  const cx0 = 110; const cx1 = 330; const cy0 = 40; const cy1 = 90; const axis = (cy0 + cy1) / 2;
  const pistonX = cx0 + 0.35 * (cx1 - cx0);
  const portA = 130; const portB = 310;
  // the jack (cylinder, rod, mass) rotated about the cylinder's centre: the drawing grows above
  // by what the rotated jack needs (`top`) and the lines start below it (`drop`)
  const mid = (cx0 + cx1) / 2;
  // (its box: rod end to mass, the labels above it and the mass's below it)
  const jy0 = cy0 - 18; const jy1 = axis + 34;
  const corners = [[cx0 - 30, jy0], [cx1 + 80, jy0], [cx0 - 30, jy1], [cx1 + 80, jy1]].map(([x, y]) => schemRotate(x, y, mid, axis, th)[1]);
  const top = Math.ceil(Math.max(0, 4 - Math.min(...corners)));
  const drop = Math.ceil(Math.max(0, Math.max(...corners) + 4 - cy1));
  svg.setAttribute('viewBox', `0 0 ${SCHEM_W} ${SCHEM_H + top + drop}`);
  const root = schemEl('g', { transform: `translate(0 ${top})` }, svg);
  const jackG = schemEl('g', { id: 'schem-jack', transform: `rotate(${-ang} ${mid} ${axis})` }, root);
  const cyl = schemGroup(jackG, 'schem-cylinder', `${singleActing ? 'Single' : 'Double'}-acting cylinder (ISO 1219-1), ` +
    `bore ${show(jack.bore, 'jack.bore')}, stroke ${show(jack.stroke, 'jack.stroke')}`, singleActing ? 'single-acting' : 'double-acting');
  schemEl('rect', { x: cx0, y: cy0, width: cx1 - cx0, height: cy1 - cy0, class: 'schem-open' }, cyl);
  schemEl('rect', { x: pistonX, y: cy0, width: 8, height: cy1 - cy0, class: 'schem-fill' }, cyl);
  schemEl('rect', { x: pistonX + 8, y: axis - 4, width: cx1 + 50 - pistonX - 8, height: 8, class: 'schem-open' }, cyl);
  if ((schemNum(jack.rod_a) || 0) > 0) schemEl('rect', { x: cx0 - 30, y: axis - 4, width: pistonX - cx0 + 30, height: 8, class: 'schem-open' }, cyl);
  schemText(cyl, portA - 12, cy0 - 6, 'A', { class: 'schem-label schem-port' });
  schemText(cyl, portB + 4, cy0 - 6, 'B', { class: 'schem-label schem-port' });
  const mass = schemNum(jack.moving_mass);
  if (mass !== null) {
    schemEl('rect', { x: cx1 + 50, y: axis - 12, width: 24, height: 24, class: 'schem-open' }, cyl);
    schemText(cyl, cx1 + 50, axis + 28, `m ${show(mass, 'jack.moving_mass')}`);
  }

  if (Object.prototype.hasOwnProperty.call(effects, 'return_spring')) {
    const p = effects.return_spring || {};
    const g = schemGroup(jackG, 'schem-spring', `Return spring: rate ${show(p.rate, 'effects.return_spring.rate')}, preload ${show(p.preload, 'effects.return_spring.preload')}`);
    schemZigzag(g, pistonX + 10, axis, cx1 - 2, 18, 10);
    schemText(g, pistonX + 30, cy0 - 6, `spring ${show(p.rate, 'effects.return_spring.rate')}`);
  }
  for (const end of schemCushionEnds(effects.end_cushion)) {
    const p = effects.end_cushion;
    const g = schemGroup(jackG, `schem-cushion-${end}`, `Adjustable end cushion at ${end === 'a' ? 'x = 0 (A)' : 'x = stroke (B)'}` +
      (schemNum(p[`length_${end}`]) !== null ? `, length ${show(p[`length_${end}`], `effects.end_cushion.length_${end}`)}` : ''));
    const x = end === 'a' ? cx0 + 2 : cx1 - 14;
    schemEl('rect', { x, y: axis - 10, width: 12, height: 20, class: 'schem-open schem-cushion' }, g);
    schemLine(g, x - 4, axis + 14, x + 14, axis - 14);
    schemArrowHead(g, x + 15, axis - 15, 0.54, -0.84, 4);
  }

  // the ports on the rotated jack, joined to the lines below it (first away from the cylinder,
  // along its rotated normal, then straight down)
  const below = schemEl('g', { transform: `translate(0 ${drop})` }, root);
  const joinPort = (px, parent) => {
    const [qx, qy] = schemRotate(px, cy1, mid, axis, th);
    const [nx, ny] = [Math.sin(th), Math.cos(th)];   // the cylinder's "down" side, rotated
    schemPath(parent, `M${qx},${qy} L${qx + 10 * nx},${qy + 10 * ny} L${px},${cy1 + drop}`, { class: 'schem-open schem-port-join' });
  };
  const joins = schemEl('g', { id: 'schem-port-joins' }, root);
  joinPort(portA, joins);
  joinPort(portB, joins);

  // ---------------------------------------------------------------- valve
  const vy0 = 290; const vy1 = 340; const vb = 55;  // box top, bottom, width
  const vx = 170;                                   // left box's left edge
  const vg = schemGroup(below, 'schem-valve', `${kind} ${proportional ? 'proportional ' : ''}directional control valve (ISO 1219-1), ` +
    `${proportional ? 'proportional ' : ''}solenoid operated, spring return`, `valve-${kind.replace(/[^\w-]/g, '_')}${proportional ? ' proportional' : ''}`);
  const rA = vx + vb + 15; const rB = vx + 2 * vb - 15;   // the right (normal) box's ports
  const lA = vx + 15; const lB = vx + vb - 15;            // the left (actuated) box's ports
  if (kind === '4/2' || threeWay) {
    schemEl('rect', { x: vx, y: vy0, width: vb, height: vy1 - vy0, class: 'schem-open' }, vg);
    schemEl('rect', { x: vx + vb, y: vy0, width: vb, height: vy1 - vy0, class: 'schem-open' }, vg);
    if (kind === '4/2') {
      // actuated: P -> A, B -> R; normal (spring): P -> B, A -> R
      schemFlow(vg, lA, vy1, lA, vy0); schemFlow(vg, lB, vy0, lB, vy1);
      schemFlow(vg, rA, vy1, rB, vy0); schemFlow(vg, rA, vy0, rB, vy1);
    } else {
      // 3/2 normally closed: actuated P -> A, R blocked; normal A -> R, P blocked
      schemFlow(vg, lA, vy1, lA, vy0); schemBlocked(vg, lB, vy1, -1);
      schemFlow(vg, rA, vy0, rB, vy1); schemBlocked(vg, rA, vy1, -1);
    }
    schemEl('rect', { x: vx - 22, y: vy0 + 14, width: 22, height: 22, class: 'schem-open' }, vg);  // solenoid
    schemLine(vg, vx - 22, vy0 + 36, vx, vy0 + 14);
    schemZigzag(vg, vx + 2 * vb, vy0 + 25, vx + 2 * vb + 30, 7, 6);                                  // spring return
    schemText(vg, vx - 40, vy0 - 6, kind);
    if (proportional) {
      // ISO 1219-1: two lines along the envelope's long sides (the spool meters at any opening)
      // and the proportional solenoid, an arrow through the solenoid's diagonal
      const pg = schemGroup(vg, 'schem-proportional', 'Proportional valve (ISO 1219-1): continuously variable opening, proportional solenoid');
      schemLine(pg, vx, vy0 - 5, vx + 2 * vb, vy0 - 5, { class: 'schem-proportional-line' });
      schemLine(pg, vx, vy1 + 5, vx + 2 * vb, vy1 + 5, { class: 'schem-proportional-line' });
      schemLine(pg, vx - 27, vy0 + 40, vx + 3, vy0 + 10, { class: 'schem-proportional-arrow' });
      schemArrowHead(pg, vx + 5, vy0 + 8, Math.SQRT1_2, -Math.SQRT1_2, 5);
    }
  } else {
    schemEl('rect', { x: vx, y: vy0, width: 2 * vb, height: vy1 - vy0, class: 'schem-open' }, vg);
    schemText(vg, vx + 8, vy0 + 30, `valve ${kind}`);
  }
  schemText(vg, rA - 3, vy1 + 12, 'P', { class: 'schem-label schem-port' });
  schemText(vg, rB + 3, vy1 + 12, 'R', { class: 'schem-label schem-port' });

  // supply on P, exhaust (and silencer) on R
  const sup = schemGroup(below, 'schem-supply', `Pneumatic pressure source (ISO 1219-1), ${show((m.supply || {}).pressure, 'supply.pressure')} absolute`);
  schemLine(sup, rA, vy1, rA, vy1 + 24);
  schemEl('circle', { cx: rA, cy: vy1 + 36, r: 12, class: 'schem-open' }, sup);
  schemPath(sup, `M${rA},${vy1 + 26} L${rA + 6},${vy1 + 36} L${rA - 6},${vy1 + 36} Z`, { class: 'schem-open' });
  schemText(sup, rA - 90, vy1 + 40, `p_s ${show((m.supply || {}).pressure, 'supply.pressure')}`);
  const sil = effects.exhaust_silencer;
  const exh = schemGroup(below, 'schem-exhaust', 'Exhaust to atmosphere (ISO 1219-1)');
  schemLine(exh, rB, vy1, rB, vy1 + 18);
  if (schemPortOn(sil, 'C')) {
    const g = schemGroup(below, 'schem-silencer', `Silencer (ISO 1219-1): C ${show(sil.C, 'effects.exhaust_silencer.C')}, b ${show(sil.b, 'effects.exhaust_silencer.b')}`);
    // a square at 45 deg (ISO 1219-1: conditioning apparatus, connections to corners), the port
    // on its top corner
    schemPath(g, `M${rB},${vy1 + 18} L${rB + 12},${vy1 + 30} L${rB},${vy1 + 42} L${rB - 12},${vy1 + 30} Z`, { class: 'schem-open schem-silencer-body' });
    for (const dy of [25, 30, 35]) { const w = 12 - Math.abs(dy - 30) - 3; schemLine(g, rB - w, vy1 + dy, rB + w, vy1 + dy); }
    schemText(g, rB + 14, vy1 + 34, `silencer ${show(sil.C, 'effects.exhaust_silencer.C')}`);
  } else schemExhaustTriangle(exh, rB, vy1 + 18);

  // ---------------------------------------------------------------- the lines from the ports
  const drawPort = (end, px, toX, turnY) => {
    const tube = effects.tubing;
    const mo = effects.meter_out_throttle;
    const mi = effects.meter_in_throttle;
    const L = tube && typeof tube === 'object' ? schemNum(tube[`length_${end}`]) : null;
    const tubeOn = L !== null && L > 0;
    const line = schemGroup(below, `schem-line-${end}`, `Working line, port ${end.toUpperCase()}`);
    // each control with its volume before the valve (physics.flow_control) sits at the
    // cylinder's port, above the tube; one in series with the valve's edge, below it
    const slots = [];
    for (const [kind, eff] of [['out', mo], ['in', mi]]) {
      if (!schemPortOn(eff, `C_${end}`)) continue;
      const V = schemNum(eff[`volume_${end}`]);
      slots.push([kind, eff[`C_${end}`], V !== null && V > 0 ? V : null]);
    }
    const order = [...slots.filter(s => s[2] !== null), 'tube', ...slots.filter(s => s[2] === null)];
    while (order.length < 3) order.push(null);
    let y = cy1;
    for (const item of order) {
      if (item === 'tube') {
        if (tubeOn) {
          const g = schemGroup(below, `schem-tube-${end}`, `Tube on port ${end.toUpperCase()}: length ${show(L, `effects.tubing.length_${end}`)}, ` +
            `inner diameter ${show(tube[`diameter_${end}`], `effects.tubing.diameter_${end}`)}`, 'schem-tube');
          schemLine(g, px, y, px, y + 50, { class: 'schem-tube-line' });
          schemText(g, px + 8, y + 26, `tube ${show(L, `effects.tubing.length_${end}`)}`);
          schemText(g, px + 8, y + 40, `⌀ ${show(tube[`diameter_${end}`], `effects.tubing.diameter_${end}`)}`);
        } else schemLine(line, px, y, px, y + 50);
        y += 50;
        continue;
      }
      if (!item) { schemLine(line, px, y, px, y + 60); y += 60; continue; }
      const [kind, C, V] = item;
      const yc = y + 30;
      const out = kind === 'out';
      const path = `effects.meter_${kind}_throttle`;
      const where = V !== null ? ` at the cylinder's port, ${show(V, `${path}.volume_${end}`)} between it and the valve`
        : ' in series with the valve\'s edge';
      const g = schemGroup(below, `schem-meter-${kind}-${end}`, `One-way flow control (ISO 1219-1), meter-${kind} on port ` +
        `${end.toUpperCase()}: throttle C ${show(C, `${path}.C_${end}`)} in parallel with a check valve,${where}`, 'schem-flow-control');
      schemLine(g, px, y, px, y + 6);
      schemLine(g, px, y + 54, px, y + 60);
      schemFlowControl(g, px, yc, out);   // meter-out: free flow into the chamber (upward)
      schemText(g, px + 24, yc + 4, `meter-${kind} ${show(C, `${path}.C_${end}`)}`);
      if (V !== null) schemText(g, px + 24, yc + 18, `V ${show(V, `${path}.volume_${end}`)}`);
      y += 60;
    }
    // to the valve port
    schemPath(line, `M${px},${y} L${px},${turnY} L${toX},${turnY} L${toX},${vy0}`, { class: 'schem-open' });
  };
  drawPort('a', portA, rA, 268);
  if (!threeWay) drawPort('b', portB, rB, 278);
  else {
    // chamber B of a 3/2 valve: not connected to the valve
    const id = { vented: 'schem-b-vent', closed: 'schem-b-closed', held: 'schem-b-held', restriction: 'schem-b-restriction' }[bMode] || 'schem-b-other';
    const what = {
      vented: 'Chamber B vented to atmosphere (single-acting)', closed: 'Chamber B closed (an air spring)',
      held: `Chamber B held at ${show(valve.b_chamber_pressure, 'valve.b_chamber_pressure')}`, restriction: 'Chamber B vented through a fixed restriction',
    }[bMode] || `Chamber B: ${bMode}`;
    const g = schemGroup(below, id, what);
    schemLine(g, portB, cy1, portB, cy1 + 20);
    if (bMode === 'vented') schemExhaustTriangle(g, portB, cy1 + 20);
    else if (bMode === 'closed') schemLine(g, portB - 8, cy1 + 20, portB + 8, cy1 + 20);
    else if (bMode === 'restriction') { schemThrottle(g, portB, cy1 + 30, false); schemLine(g, portB, cy1 + 39, portB, cy1 + 44); schemExhaustTriangle(g, portB, cy1 + 44); } else {
      schemEl('circle', { cx: portB, cy: cy1 + 32, r: 12, class: 'schem-open' }, g);
      schemPath(g, `M${portB},${cy1 + 22} L${portB + 6},${cy1 + 32} L${portB - 6},${cy1 + 32} Z`, { class: 'schem-open' });
    }
    schemText(g, portB + 16, cy1 + 30, bMode);
  }

  // ---------------------------------------------------------------- mounting angle and gravity
  // marked on the rotated jack: a horizontal through the cylinder's centre, the arc to its axis
  const ag = schemGroup(root, 'schem-angle', `Mounting angle ${+ang.toPrecision(4)} deg (0 horizontal, 90 rod up); ` +
    'the cylinder is drawn at it; gravity on the moving mass');
  const ar = 40;
  if (ang !== 0) {
    schemLine(ag, mid, axis, mid + ar + 20, axis, { class: 'schem-dashed' });
    schemPath(ag, `M${mid + ar},${axis} A${ar},${ar} 0 0 ${ang > 0 ? 0 : 1} ${mid + ar * Math.cos(th)},${axis - ar * Math.sin(th)}`,
      { class: 'schem-open schem-angle-arc' });
    schemText(ag, mid + ar + 6, axis + (ang > 0 ? 14 : -6), `${+ang.toPrecision(4)}°`, { class: 'schem-label schem-angle-label' });
  } else schemText(ag, cx1 + 6, cy0 - 6, '0°', { class: 'schem-label schem-angle-label' });   // horizontal
  const gx = 24; const gy = Math.max(axis - 30, 4 - top);
  schemLine(ag, gx, gy, gx, gy + 34);
  schemArrowHead(ag, gx, gy + 36, 0, 1);
  schemText(ag, gx + 6, gy + 22, 'g');

  // ---------------------------------------------------------------- every other effect, by name
  const others = Object.keys(effects).filter((n) => !SCHEM_DRAWN.includes(n));
  const og = schemGroup(root, 'schem-others', others.length ? `Effects not drawn: ${others.join(', ')}` : 'No other effect');
  if (others.length) schemText(og, 10, SCHEM_H + drop - 8, `+ ${others.join(', ')}`, { class: 'schem-label schem-others' });
  return svg;
}
