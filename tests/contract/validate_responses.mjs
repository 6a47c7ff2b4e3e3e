// Holds a running server's answers to api/openapi.yaml. Every documented operation is called,
// with successes and the errors a client can cause; each answer's status must be documented
// for its operation, its Content-Type must be one the spec lists, the headers the spec
// documents for it must be there, and a JSON body must validate against the schema (ajv with
// draft-04, the dialect OpenAPI 3.0 extends).
//
//   node validate_responses.mjs SPEC BASE_URL TOKEN BROKEN_SCENE
//
// BROKEN_SCENE is a catalog name whose file is broken (a job naming it fails). Exits 1 on any
// mismatch or on an operation never called; statuses documented but not provoked here are
// listed (their causes, a full disk or an unwritable store, are the fault tests' work).
import fs from 'node:fs';
import yaml from 'js-yaml';
import Ajv from 'ajv-draft-04';

const [specPath, base, token, brokenScene] = process.argv.slice(2);
if (!brokenScene) {
  console.error('usage: node validate_responses.mjs SPEC BASE_URL TOKEN BROKEN_SCENE');
  process.exit(2);
}
const spec = yaml.load(fs.readFileSync(specPath, 'utf8'));

// OpenAPI 3.0's `nullable` is not JSON Schema: turn it into a type union; point refs at the
// components document registered under the id "spec".
function toJsonSchema(node) {
  if (Array.isArray(node)) return node.map(toJsonSchema);
  if (!node || typeof node !== 'object') return node;
  const out = {};
  for (const [k, v] of Object.entries(node)) {
    if (k === '$ref' && typeof v === 'string') out[k] = v.replace('#/components/', 'spec#/components/');
    else if (k === 'nullable' || k === 'example') continue;
    else out[k] = toJsonSchema(v);
  }
  if (node.nullable === true && out.type) out.type = [].concat(out.type, 'null');
  if (node.nullable === true && out.enum) out.enum = [...out.enum, null];
  return out;
}
const ajv = new Ajv({strict: false, allErrors: true, logger: false});
ajv.addSchema(toJsonSchema({components: spec.components}), 'spec');

const resolve = (obj) => (obj && obj.$ref ? obj.$ref.split('/').slice(1).reduce((o, k) => o[k], spec) : obj);
const operations = [];
for (const [path, item] of Object.entries(spec.paths))
  for (const method of ['get', 'post', 'put', 'patch', 'delete'])
    if (item[method]) operations.push({path, method, op: item[method],
      // A path parameter holds no ':' either: /v1/jobs/{id}:pause is its own operation.
      re: new RegExp('^' + path.replace(/[.]/g, '\\.').replace(/\{[^}]+\}/g, '[^/:]+') + '$')});

let failures = 0;
const seen = new Map();  // operationId → Set of statuses
const fail = (msg) => { failures++; console.log('FAIL ' + msg); };

