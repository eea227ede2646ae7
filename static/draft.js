'use strict';
/* Unsaved model edits survive a reload (issue 24): a draft of the model being edited.
 *
 * - The draft is the page's model whenever it differs from the last one loaded or stored (a
 *   preset, a stored session's version, a version just recorded): kept in this tab's
 *   sessionStorage (one per tab, so two tabs do not overwrite each other's edits), written a
 *   moment after each edit and when the page is left; removed once the model is back to the
 *   stored one.
 * - On a reload it is read back, checked as a pasted model is (shape here, then the service's
 *   own rules: POST /api/calibrate/parameters) and put back, with "Restored unsaved edits …
 *   Discard" in the nav; Discard brings back the model the page would have shown.
 * - A stored session named by the address wins: its model is shown, and the draft is only
 *   offered ("Restore them" / "Discard").
 * - A draft that cannot be read or that the service refuses is never applied; the nav says why
 *   (as text). Nothing read from the storage reaches the HTML: the model goes through the
 *   panels' own rendering, the messages are textContent.
 * workspace.js calls modelDraft.restore() once the page is ready and the address's session
 * opened; model.js and history.js call modelDraft.markClean() when a model is loaded or stored.
 * Loaded before them and app.js (index.html), so that modelDraft exists before the first model
 * is loaded.
 */
(function modelDraft() {
  const KEY = 'pneucore.modelDraft';
  const FORMAT = 1;                 // the draft's layout: {v, at, model}
  const SAVE_DELAY_MS = 300;        // after the last edit: one write per pause in typing
  const MAX_CHARS = 2_000_000;      // far above any model the page makes (~10 kB): refused unread
  let clean = null;                 // JSON of the model as last loaded or stored
  let ready = false;                // nothing is written before the stored draft was read
  let offered = null;               // a draft shown in the nav but not applied (session won, or refused)
  let timer = 0;

  function storage() { try { return window.sessionStorage; } catch (e) { return null; } }
  function drop() { const st = storage(); try { if (st) st.removeItem(KEY); } catch (e) { /* refused */ } }
  function bar(msg, { restore = false } = {}) {
    const box = document.getElementById('draft-bar');
    if (!box) return;
    box.hidden = msg == null;
    document.getElementById('draft-msg').textContent = msg || '';
    document.getElementById('btn-draft-restore').hidden = !restore;
  }
  function clock(at) { return new Date(at).toLocaleTimeString(); }

  /** Write the draft now (or remove it when the model is the stored one). */
  function save() {
    clearTimeout(timer);
    if (!ready || typeof S === 'undefined' || !S.model) return;
    const now = JSON.stringify(S.model);
    const st = storage();
    if (now === clean) {
      if (!offered) { drop(); bar(null); }   // saved or undone: nothing unsaved any more
      return;
    }
    if (offered) { offered = null; bar(null); }   // edited again: this draft replaces the one offered
    try { if (st) st.setItem(KEY, JSON.stringify({ v: FORMAT, at: Date.now(), model: S.model })); } catch (e) { /* full or refused */ }
  }
  function later() { clearTimeout(timer); if (ready) timer = setTimeout(save, SAVE_DELAY_MS); }

  /** The model as loaded or stored now (a preset, a session's version): the one edits differ from. */
  function markClean(model) {
    clean = model == null ? null : JSON.stringify(model);
    later();
  }

  /** The stored draft, checked for shape: {draft} or {error} (a reason, as text), or null. */
  function read() {
    const st = storage();
    let raw = null;
    try { raw = st ? st.getItem(KEY) : null; } catch (e) { raw = null; }
    if (raw == null) return null;
    if (raw.length > MAX_CHARS) return { error: `it is ${raw.length} characters long` };
    let d;
    try { d = JSON.parse(raw); } catch (e) { return { error: 'it is not JSON' }; }
    const ok = d && typeof d === 'object' && d.v === FORMAT && Number.isFinite(d.at) &&
      d.model && typeof d.model === 'object' && !Array.isArray(d.model);
    return ok ? { draft: d } : { error: 'it is not a draft this page wrote' };
  }

  /** Check a draft's model with the service and put it on the page; false (said in the nav) if refused. */
  async function apply(d) {
    try {
      await api('POST', '/api/calibrate/parameters', { model: d.model });
    } catch (e) {
      const why = e instanceof ApiError && Array.isArray(e.detail)
        ? e.detail.slice(0, 3).map((x) => `${x.field || (x.loc || []).join('.')}: ${x.msg}`).join('; ')
        : (e && e.message) || String(e);
      offered = d;
      bar(`Unsaved model edits from ${clock(d.at)} were not restored: the service refuses them (${why}).`);
      return false;
    }
    offered = null;
    S.model = clone(d.model);
    renderModel();
    markStaleComparison();
    if (typeof refreshCircuit === 'function') refreshCircuit();
    bar(`Restored unsaved edits of the model from ${clock(d.at)}.`);
    return true;
  }

  /** After a reload: put the draft back, or offer it when the address's session opened (it wins). */
  async function restore(sessionWon) {
    try {
      const r = read();
      if (!r) return;
      if (r.error) {
        drop();
        bar(`Unsaved model edits kept by this tab could not be read (${r.error}); they were dropped.`);
        return;
      }
      const d = r.draft;
      if (JSON.stringify(d.model) === clean) { drop(); return; }
      if (sessionWon) {
        offered = d;
        bar(`Unsaved model edits from ${clock(d.at)} were not restored: the address names a stored session, whose model is shown.`, { restore: true });
        return;
      }
      await apply(d);
    } finally {
      ready = true;
    }
  }

  /** Discard: the draft is gone and the model is the one loaded or stored. */
  function discard() {
    const wasApplied = !offered && clean != null && JSON.stringify(S.model) !== clean;
    offered = null;
    drop();
    bar(null);
    if (wasApplied) {
      S.model = JSON.parse(clean);
      renderModel();
      markStaleComparison();
      if (typeof refreshCircuit === 'function') refreshCircuit();
    }
    setStatus(wasApplied ? 'Unsaved model edits discarded: the model is the one loaded or stored before them.'
      : 'Unsaved model edits discarded.', 'info');
  }

  function wireDraft() {
    document.getElementById('btn-draft-discard').addEventListener('click', discard);
    document.getElementById('btn-draft-restore').addEventListener('click', async (ev) => {
      const d = offered;
      if (d) await busy(ev.target, () => apply(d));
    });
    // any edit (a field, a row, an effect, a file) may change the model: written once typing pauses
    for (const type of ['input', 'change', 'click']) document.addEventListener(type, later, true);
    window.addEventListener('pagehide', save);
    document.addEventListener('visibilitychange', () => { if (document.visibilityState === 'hidden') save(); });
  }
  window.modelDraft = { restore, markClean, save, discard };
  if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', wireDraft); else wireDraft();
}());
