// Log-log line plots drawn as inline SVG: error against render time, one or more curves.

import { svg } from '/ui/dom.js';
import { fmtDuration, fmtSci } from '/ui/format.js';

const W = 640;
const PLOT_H = 280;
const PAD = { l: 64, r: 20, t: 14, b: 46 };
const LEGEND_ROW = 20;
// Curves differ by dash and marker too, not only by colour.
const DASHES = ['', '7 4', '2 3', '9 3 2 3'];
const MARKERS = ['circle', 'square', 'triangle', 'diamond'];
const SUPERSCRIPT = { '-': '⁻', 0: '⁰', 1: '¹', 2: '²', 3: '³', 4: '⁴', 5: '⁵', 6: '⁶', 7: '⁷', 8: '⁸', 9: '⁹' };

const log10 = Math.log10;

function decades(values) {
  let min = Infinity;
  let max = -Infinity;
  for (const v of values) { if (v < min) min = v; if (v > max) max = v; }
  const lo = Math.floor(log10(min) + 1e-9);
  let hi = Math.ceil(log10(max) - 1e-9);
  if (hi <= lo) hi = lo + 1;
  return { lo, hi };
}

// Seconds read best as plain numbers (0.01, 100); errors as powers of ten.
function decadeLabel(k, plain) {
  if (plain && k >= -3 && k <= 4) return String(Number(`1e${k}`));
  return `10${String(k).split('').map((c) => SUPERSCRIPT[c]).join('')}`;
}

function marker(shape, x, y, cls) {
  const r = 3.5;
  if (shape === 'square') return svg('rect', { x: x - r, y: y - r, width: 2 * r, height: 2 * r, class: cls });
  if (shape === 'triangle') return svg('polygon', { points: `${x},${y - r - 1} ${x + r + 0.5},${y + r} ${x - r - 0.5},${y + r}`, class: cls });
  if (shape === 'diamond') return svg('polygon', { points: `${x},${y - r - 1} ${x + r + 1},${y} ${x},${y + r + 1} ${x - r - 1},${y}`, class: cls });
  return svg('circle', { cx: x, cy: y, r, class: cls });
}