async function call(method, path, {body, type, auth = true, headers = {}} = {}) {
  const opts = {method, headers: {...headers}};
  if (auth) opts.headers.Authorization = 'Bearer ' + token;
  if (body !== undefined) {
    opts.body = typeof body === 'string' || body instanceof Uint8Array ? body : JSON.stringify(body);
    opts.headers['Content-Type'] = type ?? 'application/json';
  }
  const r = await fetch(base + path, opts);
  const bytes = new Uint8Array(await r.arrayBuffer());
  const text = new TextDecoder().decode(bytes);
  const where = `${method} ${path} → ${r.status}`;
  const entry = operations.find((o) => o.method === method.toLowerCase() && o.re.test(path.split('?')[0]));
  const ctype = (r.headers.get('content-type') || '').split(';')[0].trim();
  if (!entry) {
    // A method no operation has: the spec promises a 405 problem with Allow, not a schema.
    if (r.status !== 405 || !r.headers.get('allow') || ctype !== 'application/problem+json') fail(`${where}: no operation, and not a 405 problem with Allow`);
    else validate(spec.components.schemas.Problem, text, where);
    return {status: r.status, text, headers: r.headers};
  }
  const id = entry.op.operationId;
  if (!seen.has(id)) seen.set(id, new Set());
  seen.get(id).add(r.status);
  const resp = resolve(entry.op.responses[String(r.status)] ?? entry.op.responses.default);
  if (!resp) { fail(`${where}: status not documented for ${id}`); return {status: r.status, text, headers: r.headers}; }
  if (!entry.op.responses[String(r.status)]) fail(`${where}: only 'default' documents this status for ${id}`);
  // A documented header must be there unless the spec marks it `required: false` (sent only in
  // some cases, which the caller checks).
  for (const [name, h] of Object.entries(resp.headers ?? {}))
    if (h.required !== false && !r.headers.get(name)) fail(`${where}: header ${name} missing`);
  if (resp.content) {
    const media = Object.entries(resp.content).find(([k]) => k.split(';')[0].trim() === ctype);
    if (!media) fail(`${where}: Content-Type '${ctype}' not among ${Object.keys(resp.content).join(', ')}`);
    else if (ctype === 'application/x-ndjson') {
      // JSON lines: each line against the media's `x-line-schema`.
      const line = resolve(media[1]['x-line-schema']);
      if (!line) fail(`${where}: JSON lines with no x-line-schema`);
      else for (const l of text.split('\n').filter((l) => l)) validate(line, l, where);
    } else if (media[1].schema && ctype.endsWith('json')) validate(media[1].schema, text, where);
  } else if (bytes.length > 0) {
    fail(`${where}: a body where the spec documents none`);
  }
  return {status: r.status, text, headers: r.headers};
}

// A Server-Sent Events stream: the answer's status and type are checked like any other; then
// events are read until `enough` says so (or 20 s pass), each one's data validated against
// JobEvent, and the stream is dropped.
async function stream(path, {headers = {}, auth = true, enough = () => true, during = async () => {}} = {}) {
  const ac = new AbortController();
  const h = {...headers};
  if (auth) h.Authorization = 'Bearer ' + token;
  const r = await fetch(base + path, {headers: h, signal: ac.signal});
  const where = `GET ${path} → ${r.status}`;
  const entry = operations.find((o) => o.method === 'get' && o.re.test(path.split('?')[0]));
  const id = entry.op.operationId;
  if (!seen.has(id)) seen.set(id, new Set());
  seen.get(id).add(r.status);
  if (!entry.op.responses[String(r.status)]) fail(`${where}: status not documented for ${id}`);
  const ctype = (r.headers.get('content-type') || '').split(';')[0].trim();
  if (r.status !== 200) {
    const text = await r.text();
    if (ctype !== 'application/problem+json') fail(`${where}: not a problem`);
    else validate(spec.components.schemas.Problem, text, where);
    return {status: r.status, events: [], text};
  }
  if (ctype !== 'text/event-stream') fail(`${where}: Content-Type '${ctype}'`);
  const events = [];
  const reader = r.body.getReader();
  const decoder = new TextDecoder();
  let pending = '';
  const timer = setTimeout(() => ac.abort(), 20000);
  let acted = false;
  try {
    while (!enough(events)) {
      const {value, done} = await reader.read();
      if (done) break;
      pending += decoder.decode(value, {stream: true});
      let cut;
      while ((cut = pending.indexOf('\n\n')) >= 0) {
        const block = pending.slice(0, cut);
        pending = pending.slice(cut + 2);
        const e = {};
        for (const line of block.split('\n')) {
          if (!line || line.startsWith(':')) continue;
          const i = line.indexOf(':');
          const field = i < 0 ? line : line.slice(0, i);
          const value = i < 0 ? '' : line.slice(i + 1).replace(/^ /, '');
          if (field === 'data') e.data = (e.data ?? '') + value;
          else e[field] = value;
        }
        if (!e.event) continue;
        events.push(e);
        if (e.event !== 'reset') validate(spec.components.schemas.JobEvent, e.data, `${where} event ${e.event}`);
      }
      if (!acted) { acted = true; await during(); }
    }
  } catch (err) {
    if (err.name !== 'AbortError') throw err;
    fail(`${where}: the stream did not deliver what was expected in 20 s`);
  } finally {
    clearTimeout(timer);
    ac.abort();
  }
  if (!enough(events)) fail(`${where}: the stream ended before it delivered what was expected`);
  return {status: r.status, events, text: ''};
}

