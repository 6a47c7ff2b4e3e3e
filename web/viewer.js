// Looking at result images: the zoom and exposure settings (shared by the job and compare
// pages, kept for the session), their controls, and images fetched through the API.

import { api } from '/ui/api.js';
import { h } from '/ui/dom.js';
import { fmtEv } from '/ui/format.js';

const KEY = 'tessera.view';
const ZOOMS = [['fit', 'Fit'], ['1', '1:1'], ['2', '2×'], ['4', '4×'], ['8', '8×']];
export const EV_MIN = -16;
export const EV_MAX = 16;

function loadView() {
  try {
    const v = JSON.parse(sessionStorage.getItem(KEY)) || {};
    return {
      zoom: ZOOMS.some(([z]) => z === v.zoom) ? v.zoom : 'fit',
      exposure: Number.isFinite(v.exposure) ? Math.max(EV_MIN, Math.min(EV_MAX, v.exposure)) : 0,
    };
  } catch { return { zoom: 'fit', exposure: 0 }; }
}

export const view = loadView();
const listeners = new Set();

export function onViewChange(fn) {
  listeners.add(fn);
  return () => listeners.delete(fn);
}

function setView(patch) {
  Object.assign(view, patch);
  try { sessionStorage.setItem(KEY, JSON.stringify(view)); } catch { /* not kept, still applied */ }
  for (const fn of listeners) fn(view, patch);
}

// The query that applies the exposure; omitted at 0 so the plain URL (and any cache) serves.
export const exposureQuery = () => (view.exposure ? { exposure: view.exposure } : undefined);

// The zoom select and the exposure slider. Returns {el, setExposureEnabled(on)}.
export function viewControls() {
  const zoom = h('select', { id: 'zoom', name: 'zoom' }, ZOOMS.map(([v, t]) => h('option', { value: v }, t)));
  zoom.value = view.zoom;
  zoom.addEventListener('change', () => setView({ zoom: zoom.value }));

  const out = h('output', { for: 'exposure', id: 'exposure-value', class: 'mono' }, fmtEv(view.exposure));
  const range = h('input', {
    id: 'exposure', name: 'exposure', type: 'range', min: EV_MIN, max: EV_MAX, step: 0.5,
    value: String(view.exposure), 'aria-valuetext': fmtEv(view.exposure),
  });
  range.addEventListener('input', () => {
    const ev = Number(range.value);
    out.value = fmtEv(ev);
    range.setAttribute('aria-valuetext', fmtEv(ev));
    setView({ exposure: ev });
  });
  const reset = h('button', { type: 'button', class: 'small secondary', title: 'Reset the exposure to 0 EV' }, 'Reset');
  reset.addEventListener('click', () => {
    range.value = '0';
    range.dispatchEvent(new Event('input'));
  });

  const el = h('div', { class: 'view-controls' },
    h('div', { class: 'control' }, h('label', { for: 'zoom' }, 'Zoom'), zoom),
    h('div', { class: 'control exposure' }, h('label', { for: 'exposure' }, 'Exposure'), range, out, reset));
  return {
    el,
    setExposureEnabled(on) {
      range.disabled = !on;
      reset.disabled = !on;
    },
  };
}

// Sizes an image for a zoom level; past 1:1 pixels stay square instead of blurring.
export function applyZoom(img, zoom = view.zoom) {
  const fit = zoom === 'fit';
  img.classList.toggle('zoom-fit', fit);
  img.classList.toggle('pixelated', !fit && Number(zoom) > 1);
  // The element may not have decoded its new src yet; the width measured off-screen stands in.
  const natural = img.naturalWidth || Number(img.dataset.width) || 0;
  img.style.width = !fit && natural ? `${natural * Number(zoom)}px` : '';
}

// An <img> that shows API images through blob: URLs (the only way to send the token).
// Loads coalesce: while one request is in flight, later ones collapse into a single follow-up,
// so a burst of passes or a dragged slider never queues up a backlog of downloads.
export class ApiImage {
  constructor({ id, alt, onLoad, onError }) {
    this.img = h('img', { id, alt, decoding: 'async' });
    this.onLoad = onLoad;
    this.onError = onError;
    this.url = null;
    this.busy = false;
    this.next = null;
    this.controller = new AbortController();
  }

  show(path) {
    if (this.busy) { this.next = path; return; }
    this.load(path);
  }

  async load(path) {
    this.busy = true;
    try {
      const { blob, headers } = await api.blob(path, { signal: this.controller.signal });
      const url = URL.createObjectURL(blob);
      // Decode off-screen first so the visible image swaps without a blank frame.
      const probe = new Image();
      probe.src = url;
      await probe.decode().catch(() => {});
      if (this.controller.signal.aborted) { URL.revokeObjectURL(url); return; }
      this.img.dataset.width = String(probe.naturalWidth || '');
      this.img.src = url;
      if (this.url) URL.revokeObjectURL(this.url);
      this.url = url;
      this.img.hidden = false;
      applyZoom(this.img);
      this.onLoad?.(headers, path);
    } catch (e) {
      // A failure of a request already superseded is not reported: its handler would clear
      // the image and with it the newer request (a pass image's 409 racing the job's end
      // would drop the final image's fetch).
      if (e.name !== 'AbortError' && !this.next) this.onError?.(e, path);
    } finally {
      this.busy = false;
      if (this.next && !this.controller.signal.aborted) {
        const p = this.next;
        this.next = null;
        this.load(p);
      }
    }
  }

  clear() {
    this.next = null;
    this.img.removeAttribute('src');
    this.img.hidden = true;
    if (this.url) URL.revokeObjectURL(this.url);
    this.url = null;
  }

  destroy() {
    this.controller.abort();
    this.clear();
  }
}