// series: [{label, points: [{x, y}], style?}]. Points that a log axis cannot show (zero,
// negative, missing) are left out.
export function drawPlot(el, series, { xLabel = 'Render time (s)', yLabel = 'Relative MSE', empty = 'No error estimates yet.' } = {}) {
  const data = series
    .map((s, i) => ({
      ...s,
      style: s.style ?? i,
      points: s.points.filter((p) => p.x > 0 && p.y > 0 && Number.isFinite(p.x) && Number.isFinite(p.y)).sort((a, b) => a.x - b.x),
    }))
    .filter((s) => s.points.length);

  const legendH = data.length ? data.length * LEGEND_ROW + 6 : 0;
  const H = PAD.t + PLOT_H + PAD.b + legendH;
  el.replaceChildren();
  el.setAttribute('viewBox', `0 0 ${W} ${H}`);
  el.setAttribute('role', 'img');
  el.classList.add('plot');

  if (!data.length) {
    el.append(svg('text', { x: W / 2, y: PAD.t + PLOT_H / 2, 'text-anchor': 'middle', class: 'plot-empty' }, empty));
    el.setAttribute('aria-label', `${yLabel} against ${xLabel}: ${empty}`);
    return;
  }

  const xr = decades(data.flatMap((s) => s.points.map((p) => p.x)));
  const yr = decades(data.flatMap((s) => s.points.map((p) => p.y)));
  const x0 = PAD.l;
  const x1 = W - PAD.r;
  const y0 = PAD.t + PLOT_H;
  const X = (v) => x0 + ((log10(v) - xr.lo) / (xr.hi - xr.lo)) * (x1 - x0);
  const Y = (v) => y0 - ((log10(v) - yr.lo) / (yr.hi - yr.lo)) * PLOT_H;

  const grid = svg('g', { class: 'plot-grid', 'aria-hidden': 'true' });
  const labels = svg('g', { class: 'plot-labels', 'aria-hidden': 'true' });
  const axis = (range, horizontal) => {
    const span = range.hi - range.lo;
    const every = span > 8 ? 2 : 1;
    for (let k = range.lo; k <= range.hi; k++) {
      const v = 10 ** k;
      if (horizontal) {
        grid.append(svg('line', { x1: X(v), x2: X(v), y1: PAD.t, y2: y0, class: 'major' }));
        if ((k - range.lo) % every === 0) labels.append(svg('text', { x: X(v), y: y0 + 16, 'text-anchor': 'middle' }, decadeLabel(k, true)));
      } else {
        grid.append(svg('line', { x1: x0, x2: x1, y1: Y(v), y2: Y(v), class: 'major' }));
        if ((k - range.lo) % every === 0) labels.append(svg('text', { x: x0 - 8, y: Y(v) + 4, 'text-anchor': 'end' }, decadeLabel(k, false)));
      }
      if (k === range.hi) break;
      for (let m = 2; m <= 9; m++) {
        const mv = m * v;
        if (horizontal) grid.append(svg('line', { x1: X(mv), x2: X(mv), y1: y0 - 5, y2: y0, class: 'minor' }));
        else grid.append(svg('line', { x1: x0, x2: x0 + 5, y1: Y(mv), y2: Y(mv), class: 'minor' }));
        // One decade alone gives only two labels; 2 and 5 make the scale readable.
        if (span === 1 && (m === 2 || m === 5)) {
          if (horizontal) labels.append(svg('text', { x: X(mv), y: y0 + 16, 'text-anchor': 'middle', class: 'minor-label' }, fmtSci(mv)));
          else labels.append(svg('text', { x: x0 - 8, y: Y(mv) + 4, 'text-anchor': 'end', class: 'minor-label' }, fmtSci(mv)));
        }
      }
    }
  };
  axis(xr, true);
  axis(yr, false);
  grid.append(svg('rect', { x: x0, y: PAD.t, width: x1 - x0, height: PLOT_H, class: 'frame' }));
  labels.append(
    svg('text', { x: (x0 + x1) / 2, y: y0 + 36, 'text-anchor': 'middle', class: 'axis-title' }, xLabel),
    svg('text', { x: 0, y: 0, transform: `translate(16 ${PAD.t + PLOT_H / 2}) rotate(-90)`, 'text-anchor': 'middle', class: 'axis-title' }, yLabel),
  );
  el.append(grid, labels);

  const legendY = y0 + PAD.b + 4;
  data.forEach((s, i) => {
    const cls = `s${s.style % 6}`;
    const shape = MARKERS[s.style % MARKERS.length];
    const dash = DASHES[s.style % DASHES.length] || null;
    const g = svg('g', { class: `series ${cls}` });
    const d = s.points.map((p, j) => `${j ? 'L' : 'M'}${X(p.x).toFixed(1)} ${Y(p.y).toFixed(1)}`).join(' ');
    g.append(svg('path', { d, class: 'line', 'stroke-dasharray': dash }));
    for (const p of s.points) {
      const m = marker(shape, X(p.x), Y(p.y), 'marker');
      m.append(svg('title', {}, `${s.label}: ${fmtSci(p.y)} at ${fmtDuration(p.x)}${p.note ? ` (${p.note})` : ''}`));
      g.append(m);
    }
    el.append(g);

    const ly = legendY + i * LEGEND_ROW + 10;
    el.append(svg('g', { class: `legend ${cls}` },
      svg('line', { x1: x0, x2: x0 + 28, y1: ly, y2: ly, class: 'line', 'stroke-dasharray': dash }),
      marker(shape, x0 + 14, ly, 'marker'),
      svg('text', { x: x0 + 38, y: ly + 4 }, s.label)));
  });

  const summary = data.map((s) => {
    const a = s.points[0];
    const b = s.points[s.points.length - 1];
    return `${s.label}: ${s.points.length} points, from ${fmtSci(a.y)} at ${fmtDuration(a.x)} to ${fmtSci(b.y)} at ${fmtDuration(b.x)}`;
  });
  el.setAttribute('aria-label', `${yLabel} against ${xLabel}, log-log. ${summary.join('; ')}.`);
}

// A render report's convergence points as plot series: the half-buffer estimate, the error
// against the reference job when the job had one, and a denoising job's denoised image's.
export function convergenceSeries(points, label = '', style = 0) {
  const est = [];
  const ref = [];
  const den = [];
  const denRef = [];
  for (const p of points || []) {
    const note = p.spp_mean != null ? `${Number(p.spp_mean.toFixed(1))} spp` : '';
    if (p.est_rel_mse != null) est.push({ x: p.seconds, y: p.est_rel_mse, note });
    if (p.rel_mse != null) ref.push({ x: p.seconds, y: p.rel_mse, note });
    if (p.denoised_est_rel_mse != null) den.push({ x: p.seconds, y: p.denoised_est_rel_mse, note });
    if (p.denoised_rel_mse != null) denRef.push({ x: p.seconds, y: p.denoised_rel_mse, note });
  }
  const prefix = label ? `${label}: ` : '';
  const out = [{ label: `${prefix}estimated relative MSE`, points: est, style }];
  if (ref.length) out.push({ label: `${prefix}relative MSE against the reference`, points: ref, style: style + 2 });
  if (den.length) out.push({ label: `${prefix}denoised, estimated relative MSE`, points: den, style: style + 1 });
  if (denRef.length) out.push({ label: `${prefix}denoised, against the reference`, points: denRef, style: style + 3 });
  return out;
}