function validate(schema, text, where) {
  let doc;
  try { doc = JSON.parse(text); } catch { fail(`${where}: body is not JSON`); return; }
  const check = ajv.compile(toJsonSchema(schema));
  if (!check(doc)) fail(`${where}: ${JSON.stringify(check.errors).slice(0, 600)}`);
}

function expect(result, status, what) {
  if (result.status !== status) fail(`${what}: expected ${status}, got ${result.status}: ${result.text.slice(0, 200)}`);
  return result;
}
const json = (r) => JSON.parse(r.text);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function waitState(id, states) {
  for (let i = 0; i < 600; i++) {
    const s = json(await call('GET', `/v1/jobs/${id}`));
    if (states.includes(s.state)) return s;
    await sleep(50);
  }
  fail(`job ${id} never reached ${states}`);
}

const small = {scene: 'cornell_box', width: 32, height: 24, spp: 4};
const long = {scene: 'cornell_box', width: 400, height: 300, spp: 65536, max_depth: 5};

// The web page and the schema its form is built from.
expect(await call('GET', '/', {auth: false}), 200, 'the page, without a token');
expect(await call('GET', '/ui/app.js', {auth: false}), 200, 'a script of the page');
expect(await call('GET', '/ui/style.css', {auth: false}), 200, 'the style of the page');
expect(await call('GET', '/ui/no-such-file.js', {auth: false}), 404, 'a file the page does not have');
expect(await call('GET', '/v1/job-schema'), 200, 'the job schema');
expect(await call('GET', '/v1/nodes'), 200, 'the render nodes (one process: none)');

// Events: a job submitted while the stream is open is seen created; a job filter that names
// no job is 404; an id this server never gave out gets a reset.
{
  let created = null;
  const {events} = await stream('/v1/events', {
    enough: (ev) => created && ev.some((e) => e.event === 'created' && JSON.parse(e.data).job.id === created),
    during: async () => { created = json(await call('POST', '/v1/jobs', {body: small})).id; },
  });
  if (!events.some((e) => e.event === 'created')) fail('no created event');
  // Resume from the job's created event: under load the first stream's last read can already
  // hold the job's later events (then nothing after it would come).
  const last = events.find((e) => e.event === 'created' && JSON.parse(e.data).job.id === created);
  const resumed = await stream(`/v1/events?job=${created}`, {headers: {'Last-Event-ID': last.id}, enough: (ev) => ev.some((e) => e.event === 'state' && JSON.parse(e.data).job.state === 'succeeded')});
  if (resumed.events.some((e) => JSON.parse(e.data).job.id !== created)) fail('a job filter let another job through');
  expect(await stream('/v1/events?job=0123456789abcdef'), 404, 'events of an unknown job');
  const reset = await stream('/v1/events', {headers: {'Last-Event-ID': '1'}, enough: (ev) => ev.length > 0});
  if (reset.events[0]?.event !== 'reset') fail(`a foreign Last-Event-ID: ${JSON.stringify(reset.events[0])}`);
}

// Operations and health.
expect(await call('GET', '/healthz', {auth: false}), 200, 'health without a token');
expect(await call('GET', '/readyz', {auth: false}), 200, 'readiness without a token');
expect(await call('GET', '/metrics'), 200, 'metrics');
expect(await call('GET', '/metrics', {auth: false}), 401, 'metrics without a token');
expect(await call('GET', '/v1/openapi.yaml'), 200, 'the spec');

