// A render job's report (report.json, or the status while no report exists) as page sections.

import { facts, h } from '/ui/dom.js';
import { fmtBytes, fmtDuration, fmtInt, fmtSci, humanize } from '/ui/format.js';

const TIMINGS = [
  ['queued_s', 'Waiting in the queue'], ['load_s', 'Loading the scene'], ['bvh_s', 'Building the BVH'],
  ['render_s', 'Rendering'], ['write_s', 'Writing the results'], ['total_s', 'Total'],
];

const STATS = {
  rays_camera: ['Camera rays', fmtInt],
  rays_shadow: ['Shadow rays', fmtInt],
  rays_bounce: ['Bounce rays', fmtInt],
  mrays_per_s: ['Million rays per second', fmtSci],
  spp_mean: ['Samples per pixel, mean', fmtSci],
  spp_min: ['Samples per pixel, least', fmtSci],
  spp_max: ['Samples per pixel, most', fmtSci],
  bvh_nodes: ['BVH nodes', fmtInt],
  bvh_depth: ['BVH depth', fmtInt],
  bvh_sah_cost: ['SAH cost per ray', fmtSci],
  bvh_bytes: ['BVH memory', fmtBytes],
  nodes_per_ray: ['Nodes visited per ray', fmtSci],
  prim_tests_per_ray: ['Leaf tests per ray', fmtSci],
  nonfinite_samples: ['Non-finite samples dropped', fmtInt],
  max_sample_luminance: ['Brightest sample (luminance)', fmtSci],
  threads: ['Render threads', fmtInt],
};

const STOP_REASONS = {
  spp: 'reached the samples per pixel',
  time_limit: 'reached the time limit',
  target_error: 'reached the target error',
  adaptive: 'every pixel converged (adaptive sampling)',
  canceled: 'canceled',
};

function section(title, ...body) {
  const id = `sec-${title.toLowerCase().replace(/[^a-z0-9]+/g, '-')}`;
  return h('section', { class: 'card', 'aria-labelledby': id }, h('h2', { id }, title), body);
}

function list(items, cls) {
  return items?.length ? h('ul', { class: cls }, items.map((t) => h('li', {}, t))) : null;
}

export function timingsSection(timings, queuedS) {
  const t = { ...(timings || {}) };
  if (t.queued_s == null && queuedS != null) t.queued_s = queuedS;
  const total = t.total_s || 0;
  const rows = TIMINGS.filter(([k]) => t[k] != null).map(([k, label]) => {
    const share = k !== 'total_s' && k !== 'queued_s' && total > 0 ? Math.min(1, t[k] / total) : null;
    return h('tr', {},
      h('th', { scope: 'row' }, label),
      h('td', { class: 'num' }, fmtDuration(t[k])),
      h('td', { class: 'share' }, share == null ? '' : h('span', { class: 'bar', style: { width: `${(share * 100).toFixed(1)}%` }, title: `${(share * 100).toFixed(1)} % of the total` })));
  });
  if (!rows.length) return section('Timings', h('p', { class: 'muted' }, 'Known once the job has started.'));
  return section('Timings', h('table', { class: 'kv' },
    h('thead', { class: 'visually-hidden' }, h('tr', {}, h('th', { scope: 'col' }, 'Phase'), h('th', { scope: 'col' }, 'Time'), h('th', { scope: 'col' }, 'Share of the total'))),
    h('tbody', {}, rows)));
}

export function statsSection(stats) {
  if (!stats) return section('Statistics', h('p', { class: 'muted' }, 'Known once the job has finished rendering.'));
  // Known statistics in a reading order, then whatever else the server adds.
  const order = Object.keys(STATS);
  const rank = (k) => (order.includes(k) ? order.indexOf(k) : order.length);
  const pairs = Object.entries(stats)
    .filter(([, v]) => v != null && typeof v !== 'object')
    .sort(([a], [b]) => rank(a) - rank(b))
    .map(([k, v]) => {
      const [label, fmt] = STATS[k] || [humanize(k), (x) => (typeof x === 'number' ? fmtSci(x) : String(x))];
      return [label, fmt(v)];
    });
  return section('Statistics', facts(pairs));
}

function sceneSection(scene) {
  if (!scene) return null;
  const cache = scene.cache
    ? (scene.cache.hit
      ? `reused (preparing it had cost ${fmtDuration((scene.cache.load_s || 0) + (scene.cache.build_s || 0))})`
      : 'prepared for this job')
    : null;
  const stages = scene.build_stages?.length
    ? h('table', { class: 'kv compact' },
      h('caption', {}, `Build stages${scene.build_s != null ? `, ${fmtDuration(scene.build_s)} in all` : ''}`),
      h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Stage'), h('th', { scope: 'col', class: 'num' }, 'Time'))),
      h('tbody', {}, scene.build_stages.map((s) => h('tr', {}, h('th', { scope: 'row' }, s.stage), h('td', { class: 'num' }, fmtDuration(s.seconds))))))
    : null;
  return section('Scene',
    facts([
      ['Name', scene.name],
      ['Triangles', scene.triangles != null ? fmtInt(scene.triangles) : null],
      ['Spheres', scene.spheres != null ? fmtInt(scene.spheres) : null],
      ['Prepared scene', cache],
    ]),
    stages);
}

function builtSection(report) {
  const built = [...(report.render?.built || []), ...(report.scene?.built || [])];
  const left = [...(report.render?.left_out || []), ...(report.scene?.left_out || [])];
  if (!built.length && !left.length) return null;
  return section('Built and left out',
    h('div', { class: 'two-col' },
      h('div', {}, h('h3', {}, 'Built'), list(built, 'plain-list') || h('p', { class: 'muted' }, 'Nothing listed.')),
      h('div', {}, h('h3', {}, 'Left out'), list(left, 'plain-list') || h('p', { class: 'muted' }, 'Nothing left out.'))));
}

function nodesSection(nodes) {
  if (!nodes?.length) return null;
  return section('Render nodes', h('div', { class: 'table-scroll' }, h('table', { class: 'kv' },
    h('thead', {}, h('tr', {}, ['Node', 'Tiles', 'Share', 'Seconds'].map((c) => h('th', { scope: 'col' }, c)))),
    h('tbody', {}, nodes.map((n) => h('tr', {},
      h('th', { scope: 'row', class: 'mono' }, n.node), h('td', { class: 'num' }, fmtInt(n.tiles)),
      h('td', { class: 'num' }, `${(n.share * 100).toFixed(1)} %`), h('td', { class: 'num' }, fmtDuration(n.seconds))))))));
}

export function stopReasonText(report) {
  const r = report?.convergence?.stop_reason;
  return r ? `Stopped because it ${STOP_REASONS[r] || r}.` : '';
}

// Every section a render job's page shows below the image; report may be null (not finished,
// or its files removed), in which case the status supplies what it can.
export function reportSections(report, job) {
  const warnings = report?.scene?.warnings || [];
  return [
    warnings.length ? section('Scene warnings', h('div', { class: 'notice warn', role: 'note' }, list(warnings, 'plain-list'))) : null,
    timingsSection(report?.timings || job.timings, job.timings?.queued_s),
    statsSection(report?.stats || job.stats),
    report ? sceneSection(report.scene) : null,
    report ? builtSection(report) : null,
    nodesSection(job.nodes || report?.nodes),
  ].filter(Boolean);
}
