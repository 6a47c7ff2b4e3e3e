// The job page: state and progress, the image converging pass by pass, the convergence plot,
// the report and the downloads (a comparison job shows its table instead of an image).

import { api, jobPath } from '/ui/api.js';
import { facts, h, setText } from '/ui/dom.js';
import { downloadLink } from '/ui/downloads.js';
import { taskLog } from '/ui/task_log.js';
import { openEventStream } from '/ui/events.js';
import { fmtDuration, fmtPercent, fmtSci, fmtTime, shortId } from '/ui/format.js';
import { cancelJob, pauseJob, removeResults, resumeJob } from '/ui/job_actions.js';
import {
  canPause, elapsedSeconds, isActive, isComparison, isFinal, jobSize, remainingSeconds, stateBadge, stateLabel,
} from '/ui/job_info.js';
import { announce } from '/ui/notify.js';
import { convergenceSeries, drawPlot } from '/ui/plot.js';
import { comparisonView } from '/ui/comparison_view.js';
import { reportSections, stopReasonText } from '/ui/report_view.js';
import { isShot, shotView } from '/ui/shot_view.js';
import { ApiImage, applyZoom, exposureQuery, onViewChange, viewControls } from '/ui/viewer.js';

const STALE_MS = 4000;   // no event for this long while active: ask for the status instead

function settingValue(v) {
  if (v == null) return 'none';
  if (typeof v === 'object') return Object.entries(v).map(([k, x]) => `${k} ${x}`).join(', ');
  return String(v);
}

