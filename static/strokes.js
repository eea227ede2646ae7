'use strict';
/* The stroke metrics of the last simulation (stats.stroke.strokes, pneucore/analysis/strokes.py after
 * SMC's definitions) as a table in the plots panel, one row per valve switching. The columns,
 * their units and definitions come from GET /api/units ("stroke", S.units: the page holds no
 * list of its own); each value shows in the page's unit system (static/units.js). Loaded after
 * app.js; app.js's plotSimulation calls renderStrokeTable. Every value goes in through
 * textContent. */

function strokeCell(tag, text, title) {
  const c = document.createElement(tag);
  c.textContent = text;
  if (title) c.title = title;
  if (tag === 'th') c.scope = 'col';
  return c;
}

function renderStrokeTable(stroke) {
  const box = document.getElementById('stroke-table');
  if (!box) return;
  box.replaceChildren();
  const rows = stroke && Array.isArray(stroke.strokes) ? stroke.strokes : [];
  const fields = (S.units && S.units.stroke) || {};
  if (!rows.length || !Object.keys(fields).length) return;
  const cols = Object.entries(fields).map(([name, f]) => {
    const d = f.unit === '-' || typeof unitShow !== 'function' ? { unit: f.unit, scale: 1, offset: 0 } : unitShow(f.unit);
    return { name, d, description: f.description };
  });
  const table = document.createElement('table');
  table.className = 'data';
  table.id = 'stroke-metrics';
  const cap = document.createElement('caption');
  cap.textContent = 'Stroke metrics of this simulation (SMC\'s definitions), one row per valve switching';
  const head = document.createElement('tr');
  for (const c of cols) head.appendChild(strokeCell('th', `${c.name.replace(/_/g, ' ')} [${prettyUnit(c.d.unit)}]`, c.description));
  const thead = document.createElement('thead');
  thead.appendChild(head);
  const tbody = document.createElement('tbody');
  for (const r of rows) {
    const tr = document.createElement('tr');
    tr.dataset.direction = String(r.direction);
    for (const c of cols) {
      const v = r[c.name];
      const text = typeof v === 'number' ? String(+((v - (c.d.offset || 0)) / c.d.scale).toPrecision(4)) : (v == null ? '–' : String(v));
      const td = strokeCell('td', text);
      td.dataset.metric = c.name;
      if (typeof v === 'number') td.className = 'num';
      tr.appendChild(td);
    }
    tbody.appendChild(tr);
  }
  table.append(cap, thead, tbody);
  box.appendChild(table);
}
