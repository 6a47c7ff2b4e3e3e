// The submit page: a job form generated from the server's job schema (GET /v1/job-schema),
// the scene catalog with its counts and bounds, and scene upload.

import { api } from '/ui/api.js';
import { fill, h, setText } from '/ui/dom.js';
import { fmtBytes, fmtInt, humanize, shortId } from '/ui/format.js';
import { isComparison, jobOptionLabel } from '/ui/job_info.js';
import { announce, toast } from '/ui/notify.js';

const LAST_SCENE = 'tessera.lastScene';
const LABELS = {
  width: 'Width (pixels)', height: 'Height (pixels)', spp: 'Samples per pixel', light_rays: 'Light rays',
  max_depth: 'Maximum depth', bvh: 'BVH', max_leaf_size: 'Largest BVH leaf', triangle_test: 'Triangle test',
  direct: 'Direct lighting', russian_roulette: 'Russian roulette', light_selection: 'Light selection',
  tile_size: 'Tile size (pixels)', time_limit_s: 'Time limit (s)', target_error: 'Target error (relative MSE)',
  reference: 'Reference job', reference_spp: 'Reference samples per pixel', seconds: 'Seconds per run',
  reps: 'Runs per configuration', adaptive: 'Adaptive sampling', batch: 'Batch (samples)',
  shutter: 'Motion blur (shutter)', open: 'Opens (frames from the frame)', close: 'Closes (frames from the frame)',
};
const SOURCES = { builtin: 'Built in', project: 'Project scenes', directory: 'Scene folders', upload: 'Uploaded' };

// Field names become ids; a JSON pointer from a problem maps onto the same key.
const keyOf = (path) => path.join('-');
const pointerKey = (pointer) => pointer.split('/').slice(1).map((p) => p.replace(/~1/g, '/').replace(/~0/g, '~')).join('-');

function fmtVec(v) {
  return `(${v.map((x) => Number(x.toPrecision(4))).join(', ')})`;
}

// One input generated from a schema property. Returns null for a property the form cannot edit
// (it keeps the server's default). read(errors) → {value, changed}, pushing {key, message} on errors.
function makeField(name, schema, path, ctx) {
  const key = keyOf(path);
  const id = `field-${key}`;
  const label = LABELS[name] || humanize(name);
  const def = schema.default;
  const help = schema.description ? h('small', { id: `help-${key}`, class: 'help' }, schema.description) : null;
  const error = h('p', { id: `error-${key}`, class: 'field-error' });
  const describedby = [help && `help-${key}`, `error-${key}`].filter(Boolean).join(' ');
  const type = schema.type;
  let input;
  let read;

  if (type === 'object') return objectField(name, schema, path, ctx, { key, id, label, help, error, describedby });

  if (Array.isArray(schema.enum)) {
    input = h('select', { id, name: id, 'aria-describedby': describedby },
      schema.nullable ? h('option', { value: '' }, 'none') : null,
      schema.enum.map((v) => h('option', { value: String(v) }, `${v}${v === def ? ' (default)' : ''}`)));
    input.value = def == null ? '' : String(def);
    read = () => {
      const raw = input.value;
      const value = raw === '' ? null : (type === 'integer' || type === 'number' ? Number(raw) : raw);
      return { value, changed: value !== (def ?? null) };
    };
  } else if (type === 'integer' || type === 'number') {
    const integer = type === 'integer';
    input = h('input', {
      id, name: id, type: 'number', inputmode: integer ? 'numeric' : 'decimal', step: integer ? '1' : 'any',
      min: schema.minimum, max: schema.maximum, placeholder: def ?? '', value: def != null ? String(def) : '',
      'aria-describedby': describedby,
    });
    read = (errors) => {
      if (input.validity.badInput) { errors.push({ key, message: 'Enter a number.' }); return { changed: false }; }
      const raw = input.value.trim();
      if (raw === '') return { value: def ?? null, changed: false };   // empty means "the default"
      const value = Number(raw);
      return { value, changed: value !== def };
    };
  } else if (type === 'string' && name === 'reference') {
    input = h('select', { id, name: id, 'aria-describedby': describedby },
      h('option', { value: '' }, 'None: estimate the error from the image itself'),
      ctx.referenceJobs.map((j) => h('option', { value: j.id }, jobOptionLabel(j))));
    read = () => ({ value: input.value || null, changed: (input.value || null) !== (def ?? null) });
  } else if (type === 'string') {
    input = h('input', {
      id, name: id, type: 'text', value: def ?? '', minlength: schema.minLength, maxlength: schema.maxLength,
      spellcheck: 'false', autocomplete: 'off', 'aria-describedby': describedby,
    });
    read = () => {
      const raw = input.value.trim();
      const value = raw === '' && schema.nullable ? null : raw;
      return { value, changed: value !== (def ?? (schema.nullable ? null : '')) };
    };
  } else if (type === 'boolean') {
    input = h('input', { id, name: id, type: 'checkbox', checked: !!def, 'aria-describedby': describedby });
    read = () => ({ value: input.checked, changed: input.checked !== !!def });
    return {
      name, key, read, inputs: [input],
      el: h('div', { class: 'field check' }, h('label', { for: id }, input, ' ', label), help, error),
    };
  } else {
    return null;
  }
  input.addEventListener('input', () => clearFieldError(key));
  return {
    name, key, read, inputs: [input],
    el: h('div', { class: 'field' }, h('label', { for: id }, label), input, help, error),
  };
}

