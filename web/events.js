// The server's event stream (GET /v1/events). EventSource cannot send an Authorization
// header, so the stream is read with fetch() and parsed here, following the WHATWG
// Server-Sent Events rules: any of CRLF, LF or CR ends a line, events may be split across
// network chunks at any byte, and several data lines join with "\n".

import { authHeaders, query, reportUnauthorized } from '/ui/api.js';

export class SseParser {
  constructor(onEvent) {
    this.onEvent = onEvent;
    this.buf = '';
    this.type = '';
    this.data = [];
    this.lastId = null;   // the stream's last event id, sent back as Last-Event-ID
    this.retry = null;    // the server's reconnection delay in ms, if it gave one
  }

  push(chunk) {
    this.buf += chunk;
    const re = /\r\n|\r|\n/g;
    let start = 0;
    let m;
    while ((m = re.exec(this.buf))) {
      // A CR at the very end may be the first half of a CRLF still in flight.
      if (m[0] === '\r' && m.index === this.buf.length - 1) break;
      this.line(this.buf.slice(start, m.index));
      start = re.lastIndex;
    }
    this.buf = this.buf.slice(start);
  }

  line(line) {
    if (line === '') return this.dispatch();
    if (line[0] === ':') return;
    const colon = line.indexOf(':');
    const field = colon < 0 ? line : line.slice(0, colon);
    let value = colon < 0 ? '' : line.slice(colon + 1);
    if (value[0] === ' ') value = value.slice(1);
    if (field === 'event') this.type = value;
    else if (field === 'data') this.data.push(value);
    else if (field === 'id') { if (!value.includes('\0')) this.lastId = value; }
    else if (field === 'retry') { if (/^\d+$/.test(value)) this.retry = Number(value); }
  }

  dispatch() {
    const { type, data } = this;
    this.type = '';
    this.data = [];
    if (!data.length) return;
    this.onEvent({ type: type || 'message', data: data.join('\n'), id: this.lastId });
  }
}

// Connection state for the header's indicator; only one stream is open at a time.
function setStatus(state) {
  window.dispatchEvent(new CustomEvent('tessera:stream', { detail: { state } }));
}

const IDLE_MS = 45_000;   // no byte (not even a keep-alive) for this long: the connection is dead
const MAX_BACKOFF_MS = 30_000;

// Opens the stream of all jobs, or of one with {job}. onEvent(type, data) gets parsed JSON;
// onOpen({resumed}) runs on every connection, resumed telling whether Last-Event-ID was sent
// (when it was not, the caller must re-read state: events before this moment are not replayed).
// Returns {close(), get live()}.
export function openEventStream({ job, onEvent, onOpen }) {
  const url = `/v1/events${query({ job })}`;
  let closed = false;
  let live = false;
  let controller = null;
  let wake = null;
  let backoff = 1000;
  let lastId = null;
  let retry = null;

  const sleep = (ms) => new Promise((resolve) => {
    const t = setTimeout(resolve, ms);
    wake = () => { clearTimeout(t); resolve(); };
  });

  async function connectOnce() {
    controller = new AbortController();
    const headers = { ...authHeaders(), Accept: 'text/event-stream' };
    if (lastId != null) headers['Last-Event-ID'] = lastId;
    const res = await fetch(url, { headers, signal: controller.signal, cache: 'no-store' });
    if (closed) return 'ended';
    if (res.status === 401) {
      reportUnauthorized(await res.json().catch(() => ({})));
      return 'unauthorized';
    }
    if (!res.ok || !res.body || !(res.headers.get('Content-Type') || '').includes('text/event-stream')) {
      throw new Error(`event stream: HTTP ${res.status}`);
    }
    const resumed = lastId != null;
    live = true;
    backoff = 1000;
    setStatus('live');
    const parser = new SseParser(({ type, data }) => {
      let payload;
      try { payload = JSON.parse(data); } catch { return; }
      try { onEvent(type, payload); } catch (e) { console.error('event handler', e); }
    });
    try { onOpen?.({ resumed }); } catch (e) { console.error('open handler', e); }

    const reader = res.body.pipeThrough(new TextDecoderStream()).getReader();
    let idle = setTimeout(() => controller.abort(), IDLE_MS);
    try {
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        clearTimeout(idle);
        idle = setTimeout(() => controller.abort(), IDLE_MS);
        parser.push(value);
        lastId = parser.lastId ?? lastId;
        retry = parser.retry ?? retry;
      }
    } finally {
      clearTimeout(idle);
      live = false;
    }
    return 'ended';
  }

  (async () => {
    setStatus('connecting');
    while (!closed) {
      let delay;
      try {
        const outcome = await connectOnce();
        if (outcome === 'unauthorized') { setStatus('offline'); return; }
        // The server ends streams after a while on purpose: come back at once.
        delay = retry ?? 250;
      } catch {
        if (closed) return;
        delay = backoff * (0.75 + Math.random() / 2);   // jitter: many tabs must not reconnect in step
        backoff = Math.min(backoff * 2, MAX_BACKOFF_MS);
      }
      if (closed) return;
      setStatus('reconnecting');
      await sleep(delay);
    }
  })();

  return {
    get live() { return live; },
    close() {
      closed = true;
      live = false;
      controller?.abort();
      wake?.();
      setStatus('closed');
    },
  };
}
