// The web page in Debian's Chromium, headless, as a user works it: give the token, submit a
// job through the form and watch it converge pass by pass, look at the image, the sample-rate
// map, zoom and exposure, the convergence plot; cancel a second job from the queue; see the
// API's error beside a bad field; compare two jobs; all at 1280×800 and again at a phone's
// width. Every request must go to the server under test (nothing from other hosts), and the
// page must log no script error.
//
//   node page_test.mjs BASE_URL TOKEN CHROMIUM SCREENSHOT_DIR [one|farm]
//
// `farm`: the server is an API node of a render farm, which shows no pass images (a farm's
// passes are spread over its nodes); everything else is the same.
import {chromium} from 'playwright-core';

const [base, token, executablePath, shots, mode = 'one'] = process.argv.slice(2);
const farm = mode === 'farm';
if (!shots) {
  console.error('usage: node page_test.mjs BASE_URL TOKEN CHROMIUM SCREENSHOT_DIR');
  process.exit(2);
}

let failures = 0;
const fail = (msg) => { failures++; console.log('FAIL ' + msg); };
const check = (ok, msg) => { if (!ok) fail(msg); else console.log('ok   ' + msg); };
const api = async (method, path, body) => {
  const r = await fetch(base + path, {method, headers: {Authorization: 'Bearer ' + token, ...(body ? {'Content-Type': 'application/json'} : {})},
                                      body: body ? JSON.stringify(body) : undefined});
  return {status: r.status, body: r.status === 204 ? null : await r.json()};
};
const waitState = async (id, states, seconds = 60) => {
  for (let i = 0; i < seconds * 20; i++) {
    const s = (await api('GET', `/v1/jobs/${id}`)).body;
    if (states.includes(s.state)) return s;
    await new Promise((r) => setTimeout(r, 50));
  }
  throw new Error(`job ${id} never reached ${states}`);
};

// The flags Debian's Chromium needs here: root (no sandbox), no GPU, and none of its own
// calls home, which this machine's closed network would refuse.
const browser = await chromium.launch({
  executablePath, headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--disable-dev-shm-usage'],
});
const context = await browser.newContext({viewport: {width: 1280, height: 800}});
const foreign = [];
await context.route('**/*', (route) => {
  const url = route.request().url();
  if (url.startsWith(base + '/') || url.startsWith('blob:') || url.startsWith('data:')) return route.continue();
  foreign.push(url);
  return route.abort();
});
const page = await context.newPage();
const errors = [];
page.on('pageerror', (e) => errors.push(`page error: ${e.message}`));
page.on('console', (m) => {
  // A refused request shows in the console as a failed resource; those the test provokes
  // (401 before the token, 400 for the bad field) are expected. Script errors are not.
  if (m.type() === 'error' && !/Failed to load resource: the server responded with a status of (400|401|404|409|410)/.test(m.text()))
    errors.push(`console: ${m.text()}`);
});
const requests = [];
page.on('request', (r) => requests.push(r.url()));
// Refused requests, by URL: the console names only their status.
const refused = [];
page.on('response', (r) => { if (r.status() >= 400) refused.push(`${r.status()} ${r.url().replace(base, '')}`); });
const canceled = [];  // jobs the test cancels: their pass images may race their end
const shot = (name, fullPage = false) => page.screenshot({path: `${shots}/web_${farm ? 'farm_' : ''}${name}.png`, fullPage});

