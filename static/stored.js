'use strict';
/* Stored data: the datasets, refinement sessions and studies kept in the service's database,
 * listed with a Delete button each (DELETE /api/datasets|sessions|studies/{id}), a session with an
 * Open button (its model, experiments and history back on the page). Names are
 * user text: inserted with textContent only. */

const STORED_KINDS = [
  ['datasets', 'Datasets', (d) => `${d.name} — ${d.n_samples} samples, ${(d.signals || []).join(', ')}${d.sample ? ' (sample)' : ''}`],
  ['sessions', 'Refinement sessions', (s) => `${s.name} — ${s.n_versions} version${s.n_versions === 1 ? '' : 's'}`],
  ['studies', 'Robustness studies', (s) => `${s.name || s.id} — ${s.status || ''}${s.n_runs != null ? `, ${s.n_runs} runs` : ''}`],
];

async function loadStored() {
  const target = $('#stored-lists');
  const box = document.createElement('div');   // filled off-page, swapped in at once
  for (const [kind, title, describe] of STORED_KINDS) {
    const h = document.createElement('h3'); h.textContent = title; box.appendChild(h);
    let list = [];
    try { list = await api('GET', `/api/${kind}`); } catch (e) { showApiError(e, `Listing ${kind}`); continue; }
    const ul = document.createElement('ul');
    ul.className = 'stored-list';
    ul.dataset.kind = kind;
    if (!list.length) { const li = document.createElement('li'); li.className = 'muted small'; li.textContent = 'none'; ul.appendChild(li); }
    for (const item of list) {
      const li = document.createElement('li');
      li.dataset.id = item.id;
      const span = document.createElement('span'); span.textContent = `${describe(item)} `;
      const btn = document.createElement('button');
      btn.type = 'button'; btn.textContent = 'Delete'; btn.className = 'stored-delete';
      btn.dataset.kind = kind; btn.dataset.id = item.id;
      li.append(span);
      if (kind === 'sessions') {   // a stored session is reopened here: its model, experiments and history
        const open = document.createElement('button');
        open.type = 'button'; open.textContent = 'Open'; open.className = 'stored-open';
        open.dataset.id = item.id;
        li.append(open, ' ');
      }
      li.append(btn);
      ul.appendChild(li);
    }
    box.appendChild(ul);
  }
  target.replaceChildren(...box.childNodes);
  target.dataset.loads = String(Number(target.dataset.loads || 0) + 1);
}

async function openStored(ev) {
  const btn = ev.target.closest('.stored-open');
  if (!btn) return false;
  await busy(btn, async () => {
    try { await openSession(btn.dataset.id); } catch (e) { showApiError(e, 'Opening the session'); }
  });
  return true;
}

async function deleteStored(ev) {
  if (await openStored(ev)) return;
  const btn = ev.target.closest('.stored-delete');
  if (!btn) return;
  const { kind, id } = btn.dataset;
  if (!window.confirm(`Delete ${kind.replace(/s$/, '')} ${id}? This cannot be undone.`)) return;
  await busy(btn, async () => {
    try {
      await api('DELETE', `/api/${kind}/${encodeURIComponent(id)}`);
      setStatus(`Deleted ${kind.replace(/s$/, '')} ${id}.`, 'ok');
      if (kind === 'datasets' && typeof loadDatasets === 'function') await loadDatasets();
      if (kind === 'studies' && typeof loadStudies === 'function') await loadStudies();
      await loadStored();
    } catch (e) { showApiError(e, 'Delete'); }
  });
}

function wireStored() {
  const box = $('#stored-box');
  box.addEventListener('toggle', () => { if (box.open) loadStored(); });
  $('#stored-lists').addEventListener('click', deleteStored);
  $('#btn-stored-refresh').addEventListener('click', loadStored);
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', wireStored); else wireStored();