// The image, plot, downloads and report of a render job. Returns {update, pass, resultsRemoved, destroy}.
function renderBody(container, first) {
  const id = first.id;
  let job = first;
  let report = null;
  let gone = false;
  let showRate = false;
  let downloadsKey = '';
  const passes = new Map();

  const passInfo = h('p', { id: 'pass-info', class: 'pass-info' });
  const placeholder = h('p', { class: 'placeholder' });
  const image = new ApiImage({
    id: 'job-image',
    alt: `Render of ${first.settings.scene}`,
    onLoad(headers) {
      const pass = headers.get('X-Tessera-Pass');
      image.img.dataset.pass = pass ?? 'final';
      placeholder.hidden = true;
      if (showRate) setText(passInfo, pass != null ? `Sample-rate map after pass ${pass}` : 'Sample-rate map of the final image');
      else if (pass != null) {
        const spp = headers.get('X-Tessera-Pass-Spp');
        const err = Number(headers.get('X-Tessera-Pass-Error'));
        setText(passInfo, `${showDenoised ? 'Denoised, pass' : 'Pass'} ${pass}${spp ? ` · ${spp} spp` : ''}${Number.isFinite(err) && headers.get('X-Tessera-Pass-Error') ? ` · estimated relative MSE ${fmtSci(err)}` : ''}`);
      } else {
        const spp = report?.stats?.spp_mean ?? job.stats?.spp_mean;
        setText(passInfo, `Final image${spp != null ? ` · ${fmtSci(spp)} spp on average` : ''}`);
      }
    },
    onError(e) {
      image.clear();
      image.img.dataset.pass = '';
      if (e.status === 409) showPlaceholder(job.state === 'queued' ? 'The image appears once the job runs.'
        : showDenoised ? 'The denoised image appears after the 4-spp pass.' : 'The image appears after the first pass.');
      else if (e.status === 410) showPlaceholder(job.state === 'succeeded' ? 'The results of this job were removed.' : 'This job ended without an image.');
      else if (e.status === 404 && showDenoised) showPlaceholder('This job has no denoised image: its render ended before every pixel had the two samples the denoiser compares.');
      else if (e.status === 503) showPlaceholder('The server is busy encoding images for other clients; the next update tries again.');
      else showPlaceholder(`The image could not be loaded: ${e.message}`);
    },
  });
  image.img.hidden = true;

  function showPlaceholder(text) {
    setText(placeholder, text);
    placeholder.hidden = false;
    setText(passInfo, '');
  }

  const controls = viewControls();
  // A denoising job shows its denoised image or the noisy one (from the 4-spp pass on while it runs).
  const denoises = first.settings.denoise === true;
  let showDenoised = false;
  const denoisedButton = h('button', { type: 'button', id: 'show-denoised', class: 'secondary toggle', 'aria-pressed': 'false', hidden: !denoises }, 'Denoised');
  denoisedButton.addEventListener('click', () => {
    showDenoised = !showDenoised;
    denoisedButton.setAttribute('aria-pressed', String(showDenoised));
    if (showDenoised && showRate) rateButton.click();
    controls.setExposureEnabled(!showDenoised && !showRate);
    refreshImage();
  });
  const rateButton = h('button', { type: 'button', id: 'show-rate', class: 'secondary toggle', 'aria-pressed': 'false' }, 'Sample-rate map');
  rateButton.addEventListener('click', () => {
    showRate = !showRate;
    if (showRate && showDenoised) denoisedButton.click();
    rateButton.setAttribute('aria-pressed', String(showRate));
    controls.setExposureEnabled(!showRate);
    image.img.alt = showRate ? `Sample-rate map of ${job.settings.scene}` : `Render of ${job.settings.scene}`;
    refreshImage();
  });

  const plot = document.createElementNS('http://www.w3.org/2000/svg', 'svg');
  plot.id = 'convergence-plot';
  const stopReason = h('p', { class: 'muted' });
  const downloads = h('div');
  const log = taskLog(first.id);
  const reportBox = h('div', { class: 'report-grid' });
  const viewport = h('div', { class: 'viewport', tabindex: '0', role: 'region', 'aria-label': 'Image (scrolls when zoomed)' }, image.img, placeholder);

  container.append(
    h('section', { class: 'card', 'aria-labelledby': 'image-h' },
      h('h2', { id: 'image-h' }, 'Image'),
      h('div', { class: 'toolbar' }, rateButton, denoisedButton, controls.el),
      passInfo, viewport),
    h('section', { class: 'card', 'aria-labelledby': 'plot-h' },
      h('h2', { id: 'plot-h' }, 'Convergence'), plot, stopReason),
    h('section', { class: 'card', 'aria-labelledby': 'downloads-h' },
      h('h2', { id: 'downloads-h' }, 'Downloads'), downloads),
    reportBox,
    log.el,
    h('details', { class: 'card settings' }, h('summary', {}, 'Settings'),
      facts(Object.entries(first.settings).map(([k, v]) => [k, settingValue(v)]), 'facts mono-values')));

  const offView = onViewChange((_, patch) => {
    if ('zoom' in patch) applyZoom(image.img);
    if ('exposure' in patch && !showRate) refreshImage();
  });

  const hasPassImage = () => job.state === 'running' && (job.latest_pass != null || passes.size > 0);

  function refreshImage() {
    if (gone && job.state !== 'running') return showPlaceholder('The results of this job were removed.');
    if (job.state === 'queued') { image.clear(); return showPlaceholder('The image appears once the job runs.'); }
    if (job.state === 'paused') { image.clear(); return showPlaceholder('This job is paused; it keeps its samples and shows its image again once resumed.'); }
    if (job.state === 'waiting') { image.clear(); return showPlaceholder('This job waits for the jobs it runs after.'); }
    // Failed and canceled jobs keep no results: nothing to ask for (it would be a 410).
    if (job.state === 'failed' || job.state === 'canceled') { image.clear(); return showPlaceholder('This job ended without an image.'); }
    if (job.state === 'running' && !hasPassImage()) { image.clear(); return showPlaceholder('The image appears after the first pass.'); }
    image.show(showRate ? jobPath(id, 'rate.png') : showDenoised ? jobPath(id, 'denoised.png') : jobPath(id, 'image.png', exposureQuery()));
  }

  function drawConvergence() {
    const points = report?.convergence?.points?.length ? report.convergence.points : [...passes.values()].sort((a, b) => a.index - b.index);
    const empty = job.state === 'queued' ? 'The curve grows here pass by pass once the job runs.'
      : job.state === 'running' ? 'Waiting for the first pass with an error estimate.'
        : 'No convergence data.';
    drawPlot(plot, convergenceSeries(points), { empty });
    setText(stopReason, stopReasonText(report));
  }

  function drawDownloads() {
    const pass = hasPassImage();
    // A denoising job whose render ended before two samples a pixel has no denoised image: its
    // status then links to none (the server answers 404 not-denoised).
    const denoisedMade = denoises && job.links?.denoised_png != null;
    const key = `${job.state}|${pass}|${gone}|${denoisedMade}`;
    if (key === downloadsKey) return;
    downloadsKey = key;
    const link = (elId, file, label, hint) => h('li', {}, downloadLink({ id: elId, path: jobPath(id, file), filename: `tessera-${id}-${file}`, label, hint }));
    if (job.state === 'succeeded' && !gone) {
      downloads.replaceChildren(h('ul', { class: 'downloads' },
        link('download-png', 'image.png', 'Image (PNG, sRGB)'),
        link('download-exr', 'image.exr', 'Image (OpenEXR, linear, with sample counts)'),
        link('download-rate', 'rate.png', 'Sample-rate map (PNG)'),
        link('download-report', 'report.json', 'Report (JSON)'),
        link('download-csv', 'convergence.csv', 'Convergence (CSV)'),
        link('download-svg', 'convergence.svg', 'Convergence plot (SVG)'),
        ...(denoisedMade ? [link('download-denoised', 'denoised.png', 'Denoised image (PNG, sRGB)'),
          link('download-denoised-exr', 'denoised.exr', 'Denoised image (OpenEXR, linear)')] : []),
        ...((first.settings.passes || []).length ? [link('download-passes', 'passes.exr', 'Passes (multilayer OpenEXR)')] : [])));
    } else if (pass) {
      downloads.replaceChildren(h('ul', { class: 'downloads' },
        link('download-png', 'image.png', 'Image (PNG, sRGB)', '— the latest pass'),
        link('download-exr', 'image.exr', 'Image (OpenEXR, linear)', '— the latest pass'),
        link('download-rate', 'rate.png', 'Sample-rate map (PNG)', '— the latest pass')));
    } else {
      downloads.replaceChildren(h('p', { class: 'muted' }, gone ? 'The results were removed.'
        : isActive(job.state) ? 'The downloads appear once the job has an image.' : 'This job has no results to download.'));
    }
  }

  function drawReport() {
    reportBox.replaceChildren(...reportSections(report, job));
  }

  async function loadReport() {
    if (gone) return;
    try {
      report = await api.report(id, { signal: image.controller.signal });
    } catch (e) {
      if (e.name === 'AbortError') return;
      report = null;
      if (e.status === 410 && job.state === 'succeeded') gone = true;
    }
    drawConvergence();
    drawReport();
    drawDownloads();
  }

  function pass(p) {
    if (!p || passes.has(p.index)) return;
    passes.set(p.index, p);
    if (!report) drawConvergence();
    if (job.state === 'running') {
      drawDownloads();
      refreshImage();
    }
  }

  function update(j, prev) {
    job = j;
    log.refresh(prev !== j.state);
    if (j.latest_pass) pass(j.latest_pass);
    if (prev !== j.state) {
      if (j.state === 'succeeded') loadReport();
      else { drawConvergence(); drawReport(); drawDownloads(); }
      refreshImage();
    }
    drawDownloads();
  }

  update(first, undefined);
  return {
    update,
    pass: (p, j) => { job = j; pass(p); },
    resultsRemoved() {
      gone = true;
      report = null;
      image.clear();
      refreshImage();
      drawConvergence();
      drawReport();
      drawDownloads();
    },
    destroy() { offView(); image.destroy(); },
  };
}

