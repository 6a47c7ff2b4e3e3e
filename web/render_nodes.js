// A farm's render nodes on the queue page: live or gone, tags, how busy, and the failures
// counted against each across jobs; a node that two jobs or more blocklisted is flagged.
// One process has none, and the panel stays hidden.

import { api } from '/ui/api.js';
import { h, setText } from '/ui/dom.js';

export function renderNodes({ signal }) {
  const tbody = h('tbody');
  const note = h('p', { class: 'muted' });
  const panel = h('section', { id: 'render-nodes', class: 'card', hidden: true, 'aria-labelledby': 'render-nodes-title' },
    h('h2', { id: 'render-nodes-title' }, 'Render nodes'),
    h('div', { class: 'table-scroll' },
      h('table', { class: 'data' },
        h('thead', {}, h('tr', {}, ['Node', 'State', 'Tags', 'Busy', 'Failed tasks', 'Blocklisted by'].map((c) => h('th', { scope: 'col' }, c)))),
        tbody)),
    note);

  function row(n) {
    const flag = n.failing
      ? h('span', { class: 'badge badge-failed', title: 'Blocklisted by two jobs or more: drain it and look at its log' },
        h('span', { 'aria-hidden': 'true' }, '⚠'), ' failing')
      : null;
    return h('tr', { 'data-node': n.name, class: n.failing ? 'failing' : '' },
      h('th', { scope: 'row', class: 'mono' }, n.name, flag ? ' ' : '', flag),
      h('td', { 'data-label': 'State' }, n.live ? 'live' : 'gone'),
      h('td', { 'data-label': 'Tags' }, n.tags.length ? n.tags.join(', ') : '—'),
      h('td', { 'data-label': 'Busy', class: 'num' }, `${Math.round(n.busy * 100)} %`),
      h('td', { 'data-label': 'Failed tasks', class: 'num' }, String(n.failed_tasks)),
      h('td', { 'data-label': 'Blocklisted by', class: 'num' }, n.blocklisted_jobs === 1 ? '1 job' : `${n.blocklisted_jobs} jobs`));
  }

  async function refresh() {
    try {
      const { nodes } = await api.nodes({ signal });
      panel.hidden = nodes.length === 0;
      tbody.replaceChildren(...nodes.map(row));
      const failing = nodes.filter((n) => n.failing).length;
      setText(note, failing ? `${failing} node${failing > 1 ? 's' : ''} failing.` : '');
    } catch (e) {
      if (e.name !== 'AbortError') panel.hidden = true;  // a courtesy: the queue itself still shows
    }
  }
  refresh();
  const timer = setInterval(refresh, 5000);
  signal.addEventListener('abort', () => clearInterval(timer));
  return panel;
}
