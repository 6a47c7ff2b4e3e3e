// Download links for job results. A plain link cannot carry the bearer token, so a click
// fetches the file through the API and saves the blob; the href stays the real URL so the link
// still reads (and copies) as what it is.

import { api } from '/ui/api.js';
import { h } from '/ui/dom.js';
import { toastError } from '/ui/notify.js';

async function save(path, filename, link) {
  link.setAttribute('aria-busy', 'true');
  try {
    const { blob } = await api.blob(path);
    const url = URL.createObjectURL(blob);
    const a = h('a', { href: url, download: filename, hidden: true });
    document.body.append(a);
    a.click();
    a.remove();
    // Revoking at once can cancel the download in some browsers.
    setTimeout(() => URL.revokeObjectURL(url), 60_000);
  } catch (e) {
    toastError(e, `Download of ${filename} failed: `);
  } finally {
    link.removeAttribute('aria-busy');
  }
}

export function downloadLink({ id, path, filename, label, hint }) {
  const a = h('a', { id, href: path, download: filename, class: 'download' }, label, hint && h('span', { class: 'muted' }, ` ${hint}`));
  a.addEventListener('click', (ev) => {
    if (ev.button !== 0 || ev.metaKey || ev.ctrlKey || ev.shiftKey || ev.altKey) return;
    ev.preventDefault();
    if (!a.hasAttribute('aria-busy')) save(path, filename, a);
  });
  return a;
}
