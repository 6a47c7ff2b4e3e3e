// A job's log (GET /v1/jobs/{id}/log): one row a task, with the lines its node logged.

import { api, jobPath } from '/ui/api.js';
import { h } from '/ui/dom.js';

const where = (t) => [t.frame != null ? `frame ${t.frame}` : null, t.pass != null ? `pass ${t.pass}` : null,
  t.tile != null ? `tile ${t.tile}` : null].filter(Boolean).join(' · ');

function row(t) {
  const seconds = Math.max(0, t.end - t.start);
  const notes = [...t.errors.map((e) => h('div', { class: 'error-text' }, e)), ...t.warnings.map((w) => h('div', { class: 'muted' }, w))];
  const lines = t.lines.length ? h('details', {}, h('summary', {}, `${t.lines.length} line${t.lines.length === 1 ? '' : 's'}`),
    h('pre', { class: 'log-lines' }, t.lines.join('\n'))) : '';
  return h('tr', { 'data-outcome': t.outcome },
    h('td', {}, t.task), h('td', {}, where(t)), h('td', { class: 'mono' }, t.node), h('td', {}, String(t.attempt)),
    h('td', {}, new Date(t.start * 1000).toLocaleTimeString()), h('td', {}, `${seconds.toFixed(3)} s`),
    h('td', {}, t.outcome), h('td', {}, ...notes, lines));
}

// A <details> that loads the log when opened, and on refresh() while open (new tasks only; at
// most every 2 s unless forced, since a running job's progress refreshes often).
export function taskLog(id) {
  const body = h('tbody');
  const status = h('p', { class: 'muted' }, 'Open to load the log.');
  let read = 0;
  let shown = 0;
  let loading = false;
  let last = 0;
  const el = h('details', { class: 'card', id: 'job-log' }, h('summary', {}, 'Log'), status,
    h('div', { class: 'table-scroll' }, h('table', { class: 'data log' }, h('thead', {}, h('tr', {}, ...['Task', 'Where', 'Node', 'Attempt', 'Start', 'Time', 'Outcome', 'Notes'].map((c) => h('th', {}, c)))), body)));
  async function refresh(force = true) {
    if (!el.open || loading || (!force && Date.now() - last < 2000)) return;
    loading = true;
    last = Date.now();
    try {
      // A page at a time (at most 1,000 tasks and about 4 MiB); Next-From is where the next
      // starts. Read on until a page is empty: a finished job's log is not refreshed again.
      let more = false;
      for (let page = 0; ; ++page) {
        if (page === 100) { more = true; break; }
        const res = await api.blob(jobPath(id, 'log', { from: read, limit: 1000 }));
        const text = await res.blob.text();
        const tasks = text.split('\n').filter((l) => l).map((l) => JSON.parse(l));
        const header = res.headers.get('Next-From');
        const next = header === null ? NaN : Number(header);
        read = Number.isFinite(next) && next >= read ? next : read + tasks.length;
        shown += tasks.length;
        body.append(...tasks.map(row));
        if (!tasks.length) break;
      }
      status.textContent = (shown ? `${shown} task${shown === 1 ? '' : 's'}` : 'No task has ended yet.') +
        (more ? ' (more: close and open the log to read on)' : '');
    } catch (e) {
      status.textContent = `The log could not be read: ${e.message}`;
    } finally {
      loading = false;
    }
  }
  el.addEventListener('toggle', () => refresh());
  return { el, refresh };
}