// A nested object; when nullable (adaptive: null or {batch, tolerance}) a checkbox in the legend
// turns it on, and the whole object is sent once on.
function objectField(name, schema, path, ctx, { key, id, label, help, error, describedby }) {
  const subs = Object.entries(schema.properties || {})
    .map(([n, s]) => makeField(n, s, [...path, n], ctx))
    .filter(Boolean);
  const nullable = schema.nullable || schema.default === null;
  const enable = nullable ? h('input', { type: 'checkbox', id, name: id, checked: schema.default != null, 'aria-describedby': describedby }) : null;
  const fieldset = h('fieldset', { class: 'subfields' },
    h('legend', {}, enable ? h('label', { for: id, class: 'check' }, enable, ' ', label) : label),
    help, h('div', { class: 'grid' }, subs.map((f) => f.el)), error);
  // Descendants of a disabled fieldset are disabled, except inside its legend: the checkbox.
  const sync = () => { if (enable) fieldset.disabled = !enable.checked; };
  enable?.addEventListener('change', () => { sync(); clearFieldError(key); });
  sync();
  return {
    name, key, el: fieldset, inputs: enable ? [enable] : [],
    read(errors) {
      if (enable && !enable.checked) return { value: null, changed: schema.default != null };
      const whole = enable && schema.default == null;
      const value = {};
      let changed = whole;
      for (const f of subs) {
        const r = f.read(errors);
        if (whole || r.changed) { value[f.name] = r.value; changed = changed || r.changed; }
      }
      return { value, changed };
    },
  };
}

function clearFieldError(key) {
  const err = document.getElementById(`error-${key}`);
  if (err) err.textContent = '';
  document.getElementById(`field-${key}`)?.removeAttribute('aria-invalid');
}

// Upload names must be plain file names ending in a known extension.
function uploadName(file) {
  const m = /\.(glb|gltf|dae)$/i.exec(file.name);
  if (!m) return null;
  let stem = file.name.slice(0, m.index).replace(/[^A-Za-z0-9._-]/g, '_').replace(/^\.+/, '') || 'scene';
  stem = stem.slice(0, 120);
  return `${stem}${m[0].toLowerCase()}`;
}

