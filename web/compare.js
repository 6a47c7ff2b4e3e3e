// The compare page: two finished jobs side by side or overlaid with a split slider, at the
// same zoom and exposure, and their convergence curves on one plot.

import { api, jobPath } from '/ui/api.js';
import { h, setText } from '/ui/dom.js';
import { isComparison, jobOptionLabel, jobSize, stateLabel } from '/ui/job_info.js';
import { shortId } from '/ui/format.js';
import { convergenceSeries, drawPlot } from '/ui/plot.js';
import { ApiImage, applyZoom, exposureQuery, onViewChange, viewControls } from '/ui/viewer.js';

export function mount(root, { query }) {
  const controller = new AbortController();
  const signal = controller.signal;
  let mode = query.get('mode') === 'slider' ? 'slider' : 'side';
  const sides = {
    a: { id: query.get('a') || '', job: null, report: null, seq: 0 },
    b: { id: query.get('b') || '', job: null, report: null, seq: 0 },
  };
  let known = [];

  const select = (key) => h('select', { id: `compare-${key}`, name: `compare-${key}` });
  const selA = select('a');
  const selB = select('b');
  const modeSel = h('select', { id: 'compare-mode', name: 'compare-mode' },
    h('option', { value: 'side' }, 'Side by side'), h('option', { value: 'slider' }, 'Overlay with a slider'));
  modeSel.value = mode;
  const swap = h('button', { type: 'button', class: 'secondary small', id: 'compare-swap' }, 'Swap A and B');
  const controls = viewControls();
  const slider = h('input', { type: 'range', id: 'compare-slider', min: 0, max: 100, step: 1, value: '50', 'aria-valuetext': 'A shows on the left 50 %' });
  const sliderField = h('div', { class: 'control slider-control' }, h('label', { for: 'compare-slider' }, 'Split (A on the left, B on the right)'), slider);
  const stage = h('div', { class: 'compare-stage' });
  const note = h('p', { class: 'muted', role: 'status' });
  const plot = document.createElementNS('http://www.w3.org/2000/svg', 'svg');
  plot.id = 'compare-plot';

  const captions = { a: h('span'), b: h('span') };
  const placeholders = { a: h('p', { class: 'placeholder' }, 'Choose job A.'), b: h('p', { class: 'placeholder' }, 'Choose job B.') };
  const makeImage = (key) => new ApiImage({
    id: `compare-image-${key}`,
    alt: `Job ${key.toUpperCase()}`,
    onLoad() { placeholders[key].hidden = true; },
    onError(e) {
      images[key].clear();
      placeholders[key].hidden = false;
      setText(placeholders[key], e.status === 409 ? 'This job has no image yet.' : e.status === 410 ? 'This job’s results were removed.' : `The image could not be loaded: ${e.message}`);
    },
  });
  const images = { a: makeImage('a'), b: makeImage('b') };
  images.a.img.hidden = true;
  images.b.img.hidden = true;

  root.append(
    h('h1', { tabindex: '-1' }, 'Compare jobs'),
    h('div', { class: 'card compare-controls' },
      h('div', { class: 'control' }, h('label', { for: 'compare-a' }, 'Job A'), selA),
      h('div', { class: 'control' }, h('label', { for: 'compare-b' }, 'Job B'), selB),
      swap,
      h('div', { class: 'control' }, h('label', { for: 'compare-mode' }, 'View'), modeSel),
      controls.el),
    note,
    h('section', { class: 'card', 'aria-labelledby': 'cmp-img-h' }, h('h2', { id: 'cmp-img-h', class: 'visually-hidden' }, 'Images'), sliderField, stage),
    h('section', { class: 'card', 'aria-labelledby': 'cmp-plot-h' }, h('h2', { id: 'cmp-plot-h' }, 'Convergence'), plot));

  function syncUrl() {
    const q = new URLSearchParams();
    if (sides.a.id) q.set('a', sides.a.id);
    if (sides.b.id) q.set('b', sides.b.id);
    if (mode !== 'side') q.set('mode', mode);
    const s = q.toString();
    history.replaceState(null, '', `#/compare${s ? `?${s}` : ''}`);
  }

  function setSplit(v) {
    const pct = Math.max(0, Math.min(100, v));
    stage.style.setProperty('--split', `${pct}%`);
    slider.setAttribute('aria-valuetext', `A shows on the left ${Math.round(pct)} %`);
  }
  slider.addEventListener('input', () => setSplit(Number(slider.value)));

  function figure(key, viewport) {
    return h('figure', { class: 'compare-figure' },
      h('figcaption', {}, h('strong', {}, key.toUpperCase()), ' ', captions[key]), viewport);
  }

  // Both layouts reuse the same two <img> elements, so switching keeps the loaded images.
  function layout() {
    sliderField.hidden = mode !== 'slider';
    stage.className = `compare-stage mode-${mode}`;
    images.a.img.classList.toggle('over', mode === 'slider');
    if (mode === 'side') {
      const vps = ['a', 'b'].map((k) => h('div', { class: 'viewport', tabindex: '0', role: 'region', 'aria-label': `Job ${k.toUpperCase()} (scrolls when zoomed)` }, images[k].img, placeholders[k]));
      // Scrolling one zoomed image scrolls the other to the same place.
      let syncing = false;
      vps.forEach((vp, i) => vp.addEventListener('scroll', () => {
        if (syncing) { syncing = false; return; }
        const other = vps[1 - i];
        syncing = true;
        other.scrollLeft = vp.scrollLeft;
        other.scrollTop = vp.scrollTop;
      }));
      stage.replaceChildren(h('div', { class: 'side-by-side' }, figure('a', vps[0]), figure('b', vps[1])));
    } else {
      const overlay = h('div', { class: 'overlay' },
        images.b.img, images.a.img,
        h('span', { class: 'overlay-label left', 'aria-hidden': 'true' }, 'A'),
        h('span', { class: 'overlay-label right', 'aria-hidden': 'true' }, 'B'),
        h('span', { class: 'divider', 'aria-hidden': 'true' }));
      // Dragging on the image moves the split too; the range input stays the keyboard control.
      const drag = (ev) => {
        const r = overlay.getBoundingClientRect();
        if (!r.width) return;
        slider.value = String(Math.round(((ev.clientX - r.left) / r.width) * 100));
        setSplit(Number(slider.value));
      };
      overlay.addEventListener('pointerdown', (ev) => { overlay.setPointerCapture(ev.pointerId); drag(ev); });
      overlay.addEventListener('pointermove', (ev) => { if (overlay.hasPointerCapture(ev.pointerId)) drag(ev); });
      stage.replaceChildren(
        h('figure', { class: 'compare-figure' },
          h('figcaption', {}, h('strong', {}, 'A'), ' ', captions.a, h('br'), h('strong', {}, 'B'), ' ', captions.b),
          h('div', { class: 'viewport', tabindex: '0', role: 'region', 'aria-label': 'Jobs A and B overlaid (scrolls when zoomed)' },
            overlay, placeholders.a, placeholders.b)));
    }
    setSplit(Number(slider.value));
  }

  function drawCurves() {
    const series = [];
    for (const [key, style] of [['a', 0], ['b', 1]]) {
      const s = sides[key];
      if (s.report?.convergence?.points) series.push(...convergenceSeries(s.report.convergence.points, `${key.toUpperCase()} (${shortId(s.id)})`, style));
    }
    drawPlot(plot, series, { empty: sides.a.id || sides.b.id ? 'No convergence data for these jobs.' : 'Choose two jobs to compare their curves.' });
  }

  function describe() {
    const { a, b } = sides;
    const msgs = [];
    if (a.job && b.job && jobSize(a.job) !== jobSize(b.job)) msgs.push(`The images differ in size (${jobSize(a.job)} and ${jobSize(b.job)})${mode === 'slider' ? ': A is stretched over B.' : '.'}`);
    for (const [k, s] of Object.entries(sides)) if (s.job && s.job.state !== 'succeeded') msgs.push(`Job ${k.toUpperCase()} is ${stateLabel(s.job.state).toLowerCase()}.`);
    if (a.id && a.id === b.id) msgs.push('A and B are the same job.');
    setText(note, msgs.join(' '));
  }

  function showImage(key) {
    const s = sides[key];
    if (!s.id) return;
    images[key].show(jobPath(s.id, 'image.png', exposureQuery()));
  }

  async function choose(key, id) {
    const s = sides[key];
    const seq = ++s.seq;
    s.id = id;
    s.job = null;
    s.report = null;
    syncUrl();
    images[key].clear();
    placeholders[key].hidden = false;
    if (!id) {
      setText(placeholders[key], `Choose job ${key.toUpperCase()}.`);
      captions[key].replaceChildren();
      describe();
      drawCurves();
      return;
    }
    setText(placeholders[key], 'Loading…');
    try {
      const job = known.find((j) => j.id === id) || await api.job(id, { signal });
      if (seq !== s.seq) return;
      s.job = job;
      captions[key].replaceChildren(h('a', { href: `#/jobs/${job.id}` }, jobOptionLabel(job)));
      describe();
      showImage(key);
      const report = await api.report(id, { signal }).catch(() => null);
      if (seq !== s.seq) return;
      s.report = report;
      drawCurves();
    } catch (e) {
      if (e.name === 'AbortError' || seq !== s.seq) return;
      setText(placeholders[key], e.status === 404 ? `There is no job ${id}.` : `The job could not be loaded: ${e.message}`);
    }
  }

  function fillSelect(sel, key) {
    const opts = known.map((j) => h('option', { value: j.id }, `${jobOptionLabel(j)}${j.state !== 'succeeded' ? ` (${stateLabel(j.state).toLowerCase()})` : ''}`));
    sel.replaceChildren(h('option', { value: '' }, `Choose job ${key.toUpperCase()}…`), ...opts);
    sel.value = sides[key].id;
  }

  selA.addEventListener('change', () => choose('a', selA.value));
  selB.addEventListener('change', () => choose('b', selB.value));
  modeSel.addEventListener('change', () => { mode = modeSel.value; syncUrl(); layout(); describe(); });
  swap.addEventListener('click', () => {
    const a = sides.a.id;
    const b = sides.b.id;
    selA.value = b;
    selB.value = a;
    choose('a', b);
    choose('b', a);
  });

  const offView = onViewChange((_, patch) => {
    if ('zoom' in patch) { applyZoom(images.a.img); applyZoom(images.b.img); }
    if ('exposure' in patch) { showImage('a'); showImage('b'); }
  });

  async function load() {
    try {
      const list = await api.listJobs({ state: 'succeeded', limit: 200 }, { signal });
      known = list.jobs.filter((j) => !isComparison(j));
    } catch (e) {
      if (e.name === 'AbortError') return;
      setText(note, `The finished jobs could not be listed: ${e.message}`);
    }
    // Jobs named in the URL may be older than the list reaches, or not finished.
    for (const key of ['a', 'b']) {
      const id = sides[key].id;
      if (id && !known.some((j) => j.id === id)) {
        try { known.push(await api.job(id, { signal })); } catch { /* choose() reports it */ }
      }
    }
    if (signal.aborted) return;
    fillSelect(selA, 'a');
    fillSelect(selB, 'b');
    if (known.length < 2 && !note.textContent) setText(note, 'Comparing needs two succeeded render jobs.');
    if (sides.a.id) choose('a', sides.a.id);
    if (sides.b.id) choose('b', sides.b.id);
  }

  layout();
  drawCurves();
  fillSelect(selA, 'a');
  fillSelect(selB, 'b');
  load();

  return () => {
    controller.abort();
    offView();
    images.a.destroy();
    images.b.destroy();
  };
}