try {
  // 1. The token: the server asks for one, the page asks the user; a wrong one is asked again.
  await page.goto(base + '/');
  await page.waitForSelector('#token-form', {state: 'visible', timeout: 10000});
  await page.fill('#token-input', 'not-the-token-0123456789');
  await page.press('#token-input', 'Enter');
  await page.waitForFunction(() => /not accept/i.test(document.querySelector('#token-form')?.textContent ?? '') &&
                                   document.querySelector('#token-form')?.checkVisibility(), null, {timeout: 10000});
  check(true, 'a wrong token is refused and asked for again');
  await page.fill('#token-input', token);
  await page.press('#token-input', 'Enter');
  await page.waitForSelector('#queue', {timeout: 10000});
  check(await page.isHidden('#token-form').catch(() => true), 'the token form goes once the token is taken');
  // A farm's render nodes under the queue (the API node renders too: one live node); one
  // process has none, and no panel.
  if (farm) {
    await page.waitForSelector('#render-nodes tr[data-node]', {state: 'visible', timeout: 15000});
    const live = await page.textContent('#render-nodes tbody');
    check(/live/.test(live), `the queue page lists the farm's render nodes, live (${live.trim().slice(0, 80)})`);
  } else {
    await page.waitForTimeout(300);
    check(await page.isHidden('#render-nodes'), 'one process shows no render nodes');
  }

  // Jobs the compare view and the queue will show.
  const a = (await api('POST', '/v1/jobs', {scene: 'cornell_spheres', width: 96, height: 72, spp: 8, max_depth: 3})).body.id;
  const b = (await api('POST', '/v1/jobs', {scene: 'cornell_spheres', width: 96, height: 72, spp: 64, max_depth: 3})).body.id;
  await waitState(a, ['succeeded']);
  await waitState(b, ['succeeded']);

  // 2. Submit through the form; the job's page follows it pass by pass.
  await page.click('#nav-submit');
  await page.waitForSelector('#submit-form');
  await page.waitForFunction(() => [...document.querySelectorAll('#field-scene option')].some((o) => o.value === 'cornell_spheres'));
  const labelled = await page.evaluate(() => [...document.querySelectorAll('#submit-form input, #submit-form select, #submit-form textarea')]
    .filter((c) => c.type !== 'hidden' && c.type !== 'submit' && !(c.labels && c.labels.length) && !c.getAttribute('aria-label') && !c.getAttribute('aria-labelledby'))
    .map((c) => c.id || c.name));
  check(labelled.length === 0, `every form field has a label (unlabelled: ${labelled.join(', ')})`);
  await page.selectOption('#field-scene', 'cornell_spheres');
  await page.fill('#field-width', '160');
  await page.fill('#field-height', '120');
  await page.fill('#field-spp', '1024');
  await page.fill('#field-max_depth', '4');
  await shot('submit');
  await page.click('#submit-button');
  await page.waitForURL(/#\/jobs\/[0-9a-f]{16}/, {timeout: 10000});
  const id = page.url().match(/#\/jobs\/([0-9a-f]{16})/)[1];
  const status = (await api('GET', `/v1/jobs/${id}`)).body;
  check(status.settings.spp === 1024 && status.settings.width === 160 && status.settings.max_depth === 4, 'the form sent the values typed');
  await page.waitForSelector('#job-view');
  if (!farm) {
    await page.waitForFunction(() => /^\d+$/.test(document.querySelector('#job-image')?.dataset.pass ?? ''), null, {timeout: 30000});
    const passShown = await page.getAttribute('#job-image', 'data-pass');
    check(Number(passShown) >= 0, `a running job shows a pass image (pass ${passShown})`);
  } else {
    await page.waitForFunction(() => document.querySelector('#job-view')?.dataset.state === 'running', null, {timeout: 30000});
    check(true, 'a running job is shown running');
  }
  await page.waitForFunction(() => document.querySelector('#job-view')?.dataset.state === 'succeeded', null, {timeout: 120000});
  await page.waitForFunction(() => document.querySelector('#job-image')?.dataset.pass === 'final', null, {timeout: 10000});
  const passesSeen = requests.filter((u) => u.includes(`/v1/jobs/${id}/image.png`)).length;
  if (!farm) check(passesSeen >= 2, `the image was fetched again as passes finished (${passesSeen} fetches)`);
  const natural = await page.evaluate(() => {
    const img = document.querySelector('#job-image');
    return img.complete ? [img.naturalWidth, img.naturalHeight] : null;
  });
  check(natural && natural[0] === 160 && natural[1] === 120, `the final image is shown (${natural})`);
  await page.waitForFunction(() => document.querySelectorAll('#convergence-plot path, #convergence-plot polyline, #convergence-plot circle').length > 0, null, {timeout: 10000});
  check(true, 'the convergence plot is drawn');
  check(await page.getAttribute('#download-png', 'href') !== null, 'a PNG download link');
  check(await page.getAttribute('#download-exr', 'href') !== null, 'an EXR download link');
  check(await page.getAttribute('#download-report', 'href') !== null, 'a report download link');
  await shot('job', true);

  // The sample-rate map, zoom to pixels, exposure.
  const before = await page.getAttribute('#job-image', 'src');
  await page.click('#show-rate');
  await page.waitForFunction((old) => document.querySelector('#job-image').src !== old && document.querySelector('#job-image').complete, before, {timeout: 10000});
  check(requests.some((u) => u.includes(`/v1/jobs/${id}/rate.png`)), 'the rate map is fetched');
  await shot('rate');
  await page.click('#show-rate');
  await page.selectOption('#zoom', {index: (await page.$$eval('#zoom option', (o) => o.length)) - 1});
  const shownWidth = await page.evaluate(() => document.querySelector('#job-image').getBoundingClientRect().width);
  check(shownWidth >= 160 * 4 - 1, `zoom enlarges the pixels (${shownWidth} px wide for 160)`);
  await page.$eval('#exposure', (e) => { e.value = '2'; e.dispatchEvent(new Event('input', {bubbles: true})); e.dispatchEvent(new Event('change', {bubbles: true})); });
  await page.waitForFunction((jid) => performance.getEntriesByType('resource').some((r) => r.name.includes(`/v1/jobs/${jid}/image.png?exposure=2`)), id, {timeout: 10000})
    .catch(() => {});
  check(requests.some((u) => u.includes(`/v1/jobs/${id}/image.png?exposure=2`)), 'the exposure control asks for the image at +2 EV');

  // 3. A field error from the API beside its field: within the schema's bounds, past the
  //    server's pixel limit (the problem names /width).
  await page.click('#nav-submit');
  await page.waitForSelector('#submit-form');
  await page.waitForFunction(() => [...document.querySelectorAll('#field-scene option')].some((o) => o.value === 'cornell_spheres'));
  await page.selectOption('#field-scene', 'cornell_spheres');
  await page.fill('#field-width', '400');
  await page.fill('#field-height', '400');
  await page.click('#submit-button');
  await page.waitForFunction(() => (document.querySelector('#error-width')?.textContent ?? '').trim().length > 0, null, {timeout: 10000});
  check(/pixel|width/i.test(await page.textContent('#error-width')), `the API's problem shows beside width: "${(await page.textContent('#error-width')).trim()}"`);
  check(await page.getAttribute('#field-width', 'aria-invalid') === 'true', 'the field is marked invalid');
  await shot('field_error');

  // Scene upload from the form: the new scene is then the one selected.
  await page.setInputFiles('#upload-file', new URL('../../scenes/cornell_box.gltf', import.meta.url).pathname);
  await page.click('#upload-button');
  await page.waitForFunction(() => (document.querySelector('#field-scene')?.value ?? '').startsWith('upload/'), null, {timeout: 10000});
  const uploaded = await page.inputValue('#field-scene');
  const catalog = (await api('GET', '/v1/scenes')).body.scenes.map((e) => e.name);
  check(catalog.includes(uploaded), `an uploaded scene is in the catalog and selected (${uploaded})`);

  // An equal-time comparison job's page shows its table and plot.
  const cmp = (await api('POST', '/v1/comparisons', {scene: 'cornell_box', width: 24, height: 18, seconds: 0.1, reps: 1, reference_spp: 8})).body.id;
  await waitState(cmp, ['succeeded']);
  await page.goto(`${base}/#/jobs/${cmp}`);
  await page.waitForSelector('#comparison-table tbody tr', {timeout: 10000});
  const rows = await page.$$eval('#comparison-table tbody tr', (r) => r.length);
  const configs = (await api('GET', `/v1/jobs/${cmp}/report.json`)).body.comparison;
  const expected = Array.isArray(configs) ? configs.length : (configs.rows ?? configs.configs ?? []).length;
  check(rows >= 2 && (!expected || rows === expected), `a comparison job's table: ${rows} configurations (report: ${expected})`);
  await page.waitForFunction(() => { const i = document.querySelector('#comparison-plot'); return i && i.complete && i.naturalWidth > 0; }, null, {timeout: 10000});
  check(true, "a comparison job's plot is shown");
  await shot('comparison_job', true);

  // A denoising job's page offers its denoised image, and none where its render ended before
  // two samples a pixel (the server has none: 404).
  const dn = (await api('POST', '/v1/jobs', {scene: 'cornell_box', width: 32, height: 24, spp: 8, denoise: true})).body.id;
  await waitState(dn, ['succeeded']);  // one at a time: the server here queues one job
  const dn0Post = await api('POST', '/v1/jobs', {scene: 'cornell_box', width: 64, height: 48, spp: 4096, max_depth: 200, denoise: true, time_limit_s: 0.001});
  check(dn0Post.status === 202, `a job with a time limit of a millisecond is taken (${dn0Post.status} ${JSON.stringify(dn0Post.body).slice(0, 200)})`);
  const dn0 = dn0Post.body.id;
  await waitState(dn0, ['succeeded']);
  await page.goto(`${base}/#/jobs/${dn}`);
  await page.waitForSelector('#download-denoised', {timeout: 10000});
  check(true, "a denoising job's page offers its denoised image");
  await page.goto(`${base}/#/jobs/${dn0}`);
  await page.waitForSelector('#download-report', {timeout: 10000});
  check((await api('GET', `/v1/jobs/${dn0}/denoised.png`)).status === 404 && !(await page.$('#download-denoised')),
        'a denoising job that made no denoised image offers none');

  // 4. Cancel a second job from the queue while the first one runs.
  const blocker = (await api('POST', '/v1/jobs', {scene: 'cornell_spheres', width: 200, height: 150, spp: 4096, max_depth: 5})).body.id;
  const second = (await api('POST', '/v1/jobs', {scene: 'cornell_spheres', width: 200, height: 150, spp: 65536, max_depth: 5, seed: 7})).body.id;
  await page.click('#nav-queue');
  await page.waitForSelector(`#queue tr[data-job-id="${second}"]`, {timeout: 10000});
  await page.waitForFunction((bid) => document.querySelector(`#queue tr[data-job-id="${bid}"]`)?.dataset.state === 'running', blocker, {timeout: 10000});
  await page.waitForFunction((bid) => { const p = document.querySelector(`#queue tr[data-job-id="${bid}"] progress`); return p && p.value / (p.max || 1) >= 0.02; }, blocker, {timeout: 60000});
  check(true, 'the running job shows progress in the queue');
  await shot('queue');
  canceled.push(second, blocker);
  await page.click(`#queue tr[data-job-id="${second}"] button[data-action="cancel"]`);
  await page.waitForFunction((sid) => document.querySelector(`#queue tr[data-job-id="${sid}"]`)?.dataset.state === 'canceled', second, {timeout: 10000});
  check((await api('GET', `/v1/jobs/${second}`)).body.state === 'canceled', 'the queue cancels a job');
  const third = (await api('POST', '/v1/jobs', {scene: 'cornell_spheres', width: 200, height: 150, spp: 4096, max_depth: 5, seed: 8})).body.id;
  await page.waitForSelector(`#queue tr[data-job-id="${third}"]`, {timeout: 10000});
  canceled.push(third);
  await api('DELETE', `/v1/jobs/${third}`);
  await page.waitForFunction((tid) => document.querySelector(`#queue tr[data-job-id="${tid}"]`)?.dataset.state === 'canceled', third, {timeout: 10000});
  check(true, 'a job submitted and canceled elsewhere appears, then shows canceled (event stream)');
  // And the running one from its own page.
  await page.goto(`${base}/#/jobs/${blocker}`);
  // Paused and resumed from its page first.
  await page.waitForSelector('#pause-job', {state: 'visible', timeout: 10000});
  await page.click('#pause-job');
  await page.waitForFunction(() => document.querySelector('#job-view')?.dataset.state === 'paused', null, {timeout: 15000});
  check((await api('GET', `/v1/jobs/${blocker}`)).body.state === 'paused', 'a running job is paused from its page');
  await page.waitForSelector('#resume-job', {state: 'visible', timeout: 10000});
  await page.click('#resume-job');
  await page.waitForFunction(() => ['queued', 'running'].includes(document.querySelector('#job-view')?.dataset.state), null, {timeout: 15000});
  check(true, 'a paused job is resumed from its page');
  await page.waitForSelector('#cancel-job', {state: 'visible', timeout: 10000});
  await page.click('#cancel-job');
  await page.waitForFunction(() => document.querySelector('#job-view')?.dataset.state === 'canceled', null, {timeout: 15000});
  check((await api('GET', `/v1/jobs/${blocker}`)).body.state === 'canceled', "a running job is canceled from its page");

  // 5. Compare two finished jobs, side by side and with the slider; both curves on one plot.
  await page.goto(`${base}/#/compare?a=${a}&b=${b}`);
  await page.waitForSelector('#compare-a');
  await page.waitForFunction(() => document.querySelector('#compare-a').value && document.querySelector('#compare-b').value, null, {timeout: 10000});
  check(await page.inputValue('#compare-a') === a && await page.inputValue('#compare-b') === b, 'the compare view takes its jobs from the address');
  await page.waitForFunction(() => document.querySelectorAll('#compare-plot path, #compare-plot polyline').length >= 2, null, {timeout: 10000});
  check(true, 'both convergence curves on one plot');
  await shot('compare');
  await page.selectOption('#compare-mode', 'slider');
  await page.waitForSelector('#compare-slider', {state: 'visible'});
  await page.focus('#compare-slider');
  await page.keyboard.press('ArrowLeft');
  check(true, 'the slider takes the keyboard');
  await shot('compare_slider');

  // 6. Keyboard: tabbing from the top reaches the navigation.
  await page.goto(base + '/#/');
  await page.waitForSelector('#queue');
  await page.keyboard.press('Tab');
  await page.keyboard.press('Tab');
  const focused = await page.evaluate(() => document.activeElement?.tagName);
  check(['A', 'BUTTON', 'SELECT', 'INPUT'].includes(focused), `Tab moves focus to controls (${focused})`);

  // 6b. A shot (one process only: a farm refuses shots): the frame strip fills as frames are
  // written, a written frame opens in the viewer, the preview plays once the shot is done.
  if (!farm) {
    const shotId = (await api('POST', '/v1/jobs', {scene: 'cornell_shot', width: 64, height: 48, spp: 2, max_depth: 2,
                                                    frames: {start: 0, end: 48, step: 24}})).body.id;
    await page.goto(`${base}/#/jobs/${shotId}`);
    await page.waitForSelector('#frame-strip');
    await page.waitForFunction(() => document.querySelectorAll('#frame-strip .frame-succeeded').length === 3, null, {timeout: 30000});
    check(true, 'the frame strip shows every frame written');
    await page.waitForSelector('#shot-preview:not([hidden])', {timeout: 15000});
    check(await page.evaluate(() => document.querySelector('#shot-preview').src.startsWith('blob:')), 'the preview video is loaded');
    await page.click('#frame-strip [data-frame="24"]');
    await page.waitForFunction(() => document.querySelector('#frame-caption')?.textContent === 'Frame 24', null, {timeout: 5000});
    await page.waitForSelector('#download-frame-exr', {timeout: 5000});
    check(true, 'a written frame opens in the viewer with its downloads');
    await shot('shot');
  }

  // 6c. The job's log: opened, a row a task, with how it ended.
  await page.goto(`${base}/#/jobs/${id}`);
  await page.waitForSelector('#job-log summary');
  await page.click('#job-log summary');
  await page.waitForSelector('#job-log tbody tr[data-outcome="done"]', {timeout: 10000});
  check(true, "the job's log shows its tasks");

  // 7. A phone's width: nothing wider than the screen.
  await page.setViewportSize({width: 375, height: 800});
  await page.goto(`${base}/#/jobs/${id}`);
  await page.waitForSelector('#job-image');
  const overflow = await page.evaluate(() => document.documentElement.scrollWidth - window.innerWidth);
  check(overflow <= 1, `the job page fits a 375 px screen (overflow ${overflow} px)`);
  await shot('phone_job');
  await page.goto(base + '/#/');
  await page.waitForSelector('#queue');
  const queueOverflow = await page.evaluate(() => document.documentElement.scrollWidth - window.innerWidth);
  check(queueOverflow <= 1, `the queue fits a 375 px screen (overflow ${queueOverflow} px)`);
  await shot('phone_queue');
} catch (e) {
  fail(`${e.message}`);
  await shot('failure').catch(() => {});
} finally {
  await browser.close();
}

// A 410 is expected only for a job canceled while the page was fetching its latest pass (the
// request raced the job's end); anywhere else it means the page asked for results that are gone.
const canceledIds = new Set(canceled);
const stray410 = refused.filter((r) => r.startsWith('410 ') && ![...canceledIds].some((id) => r.includes(id)));
check(stray410.length === 0, `no requests for results that are gone (${stray410.join(', ')})`);
check(foreign.length === 0, `nothing requested from other hosts (${foreign.slice(0, 3).join(', ')})`);
check(errors.length === 0, `no script errors (${errors.slice(0, 5).join(' | ')}${errors.length ? `; refused: ${refused.join(', ')}` : ''})`);
console.log(`${failures} failures`);
process.exit(failures ? 1 : 0);