// Jobs: success, then every error a client can cause.
const job = json(expect(await call('POST', '/v1/jobs', {body: small}), 202, 'submit'));
expect(await call('POST', '/v1/jobs', {body: small, auth: false}), 401, 'submit without a token');
expect(await call('POST', '/v1/jobs', {body: small, auth: false, headers: {Authorization: 'Bearer not-the-token-0123456789'}}), 401, 'submit with a wrong token');
expect(await call('POST', '/v1/jobs', {body: '{not json'}), 400, 'malformed JSON');
expect(await call('POST', '/v1/jobs', {body: [1]}), 400, 'not an object');
expect(await call('POST', '/v1/jobs', {body: {scene: 'cornell_box', spp: 'x'}}), 400, 'mistyped field');
expect(await call('POST', '/v1/jobs', {body: {scene: 'no_such_scene'}}), 404, 'unknown scene');
expect(await call('POST', '/v1/jobs', {body: {scene: 'cornell_box', requires: ['bigmem']}}), 400, 'node tags one process lacks');
expect(await call('POST', '/v1/jobs', {body: {scene: 'cornell_box', note: 'x'.repeat(600)}}), 413, 'body over --max-body');
expect(await call('POST', '/v1/jobs', {body: small, type: 'text/plain'}), 415, 'not JSON');
// A catalog scene is read when the job runs, not at submission: a broken one fails the job
// with the loader's position.
const broken = json(expect(await call('POST', '/v1/jobs', {body: {...small, scene: brokenScene}}), 202, 'a broken scene file'));
expect(await call('PUT', '/v1/jobs', {body: {}}), 405, 'wrong method');
expect(await call('GET', '/v1/jobs?state=succeeded&limit=5'), 200, 'list');
expect(await call('GET', '/v1/jobs?limit=0'), 400, 'bad limit');
expect(await call('GET', `/v1/jobs/${job.id}`), 200, 'status');
expect(await call('GET', '/v1/jobs/0123456789abcdef'), 404, 'unknown job');
expect(await call('DELETE', '/v1/jobs/0123456789abcdef'), 404, 'cancel an unknown job');
const files = ['image.png', 'image.exr', 'rate.png', 'report.json', 'convergence.csv', 'convergence.svg'];
for (const f of files) expect(await call('GET', `/v1/jobs/0123456789abcdef/${f}`), 404, `${f} of an unknown job`);
expect(await call('DELETE', '/v1/jobs/0123456789abcdef/results'), 404, 'results of an unknown job');

const failed = await waitState(broken.id, ['failed', 'succeeded']);
if (failed?.state !== 'failed' || !String(failed.error).includes(brokenScene)) fail(`a job on a broken scene: ${JSON.stringify(failed)}`);
for (const f of files) expect(await call('GET', `/v1/jobs/${broken.id}/${f}`), 410, `${f} of a failed job`);

// A running job: its report is not there yet (409), its results cannot be deleted (409); its
// images are 409 before its first pass and that pass, marked, after it.
const running = json(expect(await call('POST', '/v1/jobs', {body: long}), 202, 'submit a long job'));
for (const f of files.slice(3)) expect(await call('GET', `/v1/jobs/${running.id}/${f}`), 409, `${f} of an unfinished job`);
expect(await call('DELETE', `/v1/jobs/${running.id}/results`), 409, 'delete results of an unfinished job');
for (let i = 0; i < 600; i++) {
  const s = json(await call('GET', `/v1/jobs/${running.id}`));
  if (s.latest_pass) break;
  await sleep(20);
}
for (const f of files.slice(0, 3)) {
  const r = expect(await call('GET', `/v1/jobs/${running.id}/${f}`), 200, `${f} of a running job's latest pass`);
  if (!r.headers.get('x-tessera-pass') || !r.headers.get('x-tessera-pass-spp')) fail(`${f} of a running job: no X-Tessera-Pass headers`);
}
// The log: JSON lines, each a task (404 for an unknown job).
expect(await call('GET', '/v1/jobs/0123456789abcdef/log'), 404, 'the log of an unknown job');
// Paused (200, idempotent) and resumed (200); GET there is a 405; a finished job's is a 409.
expect(await call('POST', '/v1/jobs/0123456789abcdef:pause'), 404, 'pause an unknown job');
expect(await call('POST', '/v1/jobs/0123456789abcdef:resume'), 404, 'resume an unknown job');
expect(await call('GET', `/v1/jobs/${running.id}:pause`), 405, 'GET on an action');
expect(await call('POST', `/v1/jobs/${running.id}:pause`), 200, 'pause');
for (let i = 0; i < 500; i++) {
  if (json(await call('GET', `/v1/jobs/${running.id}`)).state === 'paused') break;
  await sleep(20);
}
if (json(await call('GET', `/v1/jobs/${running.id}`)).state !== 'paused') fail('a paused job did not become paused');
expect(await call('GET', '/v1/jobs?state=paused'), 200, 'list paused jobs');
expect(await call('POST', `/v1/jobs/${running.id}:resume`), 200, 'resume');
expect(await call('DELETE', `/v1/jobs/${running.id}`), 200, 'cancel');
await waitState(running.id, ['canceled']);
expect(await call('POST', `/v1/jobs/${running.id}:resume`), 409, 'resume a canceled job');
const blocker = json(expect(await call('POST', '/v1/jobs', {body: {...long, seed: 98}}), 202, 'a job that runs'));
const unstarted = json(expect(await call('POST', '/v1/jobs', {body: {...long, seed: 99}}), 202, 'a job behind it'));
for (const f of files) expect(await call('GET', `/v1/jobs/${unstarted.id}/${f}`), 409, `${f} of a queued job`);
await call('DELETE', `/v1/jobs/${unstarted.id}`);
await call('DELETE', `/v1/jobs/${blocker.id}`);

