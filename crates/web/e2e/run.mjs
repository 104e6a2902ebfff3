// End-to-end scenarios of the operator page in the system's headless Chromium, against the
// real service process. Run by `cargo test -p multistep --test web_browser`, which passes:
//   SERVICE_ARGV  JSON array: the service command; "{http}" is replaced by HOST:PORT and
//                 "{other}" by the TCP address of the second board
//   OTHER_ARGV    JSON array: a second board's service (line protocol only), shown on the
//                 same page; it prints "board NAME listening on tcp://HOST:PORT" on stdout
//   SCREENSHOT    where to write the screenshot taken during a two-axis move
//   CHROMIUM      browser executable (default /usr/bin/chromium)
// The service must print "web page on http://HOST:PORT/" on stderr.
// Prints one line per scenario and then "N passed, M failed"; exits 1 on any failure.
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const ARGV = JSON.parse(process.env.SERVICE_ARGV || 'null');
const OTHER_ARGV = JSON.parse(process.env.OTHER_ARGV || 'null');
const SCREENSHOT = process.env.SCREENSHOT;
const T = 20000; // longest wait for anything (ms); the scenarios take a few seconds each

if (!existsSync(CHROMIUM)) {
  console.error(`error: no browser at ${CHROMIUM}: install it with 'apt-get install -y chromium chromium-driver'`);
  process.exit(1);
}
if (!Array.isArray(ARGV) || !Array.isArray(OTHER_ARGV)) {
  console.error('error: SERVICE_ARGV and OTHER_ARGV (JSON arrays) must give the service commands');
  process.exit(1);
}

