// A shot's page body: the frame strip (each frame's state; a written frame opens in the viewer),
// the frame rendering now as it converges, the contact sheet and the preview video once the
// shot is done, and the downloads of the shot and of the frame shown.

import { api, jobPath } from '/ui/api.js';
import { h, setText } from '/ui/dom.js';
import { downloadLink } from '/ui/downloads.js';
import { fmtDuration } from '/ui/format.js';
import { ApiImage, applyZoom, exposureQuery, onViewChange, viewControls } from '/ui/viewer.js';

export const isShot = (job) => job?.settings?.frames != null;

export function shotView(container, first) {
  const id = first.id;
  let job = first;
  let shown = null;        // the frame in the viewer; null: the one rendering (live) or the contact sheet
  let videoUrl = null;
  let gone = false;

  const info = h('p', { id: 'shot-info', class: 'pass-info' });
  const caption = h('p', { id: 'frame-caption', class: 'muted' });
  const placeholder = h('p', { class: 'placeholder' });
  const image = new ApiImage({
    id: 'job-image',
    alt: `Frame of ${first.settings.scene}`,
    onLoad() { placeholder.hidden = true; },
    onError(e) {
      image.clear();
      setText(placeholder, e.status === 409 ? 'The frame appears after its first pass.' : `The image could not be loaded: ${e.message}`);
      placeholder.hidden = false;
    },
  });
  image.img.hidden = true;
  const controls = viewControls();
  const strip = h('ol', { id: 'frame-strip', class: 'frame-strip', 'aria-label': 'Frames' });
  const video = h('video', { id: 'shot-preview', controls: true, loop: true, muted: true, playsinline: true, hidden: true });
  const previewNote = h('p', { class: 'muted' });
  const downloads = h('div');

  container.append(
    h('section', { class: 'card', 'aria-labelledby': 'frames-h' },
      h('h2', { id: 'frames-h' }, 'Frames'), info, strip),
    h('section', { class: 'card', 'aria-labelledby': 'image-h' },
      h('h2', { id: 'image-h' }, 'Image'), h('div', { class: 'toolbar' }, controls.el), caption,
      h('div', { class: 'viewport', tabindex: '0', role: 'region', 'aria-label': 'Image (scrolls when zoomed)' }, image.img, placeholder)),
    h('section', { class: 'card', 'aria-labelledby': 'preview-h' },
      h('h2', { id: 'preview-h' }, 'Preview'), video, previewNote),
    h('section', { class: 'card', 'aria-labelledby': 'downloads-h' },
      h('h2', { id: 'downloads-h' }, 'Downloads'), downloads));

  const offView = onViewChange((_, patch) => {
    if ('zoom' in patch) applyZoom(image.img);
    if ('exposure' in patch) refreshImage();
  });

  const frames = () => job.shot?.frames || [];
  const done = (n) => frames().some((f) => f.frame === n && f.state === 'succeeded');

  function drawStrip() {
    const s = job.shot;
    if (!s) { setText(info, 'Waiting for the shot to start.'); strip.replaceChildren(); return; }
    const parts = [`${s.frames_done} of ${s.frames_total} frames`];
    if (s.mean_frame_s) parts.push(`${fmtDuration(s.mean_frame_s)} a frame`);
    if (job.state === 'running' && s.eta_s != null) parts.push(`about ${fmtDuration(s.eta_s)} left`);
    if (s.current_frame != null) parts.push(`rendering frame ${s.current_frame}`);
    setText(info, parts.join(' · '));
    strip.replaceChildren(...frames().map((f) => {
      const b = h('button', { type: 'button', class: `frame frame-${f.state}`, 'data-frame': String(f.frame),
        'aria-pressed': String(shown === f.frame), disabled: f.state !== 'succeeded',
        title: `Frame ${f.frame}: ${f.state}` }, String(f.frame));
      b.addEventListener('click', () => { shown = f.frame; drawStrip(); refreshImage(); drawDownloads(); });
      return h('li', {}, b);
    }));
  }

  function refreshImage() {
    if (gone) { image.clear(); setText(placeholder, 'The results of this job were removed.'); placeholder.hidden = false; return; }
    if (shown != null && done(shown)) {
      setText(caption, `Frame ${shown}`);
      return image.show(jobPath(id, `frames/${shown}/image.png`, exposureQuery()));
    }
    if (job.state === 'running') {
      // The frame rendering now once it has a pass; before that, the last frame written.
      if (job.latest_pass != null) {
        setText(caption, `Frame ${job.shot?.current_frame ?? ''}, rendering (its latest pass)`);
        return image.show(jobPath(id, 'image.png', exposureQuery()));
      }
      const last = [...frames()].reverse().find((f) => f.state === 'succeeded');
      if (last) {
        setText(caption, `Frame ${last.frame}, the last written`);
        return image.show(jobPath(id, `frames/${last.frame}/image.png`, exposureQuery()));
      }
      image.clear();
      setText(caption, '');
      setText(placeholder, 'The first frame appears after its first pass.');
      placeholder.hidden = false;
      return;
    }
    if (job.state === 'succeeded') {
      setText(caption, 'Contact sheet: every frame');
      return image.show(jobPath(id, 'contact_sheet.png'));
    }
    image.clear();
    setText(caption, '');
    setText(placeholder, job.state === 'queued' ? 'The frames appear once the shot runs.' : 'This shot ended without its contact sheet.');
    placeholder.hidden = false;
  }

  async function loadPreview() {
    if (job.state !== 'succeeded' || videoUrl || gone) return;
    try {
      const { blob } = await api.blob(jobPath(id, 'preview.mp4'), { signal: image.controller.signal });
      videoUrl = URL.createObjectURL(blob);
      video.src = videoUrl;
      video.hidden = false;
      setText(previewNote, `${frames().length || job.shot?.frames_total} frames at ${job.settings.fps} frames a second.`);
    } catch (e) {
      if (e.name === 'AbortError') return;
      setText(previewNote, e.status === 410 ? 'This server wrote no preview (its report says why).' : `The preview could not be loaded: ${e.message}`);
    }
  }

  function drawDownloads() {
    const link = (elId, file, label) => h('li', {}, downloadLink({ id: elId, path: jobPath(id, file), filename: `tessera-${id}-${file.replaceAll('/', '-')}`, label }));
    const items = [];
    if (shown != null && done(shown)) {
      items.push(link('download-frame-exr', `frames/${shown}/image.exr`, `Frame ${shown} (OpenEXR, linear)`),
        link('download-frame-png', `frames/${shown}/image.png`, `Frame ${shown} (PNG)`),
        link('download-frame-report', `frames/${shown}/report.json`, `Frame ${shown} report (JSON)`));
    }
    if (job.state === 'succeeded' && !gone) {
      items.push(link('download-sheet', 'contact_sheet.png', 'Contact sheet (PNG)'),
        link('download-preview', 'preview.mp4', 'Preview (MP4, H.264)'),
        link('download-report', 'report.json', 'Shot report (JSON)'));
    }
    downloads.replaceChildren(items.length ? h('ul', { class: 'downloads' }, ...items)
      : h('p', { class: 'muted' }, 'Pick a written frame in the strip to download it.'));
  }

  function update(j, prev) {
    job = j;
    drawStrip();
    if (prev !== j.state || j.state === 'running') refreshImage();
    if (j.state === 'succeeded') loadPreview();
    drawDownloads();
  }

  update(first, undefined);
  return {
    update,
    pass: (p, j) => { job = { ...j, latest_pass: j.latest_pass ?? p }; if (shown == null) refreshImage(); },
    resultsRemoved() { gone = true; refreshImage(); drawDownloads(); },
    destroy() {
      offView();
      image.destroy();
      if (videoUrl) URL.revokeObjectURL(videoUrl);
    },
  };
}
