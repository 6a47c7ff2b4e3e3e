// How numbers, durations and times read on the page.

const integer = new Intl.NumberFormat(undefined, { maximumFractionDigits: 0 });

export const shortId = (id) => String(id ?? '').slice(0, 8);

export function fmtInt(n) {
  return Number.isFinite(n) ? integer.format(n) : '—';
}

// Three significant digits, switching to exponent form where fixed notation gets unreadable
// (relative MSE spans 1e-6 … 1). From 100 up the whole number: 1024 spp must not read 1020.
export function fmtSci(x) {
  if (x == null || !Number.isFinite(x)) return '—';
  if (x === 0) return '0';
  const a = Math.abs(x);
  if (a >= 100 && a < 1e9) return integer.format(Math.round(x));
  if (a >= 1e-3 && a < 1e5) return String(Number(x.toPrecision(3)));
  return x.toExponential(2).replace('e+', 'e');
}

export function fmtDuration(s) {
  if (s == null || !Number.isFinite(s)) return '—';
  s = Math.max(0, s);
  if (s < 1e-3) return `${Math.round(s * 1e6)} µs`;
  if (s < 0.01) return `${(s * 1e3).toFixed(1)} ms`;
  if (s < 1) return `${Math.round(s * 1e3)} ms`;
  if (s < 10) return `${s.toFixed(2)} s`;
  if (s < 60) return `${s.toFixed(1)} s`;
  const t = Math.round(s);
  if (t < 3600) return `${Math.floor(t / 60)} min ${String(t % 60).padStart(2, '0')} s`;
  return `${Math.floor(t / 3600)} h ${String(Math.floor((t % 3600) / 60)).padStart(2, '0')} min`;
}

export function fmtBytes(n) {
  if (!Number.isFinite(n)) return '—';
  const units = ['B', 'KiB', 'MiB', 'GiB'];
  let i = 0;
  while (n >= 1024 && i < units.length - 1) { n /= 1024; i++; }
  return `${i ? n.toFixed(1) : n} ${units[i]}`;
}

export function fmtTime(unix) {
  if (unix == null) return '—';
  return new Date(unix * 1000).toLocaleString(undefined, { dateStyle: 'medium', timeStyle: 'medium' });
}

// Whole percent, rounded down so a job shows 100 % only when it is done.
export const fmtPercent = (f) => `${Math.floor(Math.max(0, Math.min(1, f || 0)) * 100)} %`;

export function fmtEv(ev) {
  const v = Number(ev) || 0;
  return `${v > 0 ? '+' : v < 0 ? '−' : '±'}${Math.abs(v).toFixed(1)} EV`;
}

export function humanize(key) {
  const s = String(key).replace(/_/g, ' ');
  return s.charAt(0).toUpperCase() + s.slice(1);
}
