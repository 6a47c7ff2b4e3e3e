// A comparison job's results: its table of configurations and its convergence plot (the
// server's convergence.svg, one curve per configuration), in place of an image.

import { api, jobPath } from '/ui/api.js';
import { h } from '/ui/dom.js';
import { downloadLink } from '/ui/downloads.js';
import { fmtDuration, fmtSci } from '/ui/format.js';
import { ApiImage } from '/ui/viewer.js';

function table(cmp) {
  const rows = cmp.rows || [];
  const best = rows.reduce((b, r) => (r.rel_mse_mean != null && (b == null || r.rel_mse_mean < b.rel_mse_mean) ? r : b), null);
  const secs = cmp.seconds_per_run;
  const target = cmp.target_rel_mse;
  return h('div', { class: 'table-scroll' }, h('table', { id: 'comparison-table', class: 'data' },
    h('caption', {}, `Each configuration rendered for ${fmtDuration(secs)} per run`,
      target != null ? `, target relative MSE ${fmtSci(target)}` : '',
      cmp.reference_seconds != null ? `; the reference took ${fmtDuration(cmp.reference_seconds)}` : '', '.'),
    h('thead', {}, h('tr', {},
      h('th', { scope: 'col' }, 'Configuration'),
      h('th', { scope: 'col', class: 'num' }, `Relative MSE at ${fmtDuration(secs)}`),
      h('th', { scope: 'col', class: 'num' }, 'Samples per pixel reached'),
      h('th', { scope: 'col', class: 'num' }, 'Time to the target'),
      h('th', { scope: 'col', class: 'num' }, 'Efficiency 1/(relMSE·s)'))),
    h('tbody', {}, rows.map((r) => h('tr', { class: r === best ? 'best' : null },
      h('th', { scope: 'row' }, r.label, r === best ? h('span', { class: 'tag' }, 'lowest error') : null),
      h('td', { class: 'num' }, fmtSci(r.rel_mse_mean), r.rel_mse_sd ? ` ± ${fmtSci(r.rel_mse_sd)}` : ''),
      h('td', { class: 'num' }, r.spp_reached != null ? String(Math.round(r.spp_reached)) : '—'),
      h('td', { class: 'num' }, r.time_to_target_s != null ? fmtDuration(r.time_to_target_s) : `not reached${r.runs_reaching_target != null ? ` (${r.runs_reaching_target} runs did)` : ''}`),
      h('td', { class: 'num' }, fmtSci(r.efficiency)))))));
}

// Mounts into container; update(job) is called with every new status. Returns {update, resultsRemoved, destroy}.
export function comparisonView(container, job) {
  const controller = new AbortController();
  const body = h('div', { class: 'stack' });
  const plot = new ApiImage({ id: 'comparison-plot', alt: 'Relative MSE against render time, one curve per configuration' });
  plot.img.hidden = true;
  plot.img.classList.add('comparison-svg');
  container.append(body);
  let loaded = false;

  function waiting(state) {
    const text = state === 'queued' || state === 'running'
      ? 'The table and the plot appear when the comparison has finished.'
      : 'This comparison has no results.';
    body.replaceChildren(h('p', { class: 'placeholder' }, text));
  }

  async function load(id) {
    loaded = true;
    body.replaceChildren(h('p', { class: 'placeholder' }, 'Loading the results…'));
    try {
      const report = await api.report(id, { signal: controller.signal });
      const cmp = report.comparison;
      body.replaceChildren(
        h('section', { class: 'card', 'aria-labelledby': 'cmp-table-h' }, h('h2', { id: 'cmp-table-h' }, 'Configurations at equal time'),
          cmp?.rows ? table(cmp) : h('pre', { class: 'markdown' }, report.table_markdown || 'No table in the report.')),
        h('section', { class: 'card', 'aria-labelledby': 'cmp-plot-h' }, h('h2', { id: 'cmp-plot-h' }, 'Convergence'),
          h('figure', { class: 'svg-figure' }, plot.img)),
        h('section', { class: 'card', 'aria-labelledby': 'cmp-dl-h' }, h('h2', { id: 'cmp-dl-h' }, 'Downloads'),
          h('ul', { class: 'downloads' },
            h('li', {}, downloadLink({ id: 'download-report', path: jobPath(id, 'report.json'), filename: `tessera-${id}-report.json`, label: 'Report (JSON)' })),
            h('li', {}, downloadLink({ id: 'download-svg', path: jobPath(id, 'convergence.svg'), filename: `tessera-${id}-convergence.svg`, label: 'Convergence plot (SVG)' })),
            h('li', {}, downloadLink({ id: 'download-csv', path: jobPath(id, 'convergence.csv'), filename: `tessera-${id}-convergence.csv`, label: 'Convergence (CSV)' })))));
      plot.show(jobPath(id, 'convergence.svg'));
    } catch (e) {
      if (e.name === 'AbortError') return;
      body.replaceChildren(h('p', { class: 'notice error' }, e.status === 410 ? 'The results of this comparison were removed.' : `The results could not be loaded: ${e.message}`));
    }
  }

  let current = job;
  function update(j) {
    current = j;
    if (j.state === 'succeeded') { if (!loaded) load(j.id); } else { loaded = false; waiting(j.state); }
  }
  update(job);
  return {
    update,
    resultsRemoved: () => { loaded = false; update(current); },
    destroy() { controller.abort(); plot.destroy(); },
  };
}
