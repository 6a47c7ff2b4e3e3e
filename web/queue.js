// The queue page: every job, newest first, kept current by the event stream.

import { api } from '/ui/api.js';
import { h, setText } from '/ui/dom.js';
import { openEventStream } from '/ui/events.js';
import { fmtDuration, fmtPercent, shortId } from '/ui/format.js';
import { cancelJob, removeResults } from '/ui/job_actions.js';
import {
  STATES, elapsedSeconds, isActive, isFinal, jobSize, jobTitle, remainingSeconds, stateBadge, stateLabel,
} from '/ui/job_info.js';
import { announce, toastError } from '/ui/notify.js';
import { renderNodes } from '/ui/render_nodes.js';

const PAGE = 50;
const STALE_MS = 5000;
const COLUMNS = ['Job', 'Scene', 'Size', 'State', 'Progress', 'Priority', 'Position', 'Elapsed', 'Time left', 'Actions'];

export function mount(root, { query }) {
  let filter = STATES.includes(query.get('state')) ? query.get('state') : '';
  const rows = new Map();          // id → {tr, job, cells, lastEvent}
  let total = 0;
  let loaded = false;
  let listSeq = 0;
  let refreshTimer = 0;
  const controller = new AbortController();
  const signal = controller.signal;

  const select = h('select', { id: 'state-filter', name: 'state' },
    h('option', { value: '' }, 'All states'), STATES.map((s) => h('option', { value: s }, stateLabel(s))));
  select.value = filter;
  select.addEventListener('change', () => {
    filter = select.value;
    history.replaceState(null, '', filter ? `#/?state=${filter}` : '#/');
    for (const r of rows.values()) r.tr.remove();
    rows.clear();
    loaded = false;
    render();
    refresh();
  });

  const tbody = h('tbody');
  const table = h('table', { id: 'queue', class: 'data queue' },
    h('caption', { class: 'visually-hidden' }, 'Render jobs, newest first'),
    h('thead', {}, h('tr', {}, COLUMNS.map((c) => h('th', { scope: 'col' }, c)))),
    tbody);
  const summary = h('p', { class: 'muted', id: 'queue-summary', 'aria-live': 'off' });
  const empty = h('p', { class: 'placeholder', hidden: true });
  const more = h('button', { type: 'button', id: 'load-more', class: 'secondary', hidden: true }, 'Load more');
  more.addEventListener('click', loadMore);
  const errorBox = h('p', { class: 'notice error', role: 'alert', hidden: true });

  root.append(
    h('div', { class: 'page-head' },
      h('h1', { tabindex: '-1' }, 'Render queue'),
      h('div', { class: 'control inline' }, h('label', { for: 'state-filter' }, 'Show'), select),
      h('a', { class: 'button', href: '#/submit' }, 'New job')),
    errorBox,
    h('div', { class: 'table-scroll' }, table),
    empty,
    h('div', { class: 'list-foot' }, summary, more),
    renderNodes({ signal }));

  function matches(job) {
    return !filter || job.state === filter;
  }

  function createRow(job) {
    const id = job.id;
    const cells = {
      scene: h('td', { 'data-label': 'Scene', class: 'scene' }),
      size: h('td', { 'data-label': 'Size', class: 'num' }),
      state: h('td', { 'data-label': 'State' }),
      progress: h('progress', { max: 1, value: 0, 'aria-label': `Progress of job ${shortId(id)}` }),
      pct: h('span', { class: 'pct' }),
      priority: h('td', { 'data-label': 'Priority', class: 'num' }),
      position: h('td', { 'data-label': 'Position', class: 'num' }),
      elapsed: h('td', { 'data-label': 'Elapsed', class: 'num' }),
      left: h('td', { 'data-label': 'Time left', class: 'num' }),
      cancel: h('button', { type: 'button', class: 'small danger', 'data-action': 'cancel', 'aria-label': `Cancel job ${shortId(id)}` }, 'Cancel'),
      remove: h('button', { type: 'button', class: 'small secondary', 'data-action': 'remove', 'aria-label': `Remove the results of job ${shortId(id)}` }, 'Remove results'),
    };
    cells.cancel.addEventListener('click', async () => {
      cells.cancel.disabled = true;
      const s = await cancelJob(id);
      cells.cancel.disabled = false;
      if (s) apply(s, 'state');
    });
    cells.remove.addEventListener('click', () => removeResults(id));
    const tr = h('tr', { 'data-job-id': id },
      h('th', { scope: 'row', 'data-label': 'Job' },
        h('a', { href: `#/jobs/${id}`, 'data-action': 'open', class: 'mono', title: `Open job ${id}` }, shortId(id))),
      cells.scene, cells.size, cells.state,
      h('td', { 'data-label': 'Progress', class: 'progress-cell' }, h('span', {}, cells.progress, cells.pct)),
      cells.priority, cells.position, cells.elapsed, cells.left,
      h('td', { 'data-label': 'Actions' }, h('div', { class: 'row-actions' }, cells.cancel, cells.remove)));
    const row = { tr, cells, job: null, lastEvent: Date.now(), state: null };
    updateRow(row, job);
    return row;
  }

  function updateTimes(row) {
    const { job, cells } = row;
    setText(cells.elapsed, job.state === 'queued' ? '—' : fmtDuration(elapsedSeconds(job)));
    const left = remainingSeconds(job);
    setText(cells.left, left == null ? '—' : `≈ ${fmtDuration(left)}`);
  }

  function updateRow(row, job) {
    const { cells, tr } = row;
    row.job = job;
    tr.dataset.state = job.state;
    if (row.state !== job.state) {
      cells.state.replaceChildren(stateBadge(job.state));
      row.state = job.state;
    }
    setText(cells.scene, jobTitle(job));
    setText(cells.size, jobSize(job));
    const f = job.state === 'succeeded' ? 1 : job.progress?.fraction || 0;
    cells.progress.value = f;
    setText(cells.pct, fmtPercent(f));
    setText(cells.priority, job.priority);
    setText(cells.position, job.queue_position == null ? '—' : job.queue_position + 1);
    cells.cancel.hidden = !isActive(job.state);
    cells.remove.hidden = !isFinal(job.state);
    updateTimes(row);
  }

  function render() {
    const n = rows.size;
    empty.hidden = !loaded || n > 0;
    setText(empty, filter ? `No ${stateLabel(filter).toLowerCase()} jobs.` : 'No jobs yet: submit one to see it here.');
    setText(summary, loaded ? `Showing ${n} of ${total} job${total === 1 ? '' : 's'}` : 'Loading…');
    more.hidden = !loaded || n >= total;
  }

  // Puts rows in the server's order, touching only rows that are out of place: moving a row
  // in the DOM would take the keyboard focus away from a button in it.
  function reconcile(jobs, { append = false } = {}) {
    const seen = new Set();
    const ordered = [];
    for (const job of jobs) {
      if (seen.has(job.id)) continue;
      seen.add(job.id);
      let row = rows.get(job.id);
      if (row) {
        if (!(isFinal(row.job.state) && isActive(job.state))) updateRow(row, job);
      } else {
        row = createRow(job);
        rows.set(job.id, row);
      }
      ordered.push(row);
    }
    if (append) {
      for (const row of ordered) if (row.tr.parentNode !== tbody) tbody.append(row.tr);
      return;
    }
    for (const [id, row] of rows) if (!seen.has(id)) { row.tr.remove(); rows.delete(id); }
    ordered.forEach((row, i) => {
      const at = tbody.children[i];
      if (at !== row.tr) tbody.insertBefore(row.tr, at || null);
    });
  }

  // Re-reads the loaded window (at least one page) from the server.
  async function refresh() {
    const seq = ++listSeq;
    try {
      const limit = Math.min(1000, Math.max(PAGE, rows.size));
      const list = await api.listJobs({ state: filter || undefined, limit, offset: 0 }, { signal });
      if (seq !== listSeq) return;
      total = list.total;
      reconcile(list.jobs);
      loaded = true;
      errorBox.hidden = true;
      render();
    } catch (e) {
      if (e.name === 'AbortError') return;
      errorBox.hidden = false;
      setText(errorBox, `The queue could not be loaded: ${e.message}`);
    }
  }

  function scheduleRefresh(ms = 400) {
    clearTimeout(refreshTimer);
    refreshTimer = setTimeout(refresh, ms);
  }

  async function loadMore() {
    more.disabled = true;
    try {
      // Jobs created since the first page shift the offsets; duplicates are skipped.
      const list = await api.listJobs({ state: filter || undefined, limit: PAGE, offset: rows.size }, { signal });
      total = list.total;
      reconcile(list.jobs, { append: true });
      render();
    } catch (e) {
      toastError(e, 'Could not load more jobs: ');
    } finally {
      more.disabled = false;
    }
  }

  // Events may arrive out of creation order (a farm's API nodes), so place by created_at.
  function insertSorted(row) {
    const t = row.job.created_at ?? Infinity;
    for (const other of tbody.children) {
      const o = rows.get(other.dataset.jobId);
      if (o && (o.job.created_at ?? 0) < t) { tbody.insertBefore(row.tr, other); return; }
    }
    tbody.append(row.tr);
  }

  function apply(job, type) {
    const row = rows.get(job.id);
    const prev = row?.job.state;
    if (row) {
      row.lastEvent = Date.now();
      if (isFinal(prev) && isActive(job.state)) return;   // stale
      if (!matches(job)) {
        // The row leaves the filtered list; keep the keyboard focus on the page.
        if (row.tr.contains(document.activeElement)) select.focus();
        row.tr.remove();
        rows.delete(job.id);
        total = Math.max(0, total - 1);
      } else updateRow(row, job);
    } else if (matches(job) && (type === 'created' || type === 'state')) {
      const r = createRow(job);
      rows.set(job.id, r);
      insertSorted(r);
      total += 1;
      if (type === 'created') announce(`Job ${shortId(job.id)} submitted`);
    }
    if (prev && prev !== job.state) announce(`Job ${shortId(job.id)} ${stateLabel(job.state).toLowerCase()}`);
    // When any job starts or ends, queue positions of the waiting ones move.
    if ((type === 'state' || (prev && prev !== job.state)) && [...rows.values()].some((r) => r.job.state === 'queued')) scheduleRefresh(600);
    render();
  }

  const stream = openEventStream({
    onEvent(type, data) {
      if (type === 'reset') { scheduleRefresh(0); return; }
      if (data?.job?.id) apply(data.job, type);
    },
    onOpen({ resumed }) { if (!resumed) scheduleRefresh(0); },
  });
  render();
  refresh();

  // Fallback while the stream is down, or for a running job it has been quiet about.
  const poll = setInterval(async () => {
    if (!stream.live) { refresh(); return; }
    const stale = [...rows.values()].filter((r) => r.job.state === 'running' && Date.now() - r.lastEvent > STALE_MS).slice(0, 10);
    for (const r of stale) {
      r.lastEvent = Date.now();
      api.job(r.job.id, { signal }).then((j) => apply(j, 'progress')).catch(() => {});
    }
  }, STALE_MS);
  const ticker = setInterval(() => {
    for (const r of rows.values()) if (r.job.state === 'running') updateTimes(r);
  }, 1000);

  return () => {
    controller.abort();
    stream.close();
    clearInterval(poll);
    clearInterval(ticker);
    clearTimeout(refreshTimer);
  };
}