// A finished job: its log (a task at least), every file, then deleted (204) and gone (410).
await waitState(job.id, ['succeeded']);
{
  const log = expect(await call('GET', `/v1/jobs/${job.id}/log`), 200, 'the log of a finished job');
  const lines = log.text.split('\n').filter((l) => l);
  if (lines.length < 1 || JSON.parse(lines[0]).outcome !== 'done') fail(`the log of a finished job: ${log.text.slice(0, 300)}`);
  const rest = expect(await call('GET', `/v1/jobs/${job.id}/log?from=${lines.length}`), 200, 'the log from its end');
  if (rest.text !== '') fail(`the log from its end is not empty: ${rest.text.slice(0, 200)}`);
}
for (const f of files) {
  const r = expect(await call('GET', `/v1/jobs/${job.id}/${f}`), 200, f);
  if (r.headers.get('x-tessera-pass')) fail(`${f} of a finished job carries X-Tessera-Pass`);
}
expect(await call('GET', `/v1/jobs/${job.id}/image.png?exposure=1.5`), 200, 'another exposure');
expect(await call('GET', `/v1/jobs/${job.id}/image.png?exposure=99`), 400, 'an exposure out of range');
expect(await call('GET', `/v1/jobs/${job.id}/image.exr?exposure=1`), 400, 'exposure on the EXR');
expect(await call('GET', `/v1/jobs/${job.id}/rate.png?exposure=1`), 400, 'exposure on the rate map');
// Conditional requests on a finished job's files: 304 for the tag the client has, 412 where its
// If-Match fails, for a streamed image and a text file alike.
for (const f of ['image.exr', 'report.json']) {
  const tag = expect(await call('GET', `/v1/jobs/${job.id}/${f}`), 200, f).headers.get('etag');
  if (!tag) { fail(`${f}: no ETag`); continue; }
  expect(await call('GET', `/v1/jobs/${job.id}/${f}`, {headers: {'If-None-Match': tag}}), 304, `${f} under its own If-None-Match`);
  expect(await call('GET', `/v1/jobs/${job.id}/${f}`, {headers: {'If-Match': '"not-it"'}}), 412, `${f} under a failing If-Match`);
}
// Passes and the denoised image: served for a job that asked for them, 404 for one that did not.
{
  const dn = json(expect(await call('POST', '/v1/jobs', {body: {...small, passes: ['albedo', 'depth'], denoise: true}}), 202, 'a job with passes and denoising'));
  await waitState(dn.id, ['succeeded']);
  for (const f of ['denoised.png', 'denoised.exr', 'passes.exr', 'passes/albedo.exr', 'passes/depth.exr'])
    expect(await call('GET', `/v1/jobs/${dn.id}/${f}`), 200, f);
  expect(await call('GET', `/v1/jobs/${dn.id}/passes/normal.exr`), 404, 'a pass the job did not ask for');
  expect(await call('GET', `/v1/jobs/${job.id}/denoised.png`), 404, 'the denoised image of a job that does not denoise');
  expect(await call('POST', '/v1/jobs', {body: {...small, passes: ['beauty']}}), 400, 'an unknown pass');
  expect(await call('POST', '/v1/jobs', {body: {...small, denoise: 'yes'}}), 400, 'denoise not a boolean');
}
expect(await call('DELETE', `/v1/jobs/${job.id}/results`), 204, 'delete results');
for (const f of files) expect(await call('GET', `/v1/jobs/${job.id}/${f}`), 410, `${f} after deletion`);

