// The Tessera HTTP API: every request the page makes goes through here, so the bearer token
// (when the server wants one) is sent everywhere, including image and file downloads.

const TOKEN_KEY = 'tessera.token';

// A failed request, carrying the RFC 9457 problem the server sent (type, title, detail, field).
export class ApiError extends Error {
  constructor(status, problem = {}) {
    super(problem.detail || problem.title || `HTTP ${status}`);
    this.name = 'ApiError';
    this.status = status;
    this.problem = problem;
    this.title = problem.title;
    this.detail = problem.detail;
    this.field = problem.field;
  }
}

export function getToken() {
  try { return localStorage.getItem(TOKEN_KEY) || ''; } catch { return ''; }
}

export function setToken(token) {
  try {
    if (token) localStorage.setItem(TOKEN_KEY, token);
    else localStorage.removeItem(TOKEN_KEY);
  } catch { /* private mode: the token lives as long as the page does */ }
  window.dispatchEvent(new CustomEvent('tessera:token'));
}

export function authHeaders() {
  const t = getToken();
  return t ? { Authorization: `Bearer ${t}` } : {};
}

// The app shows the token form; views only see the rejected request.
export function reportUnauthorized(problem) {
  window.dispatchEvent(new CustomEvent('tessera:unauthorized', { detail: problem }));
}

export async function problemOf(res) {
  const text = await res.text().catch(() => '');
  try {
    const p = JSON.parse(text);
    if (p && typeof p === 'object') return p;
  } catch { /* not JSON: a proxy's error page, say */ }
  return { title: res.statusText || `HTTP ${res.status}`, status: res.status, detail: text.trim().slice(0, 300) || undefined };
}

export async function request(path, { method = 'GET', json, body, headers = {}, signal } = {}) {
  const h = { ...authHeaders(), ...headers };
  if (json !== undefined) {
    h['Content-Type'] = 'application/json';
    body = JSON.stringify(json);
  }
  let res;
  try {
    // no-store: a running job's image.png changes with every pass under the same URL.
    res = await fetch(path, { method, headers: h, body, signal, cache: 'no-store' });
  } catch (e) {
    if (e.name === 'AbortError') throw e;
    throw new ApiError(0, { title: 'Network error', detail: 'The server cannot be reached.' });
  }
  if (res.ok) return res;
  const problem = await problemOf(res);
  if (res.status === 401) reportUnauthorized(problem);
  throw new ApiError(res.status, problem);
}

const getJson = (path, opts) => request(path, opts).then((r) => r.json());
const enc = encodeURIComponent;

export function query(params = {}) {
  const q = new URLSearchParams();
  for (const [k, v] of Object.entries(params)) if (v != null && v !== '') q.set(k, v);
  const s = q.toString();
  return s ? `?${s}` : '';
}

export const jobPath = (id, file = '', params) => `/v1/jobs/${enc(id)}${file ? `/${file}` : ''}${query(params)}`;

export const api = {
  listJobs: ({ state, limit, offset } = {}, opts) => getJson(`/v1/jobs${query({ state, limit, offset })}`, opts),
  job: (id, opts) => getJson(jobPath(id), opts),
  submitJob: (job, opts) => getJson('/v1/jobs', { ...opts, method: 'POST', json: job }),
  submitComparison: (job, opts) => getJson('/v1/comparisons', { ...opts, method: 'POST', json: job }),
  cancelJob: (id, opts) => getJson(jobPath(id), { ...opts, method: 'DELETE' }),
  pauseJob: (id, opts) => getJson(`${jobPath(id)}:pause`, { ...opts, method: 'POST' }),
  resumeJob: (id, opts) => getJson(`${jobPath(id)}:resume`, { ...opts, method: 'POST' }),
  deleteResults: (id, opts) => request(jobPath(id, 'results'), { ...opts, method: 'DELETE' }).then(() => true),
  report: (id, opts) => getJson(jobPath(id, 'report.json'), opts),
  scenes: (opts) => getJson('/v1/scenes', opts),
  nodes: (opts) => getJson('/v1/nodes', opts),
  jobSchema: (opts) => getJson('/v1/job-schema', opts),
  uploadScene: (name, file, opts) => getJson(`/v1/scenes${query({ name })}`, {
    ...opts, method: 'POST', body: file, headers: { 'Content-Type': 'application/octet-stream' },
  }),
  // Binary results come back as a Blob plus the headers (a running job's pass number lives there).
  async blob(path, opts) {
    const res = await request(path, opts);
    return { blob: await res.blob(), headers: res.headers };
  },
};
