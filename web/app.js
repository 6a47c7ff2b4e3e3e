// The page shell: hash routes to views, the navigation state, the access-token form and the
// live-connection indicator. Each view's mount(root, {id, query}) returns its cleanup.

import { getToken, setToken } from '/ui/api.js';
import { h } from '/ui/dom.js';
import { shortId } from '/ui/format.js';
import { announce } from '/ui/notify.js';
import * as compare from '/ui/compare.js';
import * as jobView from '/ui/job_view.js';
import * as queue from '/ui/queue.js';
import * as submit from '/ui/submit.js';

const ROUTES = [
  { re: /^\/$/, view: queue, title: 'Queue', nav: 'nav-queue' },
  { re: /^\/jobs\/([^/?]+)$/, view: jobView, title: 'Job', nav: 'nav-queue' },
  { re: /^\/submit$/, view: submit, title: 'Submit a job', nav: 'nav-submit' },
  { re: /^\/compare$/, view: compare, title: 'Compare jobs', nav: 'nav-compare' },
];

const main = document.getElementById('main');
let unmount = null;
let firstRoute = true;

function parseHash() {
  const raw = location.hash.replace(/^#/, '') || '/';
  const q = raw.indexOf('?');
  return {
    path: (q < 0 ? raw : raw.slice(0, q)) || '/',
    query: new URLSearchParams(q < 0 ? '' : raw.slice(q + 1)),
  };
}

function leave() {
  if (!unmount) return;
  try { unmount(); } catch (e) { console.error('leaving view', e); }
  unmount = null;
}

function route() {
  leave();
  main.replaceChildren();
  const { path, query } = parseHash();
  let match = null;
  for (const r of ROUTES) {
    const m = r.re.exec(path);
    if (m) { match = { r, id: m[1] && decodeURIComponent(m[1]) }; break; }
  }
  for (const a of document.querySelectorAll('.nav a')) a.removeAttribute('aria-current');
  if (!match) {
    document.title = 'Not found · Tessera';
    main.append(h('h1', { tabindex: '-1' }, 'Page not found'),
      h('p', {}, 'There is nothing at this address. ', h('a', { href: '#/' }, 'Go to the queue.')));
  } else {
    // "page" only where the link leads exactly here; a job page is part of the queue section.
    document.getElementById(match.r.nav)?.setAttribute('aria-current', path === '/' || !match.id ? 'page' : 'true');
    document.title = `${match.r.title}${match.id ? ` ${shortId(match.id)}` : ''} · Tessera`;
    try {
      unmount = match.r.view.mount(main, { id: match.id, query }) || null;
    } catch (e) {
      console.error(e);
      main.append(h('p', { class: 'notice error', role: 'alert' }, `This page failed to open: ${e.message}`));
    }
  }
  // Moving focus to the new heading tells screen-reader users the page changed; not on first
  // load, where the browser's own focus handling is expected.
  if (!firstRoute) (main.querySelector('h1') || main).focus();
  firstRoute = false;
}

// The access token form.
const dialog = document.getElementById('token-dialog');
const tokenForm = document.getElementById('token-form');
const tokenInput = document.getElementById('token-input');
const tokenMessage = document.getElementById('token-message');
const tokenButton = document.getElementById('token-button');
const forgetButton = document.getElementById('token-forget');

function syncTokenButton(shown) {
  if (shown || getToken()) tokenButton.hidden = false;
  forgetButton.hidden = !getToken();
}

function openTokenForm(reason) {
  if (dialog.open) return;
  tokenMessage.textContent = reason;
  tokenInput.value = '';
  tokenInput.removeAttribute('aria-invalid');
  syncTokenButton(true);
  dialog.showModal();
  tokenInput.focus();
}

// Dismissed by the user: later refusals (the background refreshes get one every few seconds)
// leave it closed; the Access token button opens it again.
let tokenDismissed = false;
window.addEventListener('tessera:unauthorized', () => {
  if (tokenDismissed) { syncTokenButton(true); return; }
  openTokenForm(getToken()
    ? 'The server did not accept the saved access token. Enter another one.'
    : 'This server needs an access token. Enter one to continue.');
});
tokenButton.addEventListener('click', () => (tokenDismissed = false, openTokenForm('The access token is kept in this browser and sent with every request.')));
tokenForm.addEventListener('submit', (ev) => {
  ev.preventDefault();
  const token = tokenInput.value.trim();
  if (!token) {
    tokenMessage.textContent = 'Enter a token.';
    tokenInput.setAttribute('aria-invalid', 'true');
    tokenInput.focus();
    return;
  }
  setToken(token);
  tokenDismissed = false;
  dialog.close();
  syncTokenButton(true);
  announce('Access token saved');
  route();
});
forgetButton.addEventListener('click', () => {
  setToken('');
  dialog.close();
  syncTokenButton(true);
  announce('Access token removed');
  route();
});
document.getElementById('token-cancel').addEventListener('click', () => { tokenDismissed = true; dialog.close(); });
dialog.addEventListener('cancel', () => { tokenDismissed = true; });  // Escape

// The connection indicator: text as well as colour.
const conn = document.getElementById('conn-status');
const CONN_TEXT = { live: 'Live', connecting: 'Connecting…', reconnecting: 'Reconnecting…', offline: 'Offline' };
window.addEventListener('tessera:stream', (ev) => {
  const state = ev.detail.state;
  conn.dataset.state = state;
  conn.hidden = !CONN_TEXT[state];
  conn.textContent = CONN_TEXT[state] || '';
  conn.title = state === 'live' ? 'Receiving live updates from the server' : 'Live updates are not flowing; the page refreshes by itself meanwhile';
});

document.getElementById('skip-link').addEventListener('click', (ev) => {
  ev.preventDefault();
  (main.querySelector('h1') || main).focus();
});

window.addEventListener('hashchange', route);
// Streams and timers stop when the page is left, and start again if it comes back from the
// back-forward cache.
window.addEventListener('pagehide', leave);
window.addEventListener('pageshow', (ev) => { if (ev.persisted) route(); });

syncTokenButton(false);
route();
