'use strict';
/* The page as one workspace with a view per step of the work (issue 24): model and circuit,
 * scenario and simulation, data, step-by-step identification, compare, diagnose and refine,
 * heat models, studies, sizing; plus "all", every panel on one page.
 *
 * - The views are the links of #workspace-nav (their data-view); an element with
 *   data-views="a b" is shown in views a and b (and in "all"), hidden in the others.
 * - The view and the session are in the address: #view=diagnose&session=ID. A link opens
 *   that view and that stored session; a reload reopens it. Without a view in the address
 *   the last one used on this browser opens (localStorage), else the model.
 * - In the Diagnose view the residual plot is moved beside the findings (#diag-residual-slot);
 *   in every other view it is back under the comparison plot (#residual-home).
 * - Plotly plots drawn while their view was hidden are resized when it is shown.
 * Nothing read from the address reaches the HTML: the view must be one of the nav's names,
 * the session id must match SESSION_ID, and both are only ever written as text.
 */
(function workspace() {
  const VIEW_KEY = 'pneucore.view';
  const DEFAULT_VIEW = 'model';
  // the service's session ids are hex strings; anything else in a link is refused before a request
  // the least height of the residual plot fitted to the Diagnose view [px]: one experiment's plot
  const MIN_RESIDUAL_H = 260;
  const SESSION_ID = /^[A-Za-z0-9_-]{1,64}$/;
  const nav = document.getElementById('workspace-nav');
  const links = Array.from(nav.querySelectorAll('a[data-view]'));
  const VIEWS = new Map(links.map((a) => [a.dataset.view, a.textContent.trim()]));

  /** The view and session named by the address (unchecked strings or null). */
  function fromHash() {
    const q = new URLSearchParams(location.hash.replace(/^#/, ''));
    return { view: q.get('view'), session: q.get('session') };
  }
  function currentSessionId() {
    return typeof S !== 'undefined' && S.session ? S.session.id : null;
  }
  function hashFor(view, session) {
    const q = new URLSearchParams();
    q.set('view', view);
    if (session) q.set('session', session);
    return `#${q.toString()}`;
  }
  function whenReady(fn) {
    if (document.body.dataset.ready) { fn(); return; }
    const t = setInterval(() => { if (document.body.dataset.ready) { clearInterval(t); fn(); } }, 50);
  }
  // what the address asked for and could not be done, said together in the status bar (as text)
  const problems = [];
  function sayProblems() {
    if (problems.length && typeof setStatus === 'function') setStatus(problems.join(' '), 'error');
  }

  /** Show one view: hide every [data-views] element that is not in it, mark the nav, move the
   * residual plot, resize the plots now shown. */
  function show(view) {
    document.body.dataset.view = view;
    for (const el of document.querySelectorAll('[data-views]')) {
      el.hidden = !(view === 'all' || el.dataset.views.split(/\s+/).includes(view));
    }
    for (const a of links) {
      if (a.dataset.view === view) a.setAttribute('aria-current', 'page'); else a.removeAttribute('aria-current');
    }
    const block = document.getElementById('residual-block');
    const target = document.getElementById(view === 'diagnose' ? 'diag-residual-slot' : 'residual-home');
    if (block && target && block.parentElement !== target) target.appendChild(block);
    if (view !== 'diagnose') unfitResidual();
    try { localStorage.setItem(VIEW_KEY, view); } catch (e) { /* storage refused: the address still holds the view */ }
    updateLink();
    delete document.body.dataset.shown;
    requestAnimationFrame(() => resizePlots().then(fitResidual).then(() => { document.body.dataset.shown = view; }));
  }
  /** In the Diagnose view the residual plot (250 px per experiment) is made no taller than the
   * screen below its top, so that it is seen whole beside the findings; its own height comes
   * back in the other views. */
  function fitResidual() {
    const el = document.getElementById('residual-plot');
    if (document.body.dataset.view !== 'diagnose' || !el || !el.layout || !window.Plotly) return null;
    const top = el.getBoundingClientRect().top + window.scrollY;
    const room = Math.max(MIN_RESIDUAL_H, Math.floor(window.innerHeight - top - 12));
    if (!(el.layout.height > room)) return null;
    el.dataset.naturalHeight = String(el.layout.height);   // the height the page drew it at
    return Plotly.relayout(el, { height: room });
  }
  function unfitResidual() {
    const el = document.getElementById('residual-plot');
    if (!el || !el.dataset.naturalHeight || !window.Plotly) return;
    const h = Number(el.dataset.naturalHeight);
    delete el.dataset.naturalHeight;
    if (el.layout && el.layout.height !== h) Plotly.relayout(el, { height: h });
  }
  /** Plotly.Plots.resize on every plot now shown; resolves when all are redrawn. */
  function resizePlots() {
    if (!window.Plotly || !Plotly.Plots) return Promise.resolve();
    const done = [];
    for (const el of document.querySelectorAll('#workspace-main .js-plotly-plot')) {
      if (el.offsetParent !== null) {
        try { done.push(Promise.resolve(Plotly.Plots.resize(el)).catch(() => null)); } catch (e) { /* a plot being redrawn: it sizes itself */ }
      }
    }
    return Promise.all(done);
  }
  /** The link to this view and session, and the session named in the nav (as text). */
  function updateLink() {
    const view = document.body.dataset.view || DEFAULT_VIEW;
    const id = currentSessionId();
    const hash = hashFor(view, id);
    if (location.hash !== hash) history.replaceState(null, '', hash);
    const link = document.getElementById('workspace-link');
    link.href = hash;
    link.hidden = !id;
    document.getElementById('workspace-session').textContent = id ? `Session ${id}.` : 'No session.';
  }
  /** Apply the address: an unknown view says so and opens the default one. */
  function applyHash() {
    const { view } = fromHash();
    if (view && !VIEWS.has(view)) {
      // said once the page is ready (its own "Ready" message would cover it)
      problems.push(`The address names no view “${view.slice(0, 80)}”: the views are ${[...VIEWS.keys()].join(', ')}.`);
      whenReady(sayProblems);
    }
    let stored = null;
    try { stored = localStorage.getItem(VIEW_KEY); } catch (e) { stored = null; }
    show(VIEWS.has(view) ? view : (VIEWS.has(stored) ? stored : DEFAULT_VIEW));
  }
  /** Switch to `view` (a nav click, or an action that leads there). */
  function go(view) {
    if (!VIEWS.has(view)) return;
    const hash = hashFor(view, currentSessionId());
    if (location.hash !== hash) history.pushState(null, '', hash);
    show(view);
  }
  /** Show the view holding `el` if it is hidden now (a status-bar error link, an anchor):
   * the first view named by its innermost [data-views] holder. */
  function reveal(el) {
    const own = el && el.closest('[data-views]');
    if (!own || !el.closest('[data-views][hidden]')) return;
    go(own.dataset.views.split(/\s+/)[0]);
  }

  /** A session named by a link opens once the page is ready; one that does not exist says so. */
  async function openLinkedSession(id) {
    if (!id || id === currentSessionId()) { updateLink(); return; }
    if (!SESSION_ID.test(id)) {
      problems.push(`The link's session id is not one this service gives (letters, digits, - and _ only): “${id.slice(0, 80)}”.`);
      sayProblems();
      updateLink();
      return;
    }
    try {
      await openSession(id, 'Opened from the link:');
    } catch (e) {
      const why = e && e.status === 404 ? 'no stored session has this id (deleted, or from another server)' : (e && e.message) || String(e);
      problems.push(`The link's session ${id} could not be opened: ${why}.`);
      sayProblems();
    }
    updateLink();
  }

  nav.addEventListener('click', (ev) => {
    const a = ev.target.closest('a[data-view]');
    if (!a) return;
    ev.preventDefault();
    go(a.dataset.view);
    a.focus();
  });
  // arrow keys move along the steps, as in a toolbar
  nav.addEventListener('keydown', (ev) => {
    const i = links.indexOf(document.activeElement);
    if (i < 0 || !['ArrowDown', 'ArrowUp', 'Home', 'End'].includes(ev.key)) return;
    ev.preventDefault();
    const j = ev.key === 'Home' ? 0 : ev.key === 'End' ? links.length - 1 : (i + (ev.key === 'ArrowDown' ? 1 : -1) + links.length) % links.length;
    links[j].focus();
  });
  // an address typed or followed in this tab: Chromium fires popstate before hashchange, and the
  // first handler rewrites the address, so both read the session before show() does
  function onAddress() {
    const { session } = fromHash();
    applyHash();
    if (document.body.dataset.ready === 'true' && session) openLinkedSession(session);
  }
  window.addEventListener('hashchange', onAddress);
  window.addEventListener('popstate', onAddress);
  window.addEventListener('resize', () => requestAnimationFrame(resizePlots));

  // the session in the address now: read before the page resumes the stored one and rewrites it
  const linked = fromHash().session;
  applyHash();
  // the history re-renders whenever the session changes (opened, started, a version recorded)
  const renderHistoryBefore = window.renderHistory;
  window.renderHistory = function renderHistoryAndLink() {
    renderHistoryBefore.apply(this, arguments);
    updateLink();
  };
  window.revealElement = reveal;
  // an action that leads to another step shows it (not when every step is on the page)
  window.showView = (view) => { if (document.body.dataset.view !== 'all') go(view); };
  whenReady(async () => {
    if (document.body.dataset.ready === 'true') {
      await openLinkedSession(linked);
      // unsaved model edits come back after a reload, unless the address's session opened (static/draft.js)
      await window.modelDraft.restore(!!linked && currentSessionId() === linked);
    }
    // a comparison redraws the residual plot at its own height: fit it again in the Diagnose view
    const res = document.getElementById('residual-plot');
    if (res && res.on) {
      res.on('plotly_afterplot', () => {
        if (document.body.dataset.view !== 'diagnose') { delete res.dataset.naturalHeight; return; }
        fitResidual();
      });
    }
    requestAnimationFrame(resizePlots);
    nav.dataset.ready = 'true';
  });
}());