// The equal-time comparison.
const cmp = json(expect(await call('POST', '/v1/comparisons', {body: {scene: 'cornell_box', width: 16, height: 12, seconds: 0.1, reps: 1, reference_spp: 4}}), 202, 'comparison'));
expect(await call('POST', '/v1/comparisons', {body: {scene: 'cornell_box', seconds: 'long'}}), 400, 'bad comparison');
expect(await call('POST', '/v1/comparisons', {body: {scene: 'no_such_scene', seconds: 0.1}}), 404, 'comparison of an unknown scene');
await waitState(cmp.id, ['succeeded', 'failed']);
expect(await call('GET', `/v1/jobs/${cmp.id}`), 200, 'comparison status');

// Scenes: the catalog, an upload, a bad name, a broken file, one over --max-upload.
expect(await call('GET', '/v1/scenes'), 200, 'catalog');
const gltf = fs.readFileSync(new URL('../../scenes/cornell_box.gltf', import.meta.url));
const up = json(expect(await call('POST', '/v1/scenes?name=box.gltf', {body: new Uint8Array(gltf), type: 'application/octet-stream'}), 201, 'upload'));
expect(await call('POST', '/v1/scenes?name=../box.gltf', {body: new Uint8Array(gltf), type: 'application/octet-stream'}), 400, 'upload with a path');
expect(await call('POST', '/v1/scenes?name=broken.gltf', {body: '{"asset": {"version": "2.0"}, "meshes": [', type: 'application/octet-stream'}), 422, 'broken upload');
expect(await call('POST', '/v1/scenes?name=big.gltf', {body: new Uint8Array(70000), type: 'application/octet-stream'}), 413, 'upload over --max-upload');
const rendered = json(expect(await call('POST', '/v1/jobs', {body: {...small, scene: up.name}}), 202, 'render the upload'));
await waitState(rendered.id, ['succeeded']);

// A full queue: the server runs with --max-queued 3 and one job at a time.
let full = null;
const queued = [];
for (let i = 0; i < 6 && !full; i++) {
  const r = await call('POST', '/v1/jobs', {body: {...long, seed: i}});
  if (r.status === 429) full = r;
  else queued.push(json(expect(r, 202, 'fill the queue')).id);
}
if (!full) fail('the queue never answered 429');
for (const id of queued) await call('DELETE', `/v1/jobs/${id}`);

// Without a token every operation that documents 401 answers it (path parameters from the
// spec's examples).
for (const {path, method, op} of operations) {
  if (!op.responses['401']) continue;
  const params = [...(spec.paths[path].parameters ?? []), ...(op.parameters ?? [])].map(resolve);
  let url = path;
  for (const p of params.filter((p) => p.in === 'path')) {
    if (p.example === undefined) fail(`${op.operationId}: path parameter ${p.name} has no example`);
    url = url.replace(`{${p.name}}`, encodeURIComponent(p.example ?? 'x'));
  }
  expect(await call(method.toUpperCase(), url, {auth: false}), 401, `${op.operationId} without a token`);
}

// Every operation called; statuses documented but not provoked are listed.
for (const {op} of operations) {
  if (!seen.has(op.operationId)) { fail(`operation ${op.operationId} was never called`); continue; }
  const missing = Object.keys(op.responses).filter((s) => s !== 'default' && !seen.get(op.operationId).has(Number(s)));
  if (missing.length) console.log(`note: ${op.operationId}: documented, not provoked here: ${missing.join(', ')}`);
}
const calls = [...seen.values()].reduce((n, s) => n + s.size, 0);
console.log(`${operations.length} operations, ${calls} (operation, status) pairs checked, ${failures} failures`);
process.exit(failures ? 1 : 0);