export function mount(root) {
  const controller = new AbortController();
  const signal = controller.signal;
  let schemas = null;
  let scenes = [];
  let fields = [];
  let kind = 'render_job';
  const ctx = { referenceJobs: [] };

  const sceneSelect = h('select', { id: 'field-scene', name: 'field-scene', required: true, 'aria-describedby': 'scene-info error-scene' });
  const sceneInfo = h('div', { id: 'scene-info', class: 'scene-info', 'aria-live': 'polite' });
  const uploadInput = h('input', { id: 'upload-file', name: 'upload-file', type: 'file', accept: '.glb,.gltf,.dae', 'aria-describedby': 'upload-help upload-error' });
  const uploadButton = h('button', { type: 'button', id: 'upload-button', class: 'secondary' }, 'Upload');
  const uploadStatus = h('p', { id: 'upload-status', class: 'muted', role: 'status' });
  const uploadError = h('p', { id: 'upload-error', class: 'field-error' });
  const kindRender = h('input', { type: 'radio', id: 'kind-render', name: 'kind', value: 'render_job', checked: true });
  const kindCompare = h('input', { type: 'radio', id: 'kind-comparison', name: 'kind', value: 'comparison_job' });
  const settings = h('div', { class: 'grid fields' });
  const formError = h('div', { id: 'form-error', class: 'form-error', role: 'alert' });
  const submitButton = h('button', { type: 'submit', id: 'submit-button' }, 'Submit job');
  const resetButton = h('button', { type: 'button', id: 'reset-button', class: 'secondary' }, 'Reset to defaults');

  const form = h('form', { id: 'submit-form', novalidate: true, class: 'stack', 'aria-labelledby': 'submit-h' },
    h('fieldset', { class: 'card' },
      h('legend', {}, 'Kind of job'),
      h('div', { class: 'radios' },
        h('label', { for: 'kind-render', class: 'check' }, kindRender, ' Render one image'),
        h('label', { for: 'kind-comparison', class: 'check' }, kindCompare, ' Compare sampling configurations at equal time'))),
    h('fieldset', { class: 'card' },
      h('legend', {}, 'Scene'),
      h('div', { class: 'field' }, h('label', { for: 'field-scene' }, 'Scene'), sceneSelect, h('p', { id: 'error-scene', class: 'field-error' })),
      sceneInfo,
      h('div', { class: 'upload' },
        h('label', { for: 'upload-file' }, 'Or upload a scene file'),
        h('small', { id: 'upload-help', class: 'help' }, 'glTF 2.0 (.glb, or .gltf with embedded buffers) or COLLADA (.dae).'),
        h('div', { class: 'row' }, uploadInput, uploadButton),
        uploadStatus, uploadError)),
    h('fieldset', { class: 'card' },
      h('legend', {}, 'Settings'),
      h('p', { class: 'muted' }, 'Only the values you change are sent; the rest take the server’s defaults.'),
      settings),
    formError,
    h('div', { class: 'actions' }, submitButton, resetButton));

  root.append(h('h1', { id: 'submit-h', tabindex: '-1' }, 'Submit a job'), form);

  function buildFields() {
    const schema = schemas?.[kind];
    fields = Object.entries(schema?.properties || {})
      .filter(([name]) => name !== 'scene')
      .map(([name, s]) => makeField(name, s, [name], ctx))
      .filter(Boolean);
    settings.replaceChildren(...fields.map((f) => f.el));
    submitButton.textContent = kind === 'comparison_job' ? 'Submit comparison' : 'Submit job';
  }

  function sceneOption(sc) {
    const counts = sc.error ? 'cannot be loaded'
      : `${fmtInt(sc.triangles ?? 0)} triangles, ${fmtInt(sc.spheres ?? 0)} spheres`;
    return h('option', { value: sc.name }, `${sc.name} — ${counts}`);
  }

  function fillScenes(selected) {
    const groups = new Map();
    for (const sc of scenes) {
      const g = sc.source || 'other';
      if (!groups.has(g)) groups.set(g, []);
      groups.get(g).push(sc);
    }
    sceneSelect.replaceChildren(...[...groups].map(([g, list]) => h('optgroup', { label: SOURCES[g] || humanize(g) }, list.map(sceneOption))));
    let last = null;
    try { last = localStorage.getItem(LAST_SCENE); } catch { /* storage blocked */ }
    const wanted = [selected, last].find((n) => n && scenes.some((s) => s.name === n));
    sceneSelect.value = wanted || scenes.find((s) => !s.error)?.name || '';
    showSceneInfo();
  }

  function showSceneInfo() {
    const sc = scenes.find((s) => s.name === sceneSelect.value);
    if (!sc) { sceneInfo.replaceChildren(); return; }
    const pairs = [
      ['Source', `${SOURCES[sc.source] || sc.source}${sc.format ? `, ${sc.format}` : ''}`],
      ['Triangles', sc.triangles != null ? fmtInt(sc.triangles) : null],
      ['Spheres', sc.spheres != null ? fmtInt(sc.spheres) : null],
      ['Lights', sc.lights != null ? `${fmtInt(sc.lights)} point or area lights, ${fmtInt(sc.emissive_meshes ?? 0)} emissive meshes` : null],
      ['Textures', sc.images ? `${fmtInt(sc.images)} images (${fmtInt(Math.round((sc.texel_bytes ?? 0) / 1024))} KiB) read by ${fmtInt(sc.textured_materials ?? 0)} materials` : null],
      ['Bounds', sc.bounds ? `${fmtVec(sc.bounds.min)} to ${fmtVec(sc.bounds.max)}` : (sc.error ? null : 'empty scene')],
    ].filter(([, v]) => v != null);
    fill(sceneInfo,
      h('dl', { class: 'facts inline' }, pairs.map(([k, v]) => [h('dt', {}, k), h('dd', {}, v)])),
      sc.note ? h('p', { class: 'muted' }, sc.note) : null,
      sc.error ? h('p', { class: 'notice error' }, `This scene cannot be loaded: ${sc.error}`) : null,
      sc.warnings?.length ? h('div', { class: 'notice warn' }, h('strong', {}, 'Warnings'), h('ul', { class: 'plain-list' }, sc.warnings.map((w) => h('li', {}, w)))) : null);
  }
  sceneSelect.addEventListener('change', () => { showSceneInfo(); clearFieldError('scene'); });

  function clearErrors() {
    formError.replaceChildren();
    for (const el of form.querySelectorAll('.field-error')) if (el !== uploadError) el.textContent = '';
    for (const el of form.querySelectorAll('[aria-invalid]')) el.removeAttribute('aria-invalid');
  }

  // Shows a message beside the field a key names, falling back to its parent object, then to
  // the form. Returns the element to focus.
  function showFieldError(key, message) {
    let k = key;
    while (k) {
      const err = document.getElementById(`error-${k}`);
      if (err && form.contains(err)) {
        err.textContent = message;
        const input = document.getElementById(`field-${k}`);
        input?.setAttribute('aria-invalid', 'true');
        return input || err;
      }
      k = k.includes('-') ? k.slice(0, k.lastIndexOf('-')) : '';
    }
    formError.replaceChildren(h('p', {}, message));
    return null;
  }

  function showProblem(e) {
    const message = e.detail || e.message;
    if (typeof e.field === 'string' && e.field.startsWith('/')) {
      const target = showFieldError(pointerKey(e.field), message);
      if (target) { target.focus(); return; }
    } else {
      fill(formError,
        h('p', {}, h('strong', {}, e.title || 'The job was refused'), e.detail ? `: ${e.detail}` : ''),
        e.status === 401 ? h('p', {}, 'Enter an access token, then submit again.') : null);
    }
    formError.scrollIntoView({ block: 'nearest' });
  }

  form.addEventListener('submit', async (ev) => {
    ev.preventDefault();
    if (!schemas) return;
    clearErrors();
    const errors = [];
    const body = { scene: sceneSelect.value };
    if (!body.scene) errors.push({ key: 'scene', message: 'Choose a scene.' });
    for (const f of fields) {
      const r = f.read(errors);
      if (r.changed) body[f.name] = r.value;
    }
    if (errors.length) {
      const targets = errors.map((er) => showFieldError(er.key, er.message));
      targets.find(Boolean)?.focus();
      return;
    }
    submitButton.disabled = true;
    submitButton.setAttribute('aria-busy', 'true');
    try {
      const job = kind === 'comparison_job' ? await api.submitComparison(body, { signal }) : await api.submitJob(body, { signal });
      try { localStorage.setItem(LAST_SCENE, body.scene); } catch { /* only a convenience */ }
      toast(`Job ${shortId(job.id)} submitted${job.queue_position != null ? `, position ${job.queue_position + 1} in the queue` : ''}.`);
      location.hash = `#/jobs/${job.id}`;
    } catch (e) {
      if (e.name !== 'AbortError') showProblem(e);
    } finally {
      submitButton.disabled = false;
      submitButton.removeAttribute('aria-busy');
    }
  });

  const onKind = () => {
    kind = kindCompare.checked ? 'comparison_job' : 'render_job';
    clearErrors();
    buildFields();
  };
  kindRender.addEventListener('change', onKind);
  kindCompare.addEventListener('change', onKind);
  resetButton.addEventListener('click', () => { clearErrors(); buildFields(); });

  uploadInput.addEventListener('change', () => { uploadError.textContent = ''; setText(uploadStatus, ''); });
  uploadButton.addEventListener('click', async () => {
    uploadError.textContent = '';
    const file = uploadInput.files?.[0];
    if (!file) { uploadError.textContent = 'Choose a file first.'; uploadInput.focus(); return; }
    const name = uploadName(file);
    if (!name) { uploadError.textContent = 'The file must end in .glb, .gltf or .dae.'; uploadInput.focus(); return; }
    uploadButton.disabled = true;
    setText(uploadStatus, `Uploading ${file.name} (${fmtBytes(file.size)})…`);
    try {
      const scene = await api.uploadScene(name, file, { signal });
      const sceneName = scene.name || scene.id;
      try { scenes = (await api.scenes({ signal })).scenes || []; } catch { scenes = [...scenes, scene]; }
      if (!scenes.some((s) => s.name === sceneName)) scenes.push(scene);
      fillScenes(sceneName);
      clearFieldError('scene');
      const msg = `Uploaded ${file.name} as ${sceneName}: ${fmtInt(scene.triangles ?? 0)} triangles, ${fmtInt(scene.spheres ?? 0)} spheres. It is now the selected scene.`;
      setText(uploadStatus, msg);
      announce(msg);
      uploadInput.value = '';
    } catch (e) {
      if (e.name === 'AbortError') return;
      setText(uploadStatus, '');
      uploadError.textContent = `${e.detail || e.message}${e.problem?.location ? ` (at ${e.problem.location})` : ''}`;
    } finally {
      uploadButton.disabled = false;
    }
  });

  async function load() {
    submitButton.disabled = true;
    formError.replaceChildren(h('p', { class: 'muted' }, 'Loading the job fields and scenes…'));
    const [schemaRes, scenesRes, jobsRes] = await Promise.allSettled([
      api.jobSchema({ signal }), api.scenes({ signal }), api.listJobs({ state: 'succeeded', limit: 200 }, { signal })]);
    if (signal.aborted) return;
    formError.replaceChildren();
    if (jobsRes.status === 'fulfilled') ctx.referenceJobs = jobsRes.value.jobs.filter((j) => !isComparison(j));
    if (scenesRes.status === 'fulfilled') {
      scenes = scenesRes.value.scenes || [];
      fillScenes();
    } else {
      showFieldError('scene', `The scenes could not be listed: ${scenesRes.reason?.message}`);
    }
    if (schemaRes.status === 'fulfilled') {
      schemas = schemaRes.value;
      buildFields();
      submitButton.disabled = false;
    } else {
      const retry = h('button', { type: 'button', class: 'secondary small' }, 'Try again');
      retry.addEventListener('click', load);
      formError.replaceChildren(h('p', {}, `The job fields could not be loaded: ${schemaRes.reason?.message} `), retry);
    }
  }
  load();

  return () => controller.abort();
}
