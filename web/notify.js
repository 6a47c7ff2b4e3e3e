// Telling the user what happened: announcements for screen readers and visible toasts.

let pending = [];
let flushTimer = 0;

// Messages arriving together (several jobs finishing in one burst) are read as one sentence:
// replacing the live region's text per message would drop all but the last.
export function announce(message) {
  if (!message) return;
  pending.push(message);
  clearTimeout(flushTimer);
  flushTimer = setTimeout(() => {
    const live = document.getElementById('live');
    if (!live) return;
    live.textContent = pending.join('. ');
    pending = [];
  }, 120);
}

export function toast(message, { kind = 'info', timeout } = {}) {
  const box = document.getElementById('toasts');
  if (!box) return;
  const el = document.createElement('div');
  el.className = `toast toast-${kind}`;
  if (kind === 'error') el.setAttribute('role', 'alert');
  const text = document.createElement('span');
  text.textContent = message;
  const close = document.createElement('button');
  close.type = 'button';
  close.className = 'toast-close';
  close.setAttribute('aria-label', 'Dismiss');
  close.textContent = '×';
  close.addEventListener('click', () => el.remove());
  el.append(text, close);
  box.append(el);
  setTimeout(() => el.remove(), timeout ?? (kind === 'error' ? 12000 : 5000));
}

export function toastError(err, prefix = '') {
  if (err?.name === 'AbortError') return;
  toast(`${prefix}${err?.message || err}`, { kind: 'error' });
}
