// What a job status says, in the words and shapes the page shows it with.

import { h } from '/ui/dom.js';

export const STATES = ['queued', 'waiting', 'running', 'paused', 'succeeded', 'failed', 'canceled'];

const LABELS = {
  queued: 'Queued', waiting: 'Waiting', running: 'Running', paused: 'Paused', succeeded: 'Succeeded', failed: 'Failed', canceled: 'Canceled',
};
// A glyph beside the word, so state never depends on colour alone.
const GLYPHS = { queued: '◷', waiting: '⧗', running: '▶', paused: '⏸', succeeded: '✓', failed: '✕', canceled: '⊘' };

export const stateLabel = (state) => LABELS[state] || state;
// Not finished: it may still change (a paused or waiting job too).
export const isActive = (state) => state === 'queued' || state === 'running' || state === 'paused' || state === 'waiting';
export const isFinal = (state) => !isActive(state);
export const canPause = (state) => state === 'queued' || state === 'running';
export const isComparison = (job) => job?.settings?.kind === 'comparison';

export function stateBadge(state) {
  return h('span', { class: `badge badge-${state}` }, h('span', { 'aria-hidden': 'true' }, GLYPHS[state] || '•'), ' ', stateLabel(state));
}

export function jobSize(job) {
  const s = job?.settings || {};
  return s.width && s.height ? `${s.width}×${s.height}` : '—';
}

export function jobTitle(job) {
  const s = job?.settings || {};
  return isComparison(job) ? `Comparison · ${s.scene}` : s.scene || '—';
}

// Seconds since the job started (or its whole run, once finished). Clamped: the browser's
// clock may run a little behind the server's.
export function elapsedSeconds(job, now = Date.now() / 1000) {
  if (!job?.started_at) return null;
  return Math.max(0, (job.finished_at ?? now) - job.started_at);
}

// A straight extrapolation of the progress so far; shaky in the first percent, so not shown then.
export function remainingSeconds(job, now) {
  const f = job?.progress?.fraction;
  if (job?.state !== 'running' || !(f > 0.01) || f >= 1) return null;
  const e = elapsedSeconds(job, now);
  return e == null ? null : (e * (1 - f)) / f;
}

// One line to tell a job apart in a list of succeeded jobs (compare, reference pickers).
export function jobOptionLabel(job) {
  const s = job.settings || {};
  const spp = s.spp ? ` · ${s.spp} spp` : '';
  return `${job.id.slice(0, 8)} · ${s.scene} · ${jobSize(job)}${spp}`;
}