export function mount(root, { id }) {
  const controller = new AbortController();
  const signal = controller.signal;
  const view = h('div', { id: 'job-view', 'data-state': 'loading', class: 'stack' }, h('p', { class: 'placeholder' }, 'Loading the job…'));
  root.append(
    h('p', { class: 'crumbs' }, h('a', { href: '#/' }, '← Queue')),
    h('h1', { tabindex: '-1' }, 'Job ', h('span', { class: 'mono' }, shortId(id))),
    view);

  let job = null;
  let body = null;
  let stream = null;
  let lastEventAt = Date.now();
  let ui = null;

  function buildHeader(j) {
    const badge = h('span', { class: 'badge-slot' });
    const progress = h('progress', { id: 'job-progress', max: 1, value: 0, 'aria-label': 'Progress' });
    const pct = h('span', { class: 'pct' });
    const detail = h('span', { class: 'muted' });
    const error = h('div', { class: 'notice error', role: 'alert', hidden: true });
    const placement = h('div', { id: 'job-placement', class: 'notice', hidden: true });
    const failures = h('div', { id: 'task-failures', class: 'notice', hidden: true });
    const cancel = h('button', { type: 'button', id: 'cancel-job', class: 'danger' }, 'Cancel job');
    const pause = h('button', { type: 'button', id: 'pause-job', class: 'secondary' }, 'Pause');
    const resume = h('button', { type: 'button', id: 'resume-job', class: 'secondary' }, 'Resume');
    const remove = h('button', { type: 'button', id: 'remove-results', class: 'secondary' }, 'Remove results');
    const compare = h('a', { id: 'compare-link', class: 'button secondary', href: `#/compare?a=${encodeURIComponent(j.id)}` }, 'Compare with another job');
    const times = h('p', { class: 'muted meta' });
    cancel.addEventListener('click', async () => {
      cancel.disabled = true;
      const s = await cancelJob(j.id);
      cancel.disabled = false;
      if (s) applyStatus(s);
    });
    for (const [button, action] of [[pause, pauseJob], [resume, resumeJob]])
      button.addEventListener('click', async () => {
        button.disabled = true;
        const s = await action(j.id);
        button.disabled = false;
        if (s) applyStatus(s);
      });
    remove.addEventListener('click', async () => {
      if (await removeResults(j.id)) body?.resultsRemoved?.();
    });
    view.replaceChildren(
      h('div', { class: 'job-head card' },
        h('p', { class: 'meta' }, h('strong', {}, isComparison(j) ? `Comparison of ${j.settings.scene}` : j.settings.scene),
          ` · ${jobSize(j)}`, j.settings.spp ? ` · ${j.settings.spp} spp` : '', ' · ', h('span', { class: 'mono', title: 'Job id' }, j.id)),
        h('div', { class: 'status-line' }, badge, h('span', { class: 'progress-wrap' }, progress, pct), detail),
        times, error, placement, failures,
        h('div', { class: 'actions' }, pause, resume, cancel, remove, compare)));
    return { badge, progress, pct, detail, error, placement, failures, cancel, pause, resume, remove, compare, times, state: null };
  }

  function tick() {
    if (!ui || !job) return;
    const e = elapsedSeconds(job);
    const left = remainingSeconds(job);
    let text = '';
    if (job.state === 'queued') text = job.queue_position != null ? `Position ${job.queue_position + 1} in the queue` : 'Waiting to start';
    else if (job.state === 'paused') text = 'Paused: its samples are kept until it is resumed';
    else if (job.state === 'running') {
      const p = job.progress || {};
      text = [p.tiles_total ? `tiles ${p.tiles_done} of ${p.tiles_total}` : null, `running for ${fmtDuration(e)}`, left != null ? `about ${fmtDuration(left)} left` : null].filter(Boolean).join(' · ');
    } else if (e != null) text = `${job.state === 'succeeded' ? 'took' : 'after'} ${fmtDuration(e)}`;
    if (job.attempts > 1) text += ` · attempt ${job.attempts}`;
    setText(ui.detail, text);
  }

  function applyStatus(j) {
    if (!j || j.id !== id) return;
    // A status fetched before an event that already said "finished" must not undo it.
    if (job && isFinal(job.state) && isActive(j.state)) return;
    const prev = job?.state;
    job = j;
    if (!ui) ui = buildHeader(j);
    view.dataset.state = j.state;
    if (ui.state !== j.state) {
      ui.badge.replaceChildren(stateBadge(j.state));
      ui.state = j.state;
    }
    const f = j.state === 'succeeded' ? 1 : j.progress?.fraction || 0;
    ui.progress.value = f;
    ui.progress.setAttribute('aria-valuetext', fmtPercent(f));
    setText(ui.pct, fmtPercent(f));
    ui.cancel.hidden = !isActive(j.state);
    ui.pause.hidden = !canPause(j.state);
    ui.resume.hidden = j.state !== 'paused';
    ui.remove.hidden = !isFinal(j.state);
    ui.compare.hidden = j.state !== 'succeeded' || isComparison(j);
    ui.error.hidden = !j.error;
    setText(ui.error, j.error ? `The job failed: ${j.error}` : '');
    // A farm's: why no node takes it now, and the tasks that failed (and where).
    ui.placement.hidden = !j.unplaceable;
    setText(ui.placement, j.unplaceable ? `No render node can take it now: ${j.unplaceable}` : '');
    const tf = j.task_failures;
    ui.failures.hidden = !tf;
    if (tf) {
      ui.failures.replaceChildren(
        h('p', {}, `${tf.failures} failed task${tf.failures === 1 ? '' : 's'}`,
          tf.blocklisted.length ? `; blocklisted: ${tf.blocklisted.join(', ')}` : '', '. The latest:'),
        h('ul', {}, tf.latest.map((r) => h('li', { class: 'mono' }, r))));
    }
    setText(ui.times, [`Submitted ${fmtTime(j.created_at)}`, j.started_at ? `started ${fmtTime(j.started_at)}` : null,
      j.finished_at ? `finished ${fmtTime(j.finished_at)}` : null, `priority ${j.priority}`].filter(Boolean).join(' · '));
    tick();
    if (!body) {
      const box = h('div', { class: 'stack' });
      view.append(box);
      body = isComparison(j) ? comparisonView(box, j) : isShot(j) ? shotView(box, j) : renderBody(box, j);
    } else body.update(j, prev);
    if (prev && prev !== j.state) announce(`Job ${shortId(id)} ${stateLabel(j.state).toLowerCase()}`);
  }

  async function refresh() {
    try { applyStatus(await api.job(id, { signal })); } catch (e) { if (e.name !== 'AbortError') console.warn('job status', e); }
  }

  function onEvent(type, data) {
    if (type === 'reset') { refresh(); return; }
    const j = data?.job;
    if (!j || j.id !== id) return;
    lastEventAt = Date.now();
    if (type === 'pass' && data.pass && body?.pass && !(job && isFinal(job.state))) body.pass(data.pass, j);
    applyStatus(j);
  }

  api.job(id, { signal }).then((j) => {
    applyStatus(j);
    stream = openEventStream({ job: id, onEvent, onOpen: ({ resumed }) => { if (!resumed) refresh(); } });
  }).catch((e) => {
    if (e.name === 'AbortError') return;
    view.dataset.state = 'error';
    view.replaceChildren(h('p', { class: 'notice error', role: 'alert' },
      e.status === 404 ? `There is no job ${id}. ` : `The job could not be loaded: ${e.message} `,
      h('a', { href: '#/' }, 'Back to the queue')));
  });

  // The fallback for a stream that is down or carries no events for this job (a render farm
  // sends no pass events; a proxy may buffer the stream).
  const poll = setInterval(() => {
    if (job && isActive(job.state) && Date.now() - lastEventAt > STALE_MS) {
      lastEventAt = Date.now();
      refresh();
    }
  }, 1000);
  const ticker = setInterval(() => { if (job?.state === 'running') tick(); }, 1000);

  return () => {
    controller.abort();
    stream?.close();
    clearInterval(poll);
    clearInterval(ticker);
    body?.destroy();
  };
}