// Starts a service and resolves once it has printed a line matching `ready` (on stderr
// for the page's address, on stdout for a board's TCP address).
function spawnService(argv, stream, ready) {
  return new Promise((resolve, reject) => {
    const p = spawn(argv[0], argv.slice(1), { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '';
    const timer = setTimeout(() => reject(new Error('service did not start: ' + out)), T);
    p.stdout.on('data', (d) => { if (stream === 'stdout') check(d); });
    p.stderr.on('data', (d) => { if (stream === 'stderr') check(d); else out += d; });
    function check(d) {
      out += d;
      const m = out.match(ready);
      if (m) { clearTimeout(timer); resolve({ proc: p, url: m[1] }); }
    }
    p.on('exit', (code) => { clearTimeout(timer); reject(new Error(`service exited (${code}): ${out}`)); });
  });
}

let otherAddr = null;
const startService = (http) =>
  spawnService(ARGV.map((a) => a.replace('{http}', http).replace('{other}', otherAddr)), 'stderr', /web page on (http:\/\/\S+?)\/?\s/);
const startOther = () => spawnService(OTHER_ARGV, 'stdout', /listening on tcp:\/\/(\S+)\s/);

function stopService(s) {
  return new Promise((resolve) => {
    s.proc.removeAllListeners('exit');
    s.proc.on('exit', resolve);
    s.proc.kill('SIGKILL');
  });
}

const card = (axis, board = 0) => `#axis-${board}-${axis}`;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function text(page, sel) {
  return (await page.locator(sel).textContent()).trim();
}

// The state an axis card shows.
function readCard(page, axis, board = 0) {
  return page.evaluate((sel) => {
    const el = document.querySelector(sel);
    if (!el) return null;
    return {
      pos: Number(el.querySelector('.pos').textContent),
      state: el.dataset.state,
      homed: el.querySelector('.homed').textContent,
      err: el.querySelector('.axis-err').textContent,
      drift: el.querySelector('.drift').hidden ? '' : el.querySelector('.drift').textContent,
      trusted: el.querySelector('.trusted').textContent,
      text: el.innerText.replace(/\s+/g, ' '),
    };
  }, card(axis, board));
}

// Polls an axis card from here (the page's CSP forbids eval, so no predicate is sent there)
// until `pred` holds for what it shows.
async function waitAxis(page, axis, pred, what, board = 0) {
  const until = Date.now() + T;
  let s = null;
  while (Date.now() < until) {
    s = await readCard(page, axis, board);
    if (s && pred(s)) return s;
    await sleep(15);
  }
  throw new Error(`${axis}: waited for ${what}; card shows: ${s && s.text}`);
}

async function moveAxis(page, axis, amount, mode = 'move', board = 0) {
  await page.locator(`${card(axis, board)} .amount`).fill(String(amount));
  await page.locator(`${card(axis, board)} .mode`).selectOption(mode);
  await page.locator(`${card(axis, board)} .go`).click();
}

const scenarios = [];
const scenario = (name, fn) => scenarios.push({ name, fn });

scenario('page loads and shows every axis of both boards', async ({ page }) => {
  await page.locator('#conn.up').waitFor({ timeout: T });
  for (const a of ['X', 'Y', 'WP']) await page.locator(card(a)).waitFor({ timeout: T });
  for (const a of ['F1', 'F2']) await page.locator(card(a, 1)).waitFor({ timeout: T });
  await waitAxis(page, 'X', (s) => s.state === 'idle', 'first status');
});

// The telescope panel: what `mount 0` reads, driven by its buttons. Waits until the
// panel shows `pred`: {state, tracking, dec: [lo, hi]}, each optional.
async function waitMount(page, pred, what) {
  try {
    // Conditions, not code: the page's CSP forbids evaluating strings.
    await page.waitForFunction((w) => {
      const d = document.getElementById('panel-mount').dataset;
      return (w.state === undefined || d.state === w.state)
        && (w.tracking === undefined || d.tracking === w.tracking)
        && (w.dec === undefined || (Number(d.dec) >= w.dec[0] && Number(d.dec) <= w.dec[1]));
    }, pred, { timeout: T });
  } catch (e) {
    const d = await page.evaluate(() => ({ ...document.getElementById('panel-mount').dataset }));
    throw new Error(`${what}: ${JSON.stringify(d)} (${e.message.split('\n')[0]})`);
  }
}

scenario('the telescope panel reads the mount, tracks, slews, guides, aborts and parks', async ({ page }) => {
  await page.locator('#panel-mount:not([hidden])').waitFor({ timeout: T });
  await waitMount(page, { state: 'still', dec: [90, 90] }, 'the home pose looks at the pole');
  if ((await text(page, '#mount-dec')) !== '+90:00:00.0') throw new Error('Dec shows ' + (await text(page, '#mount-dec')));
  if ((await text(page, '#mount-side')) !== 'east') throw new Error('pier ' + (await text(page, '#mount-side')));
  // Slew one hour west of the meridian to Dec 30: tracking goes on first.
  const lst = Number(await page.evaluate(() => document.getElementById('panel-mount').dataset.lst));
  const ra = (((lst - 1) % 24) + 24) % 24;
  await page.locator('#mount-ra-in').fill(ra.toFixed(6));
  await page.locator('#mount-dec-in').fill('30');
  await page.locator('#mount-slew').click();
  await waitMount(page, { tracking: '1', state: 'still', dec: [29.999, 30.001] }, 'the slew ends at Dec 30, tracking');
  if (!(await text(page, '#mount-tracking')).startsWith('tracking sidereal')) throw new Error('tracking badge');
  // A 1.5 s guide pulse north.
  await page.locator('#mount-guide-ms').fill('1500');
  await page.locator('.mount-guide[data-dir="n"]').click();
  await waitMount(page, { state: 'guiding' }, 'guiding');
  await waitMount(page, { state: 'still' }, 'the pulse ends');
  // A refused slew shows the mount's reason.
  await page.locator('#mount-dec-in').fill('95');
  await page.locator('#mount-slew').click();
  await page.waitForFunction(() => document.getElementById('err-mount').textContent.includes('declination'), null, { timeout: T });
  // Abort a long slew on its way.
  await page.locator('#mount-dec-in').fill('-20');
  await page.locator('#mount-slew').click();
  await waitMount(page, { state: 'slewing' }, 'the long slew starts');
  await page.locator('#mount-abort').click();
  await waitMount(page, { state: 'still', dec: [-19, 29.9] }, 'abort stops it on the way');
  // Track off, park (home counts: back at the pole), unpark.
  await page.locator('#mount-track-off').click();
  await waitMount(page, { tracking: '0' }, 'tracking off');
  await page.locator('#mount-park').click();
  await waitMount(page, { state: 'parked', dec: [90, 90] }, 'parked at the pole');
  await page.locator('#mount-unpark').click();
  await waitMount(page, { state: 'still' }, 'unparked');
});

scenario('a move is followed live until its position arrives', async ({ page }) => {
  const p0 = (await readCard(page, 'X')).pos;
  await moveAxis(page, 'X', 6000);
  await waitAxis(page, 'X', (s) => s.state === 'moving', 'moving');
  // Count what the page itself shows while the axis moves.
  const shown = await page.evaluate(async (sel) => {
    const el = document.querySelector(sel);
    const vals = [];
    const t0 = performance.now();
    while (el.dataset.state === 'moving' && performance.now() - t0 < 20000) {
      vals.push(el.querySelector('.pos').textContent);
      await new Promise((r) => setTimeout(r, 10));
    }
    return { vals, ms: performance.now() - t0 };
  }, card('X'));
  await waitAxis(page, 'X', (s) => s.pos === 6000 && s.state === 'idle', 'arrival at 6000');
  const distinct = new Set(shown.vals).size;
  console.log(`#   X: ${distinct} distinct positions shown during ${shown.ms.toFixed(0)} ms of motion (${(distinct / shown.ms * 1000).toFixed(1)}/s)`);
  // Live: positions on the way, not only the ends (the service sends 20 snapshots a second
  // while an axis moves, but a machine busy with other work may deliver only a few).
  const between = new Set(shown.vals.map(Number).filter((v) => v > p0 && v < p0 + 6000)).size;
  if (between < 2) throw new Error(`the position was not updated live (${between} positions on the way)`);
});

scenario('an out-of-limit target shows the service error next to the axis', async ({ page }) => {
  await moveAxis(page, 'X', 50000, 'moveto');
  await waitAxis(page, 'X', (s) => s.err.includes('outside the soft limits'), 'the soft-limit error');
  const err = await text(page, `${card('X')} .axis-err`);
  if (!err.startsWith('error 5:')) throw new Error('unexpected message: ' + err);
});

scenario('a preview is planned by the service and drawn', async ({ page }) => {
  await page.locator(`${card('X')} .amount`).fill('-2000');
  await page.locator(`${card('X')} .mode`).selectOption('move');
  await page.locator(`${card('X')} .preview`).click();
  await page.waitForFunction(() => document.querySelector('#preview-info').textContent.includes('6000 → 4000 (2000 steps)'), null, { timeout: T });
  const inked = await page.evaluate(() => {
    const c = document.querySelector('#preview-canvas');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++;
    return n;
  });
  if (inked < 500) throw new Error(`preview canvas is nearly empty (${inked} pixels)`);
  const st = await text(page, `${card('X')} .pos`);
  if (st !== '6000') throw new Error('a preview moved the axis to ' + st);
});

scenario('emergency stop during a move halts it and blocks new moves until reset', async ({ page }) => {
  await moveAxis(page, 'Y', 40000);
  await waitAxis(page, 'Y', (s) => s.state === 'moving' && s.pos > 200, 'moving');
  await page.locator('#estop').click();
  await page.locator('#estop-state').waitFor({ state: 'visible', timeout: T });
  await waitAxis(page, 'Y', (s) => s.state !== 'moving', 'halt');
  const at = Number(await text(page, `${card('Y')} .pos`));
  await sleep(300);
  const later = Number(await text(page, `${card('Y')} .pos`));
  if (!(at < 40000 && later === at)) throw new Error(`Y kept moving after the emergency stop: ${at} then ${later}`);
  await moveAxis(page, 'Y', 100);
  await waitAxis(page, 'Y', (s) => s.err.includes('emergency stop is active'), 'the e-stop error');
  await page.locator('#reset').click();
  await page.locator('#estop-state').waitFor({ state: 'hidden', timeout: T });
  await waitAxis(page, 'Y', (s) => s.err === '', 'the e-stop error cleared by reset');
  // The Escape key stops too.
  await moveAxis(page, 'Y', 4000);
  await waitAxis(page, 'Y', (s) => s.state === 'moving', 'moving again');
  await page.keyboard.press('Escape');
  await page.locator('#estop-state').waitFor({ state: 'visible', timeout: T });
  await waitAxis(page, 'Y', (s) => s.state !== 'moving', 'halt by Escape');
  await page.locator('#reset').click();
  await page.locator('#estop-state').waitFor({ state: 'hidden', timeout: T });
});

scenario('homing finds the sensor and marks the axis homed', async ({ page }) => {
  await page.locator(`${card('X')} .home`).click();
  await waitAxis(page, 'X', (s) => s.state === 'homing', 'homing');
  await waitAxis(page, 'X', (s) => s.state === 'idle' && s.homed === 'homed', 'homed');
  const trusted = await text(page, `${card('X')} .trusted`);
  if (trusted !== 'trusted') throw new Error('after homing the axis is ' + trusted);
});

scenario('a named position is saved and recalled', async ({ page }) => {
  await moveAxis(page, 'X', 1234, 'moveto');
  await waitAxis(page, 'X', (s) => s.pos === 1234 && s.state === 'idle', 'X at 1234');
  await page.locator('#pos-name').fill('park');
  await page.locator('#pos-save').click();
  await page.locator('#pos-list li[data-name=park]').waitFor({ timeout: T });
  await moveAxis(page, 'X', -800, 'moveto');
  await waitAxis(page, 'X', (s) => s.pos === -800 && s.state === 'idle', 'X at -800');
  await page.locator('#pos-list li[data-name=park] .goto').click();
  await waitAxis(page, 'X', (s) => s.pos === 1234 && s.state === 'idle', 'X back at 1234');
});

scenario('a bad setting shows the validation message next to the field', async ({ page }) => {
  await page.locator(`${card('X')} .gear`).click();
  const vmax = page.locator('#settings-form input[name=vmax]');
  await vmax.waitFor({ timeout: T });
  await vmax.fill('-5');
  await vmax.dispatchEvent('change');
  await page.waitForFunction(
    () => document.querySelector('#settings-form .err[data-for=vmax]').textContent.includes('vmax must be in ['),
    null, { timeout: T });
  await vmax.fill('5000');
  await vmax.dispatchEvent('change');
  await page.waitForFunction(
    () => document.querySelector('#settings-form .err[data-for=vmax]').textContent === '' &&
      document.querySelector('#settings-form input[name=vmax]').dataset.saved === '5000.0',
    null, { timeout: T });
});

scenario("the other board's axis moves through its own line protocol", async ({ page }) => {
  // 90 degrees on a periodic axis given in user units.
  await moveAxis(page, 'F1', '90u', 'moveto', 1);
  // the service reads the other board over its link every 250 ms at rest: on a loaded
  // machine the whole move may fall between two reads, and the card goes from rest
  // straight to the target
  await waitAxis(page, 'F1', (s) => s.state === 'moving' || s.pos === 3600, 'F1 moving', 1);
  await waitAxis(page, 'F1', (s) => s.pos === 3600 && s.state === 'idle', 'F1 at 3600', 1);
});

scenario('a synchronous group move runs both axes together (screenshot)', async ({ page }) => {
  await page.locator('#group-axes input[data-axis=X]').fill('-3000');
  await page.locator('#group-axes input[data-axis=Y]').fill('9000');
  await page.locator('#group-sync').check();
  await page.locator('#group-preview').click();
  await page.waitForFunction(() => document.querySelector('#preview-info').textContent.includes('Y:'), null, { timeout: T });
  await page.locator('#group-run').click();
  await waitAxis(page, 'X', (s) => s.state === 'moving', 'X moving');
  await waitAxis(page, 'Y', (s) => s.state === 'moving', 'Y moving');
  // Scrolled to the top, so the sticky header is where it belongs in a full-page shot.
  await page.evaluate(() => window.scrollTo(0, 0));
  await sleep(900);
  if (SCREENSHOT) await page.screenshot({ path: SCREENSHOT, fullPage: true });
  await waitAxis(page, 'X', (s) => s.pos === -3000 && s.state === 'idle', 'X at -3000');
  await waitAxis(page, 'Y', (s) => s.pos === 9000 && s.state === 'idle', 'Y at 9000');
});

scenario('lost steps show as a drift warning at the next sensor pass', async ({ page }) => {
  await moveAxis(page, 'X', 2000, 'moveto');
  await waitAxis(page, 'X', (s) => s.pos === 2000 && s.state === 'idle', 'X at 2000');
  // The simulation loses 40 steps unseen by the count (as a stalled motor would) …
  const r = await page.evaluate(() => fetch('/api/cmd', {
    method: 'POST', headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify({ board: 0, line: 'sim X slip 40' }),
  }).then((x) => x.json()));
  if (!r.ok) throw new Error('sim slip refused: ' + JSON.stringify(r));
  // … and the next pass over the Hall sensor in the homing direction finds the count off.
  await moveAxis(page, 'X', -3000, 'moveto');
  const s = await waitAxis(page, 'X', (s) => s.pos === -3000 && s.state === 'idle' && s.drift !== '', 'a drift warning');
  const d = Number((s.drift.match(/-?\d+/) || [])[0]);
  console.log(`#   X: "${s.drift}", ${s.trusted} after 40 lost steps`);
  if (!(Math.abs(d + 40) <= 2)) throw new Error('drift badge says ' + s.drift);
  if (s.trusted !== 'untrusted') throw new Error('after drift the axis is still ' + s.trusted);
});

// The service's own view of an axis, asked from here (not through the page).
async function serviceAxis(url, axis, board = 0) {
  const r = await fetch(url + '/api/status').then((x) => x.json());
  return r.boards[board].axes.find((a) => a.axis === axis);
}

scenario('tracking controls: a rate, a stored rate, stop; press-and-hold jog stops on release', async ({ page }) => {
  await page.locator(`${card('Y')} .rate`).fill('1234');
  await page.locator(`${card('Y')} .track`).click();
  await waitAxis(page, 'Y', (s) => s.state === 'tracking' && s.text.includes('rate 1234 steps/s'), 'tracking at 1234');
  await page.locator(`${card('Y')} .stop`).click();
  await waitAxis(page, 'Y', (s) => s.state === 'idle', 'stopped');
  await page.locator('#rates summary').click();
  await page.locator('#rate-name').fill('slow');
  await page.locator('#rate-value').fill('-2.5u');
  await page.locator('#rate-save').click();
  await page.locator('#rate-list li[data-name=slow]').waitFor({ timeout: T });
  await page.locator(`${card('Y')} .rate-preset`).selectOption('slow');
  await page.locator(`${card('Y')} .track`).click();
  await waitAxis(page, 'Y', (s) => s.state === 'tracking' && s.text.includes('rate -250 steps/s'), 'tracking at the stored rate (2.5 u/s × 100)');
  await page.locator(`${card('Y')} .stop`).click();
  await waitAxis(page, 'Y', (s) => s.state === 'idle', 'stopped again');
  // Held: runs at the jog speed for as long as the button is down.
  const p0 = (await readCard(page, 'Y')).pos;
  await page.locator(`${card('Y')} .hold-plus`).hover();
  await page.mouse.down();
  await waitAxis(page, 'Y', (s) => s.state === 'tracking' && s.pos > p0 + 200, 'jogging forward');
  await sleep(2500); // longer than the lease: the page renews it
  const held = await readCard(page, 'Y');
  if (held.state !== 'tracking') throw new Error('the jog stopped while held: ' + held.text);
  await page.mouse.up();
  const t0 = Date.now();
  await waitAxis(page, 'Y', (s) => s.state === 'idle', 'stop on release');
  const p1 = (await readCard(page, 'Y')).pos;
  await sleep(400);
  const p2 = (await readCard(page, 'Y')).pos;
  console.log(`#   Y: held jog ran ${p1 - p0} steps, at rest ${Date.now() - t0} ms after release`);
  if (p2 !== p1 || p1 <= p0 + 1000) throw new Error(`jog positions ${p0} → ${p1} → ${p2}`);
});

scenario('a renewal still on its way at the release does not start the jog again', async ({ page, serviceUrl }) => {
  await page.locator(`${card('Y')} .hold-plus`).hover();
  await page.mouse.down();
  await waitAxis(page, 'Y', (s) => s.state === 'tracking', 'jogging forward');
  // From now on every renewal takes 600 ms to reach the service; the stop does not.
  await page.route('**/api/cmd', async (route) => {
    if ((route.request().postData() || '').includes('track Y')) await sleep(600);
    await route.continue();
  });
  await sleep(400); // a renewal is on its way
  await page.mouse.up();
  const t0 = Date.now();
  let s = await serviceAxis(serviceUrl(), 'Y');
  while (s.state !== 'idle' && Date.now() - t0 < T) {
    await sleep(50);
    s = await serviceAxis(serviceUrl(), 'Y');
  }
  console.log(`#   Y: at rest ${Date.now() - t0} ms after the release, a renewal delayed 600 ms`);
  // longer than the 2-s lease a late renewal would have started
  await sleep(2500);
  const later = await serviceAxis(serviceUrl(), 'Y');
  await page.unroute('**/api/cmd');
  if (later.state !== 'idle' || later.position !== s.position) {
    throw new Error(`the jog started again after the release: ${s.position} → ${JSON.stringify(later)}`);
  }
});

scenario('a held jog stops when the page loses its connection', async ({ page, serviceUrl }) => {
  await page.locator(`${card('Y')} .hold-minus`).hover();
  await page.mouse.down();
  await waitAxis(page, 'Y', (s) => s.state === 'tracking', 'jogging backwards');
  // The connection goes: nothing the page sends arrives any more, not even the release.
  await page.route('**/api/**', (r) => r.abort());
  const t0 = Date.now();
  let s = await serviceAxis(serviceUrl(), 'Y');
  if (s.state !== 'tracking') throw new Error('not jogging when the connection went: ' + s.state);
  while (s.state !== 'idle' && Date.now() - t0 < T) {
    await sleep(50);
    s = await serviceAxis(serviceUrl(), 'Y');
  }
  const ms = Date.now() - t0;
  console.log(`#   Y: the service stopped the orphaned jog ${ms} ms after the connection went`);
  // the page's 2-s lease, and time for a loaded machine to stop the axis
  if (s.state !== 'idle' || ms > 4000) throw new Error(`the axis ran on for ${ms} ms: ${JSON.stringify(s)}`);
  const at = s.position;
  await sleep(300);
  if ((await serviceAxis(serviceUrl(), 'Y')).position !== at) throw new Error('still moving');
  await page.mouse.up();
  await page.unroute('**/api/**');
  // Back where the later scenarios expect Y.
  await page.locator('#conn.up').waitFor({ timeout: T });
  await moveAxis(page, 'Y', 9000, 'moveto');
  await waitAxis(page, 'Y', (s) => s.pos === 9000 && s.state === 'idle', 'Y back at 9000');
  for (const e of await page.locator('.axis-err').all()) await e.evaluate((x) => { x.textContent = ''; });
});

scenario('a lost connection is shown and the page reconnects by itself', async ({ page, restart }) => {
  await restart(async () => {
    await page.locator('#conn.down').waitFor({ timeout: T });
    const t = await text(page, '#conn');
    if (!t.includes('lost')) throw new Error('connection badge says ' + t);
  });
  await page.locator('#conn.up').waitFor({ timeout: T });
  // Positions were persisted and restored by the restarted service.
  await waitAxis(page, 'Y', (s) => s.pos === 9000, 'Y restored at 9000');
  await moveAxis(page, 'X', 100);
  await waitAxis(page, 'X', (s) => s.pos === -2900 && s.state === 'idle', 'a move after reconnecting');
});

async function main() {
  const other = await startOther();
  otherAddr = other.url;
  let service = await startService('127.0.0.1:0');
  // A fresh profile every run: nothing cached or remembered from an earlier one.
  const profile = mkdtempSync(join(tmpdir(), 'multistep-e2e-'));
  const browser = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync'],
    viewport: { width: 1400, height: 1000 },
  });
  const page = browser.pages()[0] || (await browser.newPage());
  const pageErrors = [];
  page.on('pageerror', (e) => pageErrors.push(String(e)));
  if (process.env.E2E_DEBUG) {
    const t0 = Date.now();
    page.on('request', (r) => console.log('#', Date.now() - t0, 'request', r.method(), r.url(), r.postData() || ''));
    page.on('requestfinished', (r) => console.log('#', Date.now() - t0, 'finished', r.url()));
    page.on('console', (m) => console.log('# console', m.text()));
  }
  const restart = async (whileDown) => {
    const port = new URL(service.url).host;
    await stopService(service);
    await whileDown();
    service = await startService(port);
  };
  await page.goto(service.url + '/');
  let passed = 0, failed = 0;
  for (const s of scenarios) {
    try {
      await s.fn({ page, restart, serviceUrl: () => service.url });
      if (pageErrors.length) throw new Error('script error on the page: ' + pageErrors.splice(0).join('; '));
      passed++;
      console.log(`ok - ${s.name}`);
    } catch (e) {
      failed++;
      console.log(`not ok - ${s.name}\n#   ${String(e.message).split('\n').join('\n#   ')}`);
    }
  }
  await browser.close();
  rmSync(profile, { recursive: true, force: true });
  await stopService(service);
  await stopService(other);
  console.log(`${passed} passed, ${failed} failed`);
  process.exit(failed ? 1 : 0);
}

main().catch((e) => { console.error('error:', e); process.exit(1); });
