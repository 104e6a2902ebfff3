// The operator page. It only sends protocol lines (POST /api/cmd), asks the service to plan
// previews (POST /api/preview) and draws what the event stream (GET /api/events) reports:
// every rule about moves lives in the controller, so the page and a terminal agree.
'use strict';

const TOKEN = new URLSearchParams(location.search).get('token');
const TRACE_SECONDS = 10;
const STALE_MS = 3000;
// Press-and-hold jog: the axis tracks at the jog speed under a lease the page renews while
// the button is held; a page that vanishes stops renewing, and the service stops the axis.
// Eight renewals a lease: a busy machine that delays a few still keeps a held jog going.
const JOG_LEASE_S = 2;
const JOG_RENEW_MS = 250;

const $ = (id) => document.getElementById(id);
const state = { boards: [], cards: new Map(), es: null, lastMsg: 0, preview: null, settings: null };

function withToken(url) {
  return TOKEN ? url + (url.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(TOKEN) : url;
}

async function post(path, body) {
  const headers = { 'Content-Type': 'application/json' };
  if (TOKEN) headers.Authorization = 'Bearer ' + TOKEN;
  const r = await fetch(path, { method: 'POST', headers, body: JSON.stringify(body) });
  return r.json();
}

async function getJson(path) {
  const headers = TOKEN ? { Authorization: 'Bearer ' + TOKEN } : {};
  const r = await fetch(path, { headers });
  if (!r.ok) throw new Error((await r.json()).error.message);
  return r.json();
}

// Shows `msg` in the error slot next to the control that caused it.
function showErr(el, msg) {
  el.textContent = msg || '';
  el.title = msg || '';
}

// Runs one protocol line on a board; errors go to `errEl`. Returns the reply or null.
async function cmd(board, line, errEl) {
  try {
    const r = await post('/api/cmd', { board, line });
    if (!r.ok) {
      showErr(errEl, `error ${r.error.code}: ${r.error.message}`);
      return null;
    }
    showErr(errEl, '');
    return r;
  } catch (e) {
    showErr(errEl, 'no connection to the service: ' + e.message);
    return null;
  }
}

// One word of a protocol line typed by the operator: no spaces, no option smuggling.
function word(value, what, errEl) {
  const v = value.trim();
  if (!v) { showErr(errEl, `enter ${what}`); return null; }
  if (/\s/.test(v)) { showErr(errEl, `${what}: no spaces`); return null; }
  return v;
}

function moveOpts() {
  const parts = [];
  const profile = $('opt-profile').value;
  const preset = $('opt-preset').value;
  if (profile) parts.push('profile=' + profile);
  if (preset) parts.push('preset=' + preset);
  for (const k of ['vmax', 'amax']) {
    const v = $('opt-' + k).value.trim();
    if (v) {
      if (/\s/.test(v)) throw new Error(k + ': no spaces');
      parts.push(`${k}=${v}`);
    }
  }
  return parts.length ? ' ' + parts.join(' ') : '';
}

function optsOrErr(errEl) {
  try { return moveOpts(); } catch (e) { showErr(errEl, e.message); return null; }
}

const selectedBoard = () => Number($('board-sel').value || 0);

// ---- axis cards ---------------------------------------------------------------------

function buildBoards() {
  const root = $('boards');
  root.textContent = '';
  state.cards.clear();
  const sel = $('board-sel');
  sel.textContent = '';
  for (const b of state.boards) {
    const sec = document.createElement('div');
    sec.className = 'board';
    sec.id = 'board-' + b.board;
    const h = document.createElement('h2');
    h.textContent = `Board ${b.name}` + (b.remote ? ` (line protocol at ${b.remote})` : '');
    const warn = document.createElement('div');
    warn.className = 'err board-warnings';
    const grid = document.createElement('div');
    grid.className = 'grid';
    sec.append(h, warn, grid);
    root.append(sec);
    for (const name of b.axes) grid.append(buildCard(b.board, name, b.remote));
    const o = document.createElement('option');
    o.value = b.board;
    o.textContent = b.name;
    sel.append(o);
  }
  buildGroup();
}

function buildCard(board, axis, remote) {
  const el = $('axis-card').content.firstElementChild.cloneNode(true);
  el.id = `axis-${board}-${axis}`;
  el.dataset.axis = axis;
  el.querySelector('.name').textContent = axis;
  const q = (c) => el.querySelector(c);
  const err = q('.axis-err');
  const card = { el, board, axis, trace: [], status: null };
  state.cards.set(`${board}/${axis}`, card);
  const moveLine = () => {
    const amount = word(q('.amount').value, 'a target or distance', err);
    const opts = optsOrErr(err);
    if (amount === null || opts === null) return null;
    return `${q('.mode').value} ${axis} ${amount}${opts}`;
  };
  q('.go').onclick = () => { const l = moveLine(); if (l) cmd(board, l, err); };
  // Another process's board is previewed on its own service's page.
  q('.preview').hidden = Boolean(remote);
  q('.preview').onclick = () => { const l = moveLine(); if (l) preview(board, l, err); };
  const jog = (sign) => {
    const step = word($('jog-step').value, 'a jog step', err);
    const opts = optsOrErr(err);
    if (step === null || opts === null) return;
    cmd(board, `move ${axis} ${sign}${step.replace(/^[-+]/, '')}${opts}`, err);
  };
  q('.jog-minus').onclick = () => jog('-');
  q('.jog-plus').onclick = () => jog('');
  holdToJog(board, axis, q('.hold-minus'), '-', err);
  holdToJog(board, axis, q('.hold-plus'), '', err);
  q('.rate-preset').onchange = () => { if (q('.rate-preset').value) q('.rate').value = q('.rate-preset').value; };
  q('.track').onclick = () => {
    const r = word(q('.rate').value, 'a rate or a rate name', err);
    if (r !== null) cmd(board, `track ${axis} ${r}`, err);
  };
  q('.stop').onclick = () => cmd(board, `stop ${axis}`, err);
  q('.home').onclick = () => cmd(board, `home ${axis}`, err);
  q('.gear').onclick = () => loadSettings(board, axis);
  return el;
}

// Every held jog button's release, so losing focus or the page going hidden stops them all.
const heldJogs = new Set();

function holdToJog(board, axis, btn, sign, err) {
  let timer = null;
  // One request at a time, each after the reply to the one before: a renewal still on its
  // way at the release would otherwise reach the service after the stop (requests travel
  // side by side) and start the jog again for a whole lease.
  let queue = Promise.resolve();
  let renewing = false;
  const send = (line) => (queue = queue.then(() => cmd(board, line, err)));
  const renew = (line) => {
    if (renewing) return; // the last renewal is unanswered yet: its lease still runs
    renewing = true;
    send(line).then(() => { renewing = false; });
  };
  const release = () => {
    if (!heldJogs.has(release)) return;
    heldJogs.delete(release);
    clearInterval(timer);
    btn.classList.remove('held');
    send(`stop ${axis}`);
  };
  btn.addEventListener('pointerdown', (e) => {
    if (e.button !== 0 || heldJogs.has(release)) return;
    const speed = word($('jog-speed').value, 'a jog speed', err);
    if (speed === null) return;
    const line = `track ${axis} ${sign}${speed.replace(/^[-+]/, '')} lease=${JOG_LEASE_S}`;
    heldJogs.add(release);
    btn.classList.add('held');
    if (btn.setPointerCapture) btn.setPointerCapture(e.pointerId);
    renew(line);
    timer = setInterval(() => renew(line), JOG_RENEW_MS);
  });
  for (const ev of ['pointerup', 'pointercancel', 'lostpointercapture', 'blur']) btn.addEventListener(ev, release);
}

const releaseAllJogs = () => { for (const r of [...heldJogs]) r(); };
window.addEventListener('blur', releaseAllJogs);
document.addEventListener('visibilitychange', () => { if (document.hidden) releaseAllJogs(); });

function badge(el, text, kind) {
  el.textContent = text;
  el.className = el.className.split(' ').filter((c) => !['ok', 'bad', 'warn', 'busy'].includes(c)).join(' ') + (kind ? ' ' + kind : '');
}

function updateCard(card, a, now) {
  const q = (c) => card.el.querySelector(c);
  card.status = a;
  card.el.dataset.state = a.state;
  card.el.classList.toggle('moving', a.state === 'moving');
  card.el.classList.toggle('homing', a.state === 'homing');
  card.el.classList.toggle('tracking', a.state === 'tracking');
  q('.num').textContent = '#' + a.number;
  q('.num').title = `motor number ${a.number}: accepted wherever the name is`;
  q('.released').hidden = a.enabled !== false;
  q('.rate-now').textContent = a.rate === null || a.rate === undefined ? '' : ` · rate ${a.rate} steps/s`;
  card.el.classList.toggle('fault', a.state === 'fault');
  q('.pos').textContent = a.position;
  q('.units').textContent = Number(a.units).toFixed(3);
  q('.speed').textContent = Number(a.speed).toFixed(0);
  badge(q('.state'), a.state, a.state === 'fault' ? 'bad' : a.state === 'idle' ? '' : 'busy');
  badge(q('.homed'), a.homed ? 'homed' : 'not homed', a.homed ? 'ok' : 'warn');
  badge(q('.trusted'), a.trusted ? 'trusted' : 'untrusted', a.trusted ? 'ok' : 'bad');
  // a board over a link (serve --board-link): whether it answers, and how old the reading is
  const link = q('.link');
  link.hidden = !a.link;
  if (a.link) {
    badge(link, 'link ' + a.link, a.link === 'up' ? 'ok' : 'bad');
    link.title = a.age_ms === undefined ? '' : `the board was read ${a.age_ms} ms ago`;
  }
  const drift = q('.drift');
  drift.hidden = !(a.drift !== null && a.drift !== 0);
  drift.textContent = `drift ${a.drift} steps`;
  drift.title = `counted minus expected position at the last sensor pass (${a.drift_checks} checks)`;
  q('.fault').textContent = a.fault ? 'fault: ' + a.fault : '';
  card.trace.push({ t: now, p: a.position, v: a.speed });
  while (card.trace.length && card.trace[0].t < now - TRACE_SECONDS) card.trace.shift();
  drawTrace(q('.trace'), card.trace, now);
}

// Position (blue, own scale) and velocity (orange, symmetric scale) over the last seconds.
function drawTrace(cv, tr, now) {
  const g = cv.getContext('2d');
  const W = cv.width, H = cv.height;
  g.clearRect(0, 0, W, H);
  g.strokeStyle = '#e4e7ec';
  g.beginPath(); g.moveTo(0, H / 2); g.lineTo(W, H / 2); g.stroke();
  if (tr.length < 2) return;
  let pmin = Infinity, pmax = -Infinity, vmax = 1;
  for (const s of tr) { pmin = Math.min(pmin, s.p); pmax = Math.max(pmax, s.p); vmax = Math.max(vmax, Math.abs(s.v)); }
  if (pmax - pmin < 1) { pmin -= 1; pmax += 1; }
  const x = (t) => W - (now - t) / TRACE_SECONDS * W;
  const line = (color, y) => {
    g.strokeStyle = color; g.lineWidth = 1.5; g.beginPath();
    tr.forEach((s, i) => (i ? g.lineTo : g.moveTo).call(g, x(s.t), y(s)));
    g.stroke();
  };
  line('#1f5fbf', (s) => H - 6 - (s.p - pmin) / (pmax - pmin) * (H - 12));
  line('#d9480f', (s) => H / 2 - s.v / vmax * (H / 2 - 6));
  g.fillStyle = '#6b7280'; g.font = '10px sans-serif';
  g.fillText(`pos ${pmin}…${pmax}`, 4, 11);
  g.fillText(`|v|≤${vmax.toFixed(0)}/s  ${TRACE_SECONDS}s`, W - 110, 11);
}

function onSnapshot(s) {
  const now = performance.now() / 1000;
  let estop = false;
  let unknown = false;
  for (const b of s.boards) {
    estop = estop || b.estop;
    const w = document.querySelector(`#board-${b.board} .board-warnings`);
    if (w) w.textContent = (b.error ? [b.error] : b.warnings).join(' · ');
    for (const a of b.axes) {
      const card = state.cards.get(`${b.board}/${a.axis}`);
      if (card) updateCard(card, a, now);
      else unknown = true;
    }
  }
  // A board that was unreachable when the page loaded has come up: rebuild the grid.
  if (unknown && !state.reloading) {
    state.reloading = true;
    loadBoards().catch(() => {}).finally(() => { state.reloading = false; });
  }
  $('estop-state').hidden = !estop;
  document.body.dataset.estop = estop ? '1' : '0';
}

// ---- connection ----------------------------------------------------------------------

function setConn(up, text) {
  const c = $('conn');
  c.className = 'conn ' + (up ? 'up' : 'down');
  c.textContent = text;
  document.body.dataset.connected = up ? '1' : '0';
}

function connect() {
  if (state.es) state.es.close();
  const es = new EventSource(withToken('/api/events'));
  state.es = es;
  es.onopen = async () => {
    setConn(true, 'connected');
    state.lastMsg = Date.now();
    try { await loadBoards(); } catch (e) { showErr($('err-top'), e.message); }
  };
  es.onmessage = (e) => { state.lastMsg = Date.now(); onSnapshot(JSON.parse(e.data)); };
  es.onerror = () => lost();
}

function lost() {
  setConn(false, 'connection lost — reconnecting…');
  if (state.es) { state.es.close(); state.es = null; }
  clearTimeout(state.retry);
  state.retry = setTimeout(connect, 1000);
}

// A stream that silently stops (a cable pulled, a suspended laptop) counts as lost too.
setInterval(() => { if (state.es && state.lastMsg && Date.now() - state.lastMsg > STALE_MS) lost(); }, 1000);

async function loadBoards() {
  const r = await getJson('/api/boards');
  const shape = JSON.stringify(r.boards);
  if (shape !== JSON.stringify(state.boards)) {
    state.boards = r.boards;
    buildBoards();
  }
  await Promise.all([loadPositions(), loadPresets(), loadRates()]);
}

// ---- everything on every board --------------------------------------------------------

async function allBoards(line) {
  const err = $('err-top');
  const rs = await Promise.all(state.boards.map((b) => cmd(b.board, line, err)));
  return rs.every((r) => r);
}
$('estop').onclick = () => allBoards('estop');
// Escape anywhere on the page is an emergency stop too: the stop is never further than a key.
document.addEventListener('keydown', (e) => { if (e.key === 'Escape') allBoards('estop'); });
$('reset').onclick = async () => {
  // The errors that the emergency stop caused are over.
  if (await allBoards('reset')) for (const e of document.querySelectorAll('.axis-err')) showErr(e, '');
};
$('stop-all').onclick = () => allBoards('stop all');

// ---- presets and named positions -----------------------------------------------------

async function loadPresets() {
  const r = await cmd(selectedBoard(), 'presets', $('err-opts'));
  if (!r) return;
  const sel = $('opt-preset');
  const keep = sel.value;
  sel.textContent = '';
  sel.append(new Option('none', ''));
  for (const l of r.data) {
    const name = l.split(' ')[0];
    sel.append(new Option(l, name));
  }
  sel.value = keep;
}

$('preset-save').onclick = async () => {
  const err = $('err-preset');
  const name = word($('preset-name').value, 'a preset name', err);
  if (name === null) return;
  if (await cmd(selectedBoard(), `preset ${name} ${$('preset-opts').value.trim()}`, err)) loadPresets();
};

async function loadPositions() {
  const board = selectedBoard();
  const err = $('err-positions');
  const r = await cmd(board, 'positions', err);
  if (!r) return;
  const ul = $('pos-list');
  ul.textContent = '';
  for (const l of r.data) {
    const [name, ...rest] = l.split(' ');
    const li = document.createElement('li');
    li.dataset.name = name;
    const b = document.createElement('b');
    b.textContent = name;
    const go = document.createElement('button');
    go.textContent = 'Go to';
    go.className = 'goto';
    go.onclick = () => { const o = optsOrErr(err); if (o !== null) cmd(board, `goto ${name}${o}`, err); };
    const forget = document.createElement('button');
    forget.textContent = 'Forget';
    forget.onclick = async () => { if (await cmd(board, `forget ${name}`, err)) loadPositions(); };
    li.append(b, ' ' + rest.join(' ') + ' ', go, ' ', forget);
    ul.append(li);
  }
}

$('pos-save').onclick = async () => {
  const err = $('err-positions');
  const name = word($('pos-name').value, 'a name', err);
  if (name !== null && (await cmd(selectedBoard(), `save ${name}`, err))) loadPositions();
};

$('board-sel').onchange = () => { buildGroup(); loadPositions(); loadPresets(); loadRates(); };

// ---- tracking rates (per board) -------------------------------------------------------

async function loadRates() {
  for (const b of state.boards) {
    const r = await cmd(b.board, 'rates', $('err-rate'));
    if (!r) continue;
    const names = r.data.map((l) => l.split(' '));
    for (const card of state.cards.values()) {
      if (card.board !== b.board) continue;
      const sel = card.el.querySelector('.rate-preset');
      sel.textContent = '';
      sel.append(new Option('rates…', ''));
      for (const [name, value] of names) sel.append(new Option(`${name} (${value})`, name));
    }
    if (b.board === selectedBoard()) {
      const ul = $('rate-list');
      ul.textContent = '';
      for (const [name, value] of names) {
        const li = document.createElement('li');
        li.dataset.name = name;
        li.textContent = `${name} ${value} steps/s`;
        ul.append(li);
      }
    }
  }
}

$('rate-save').onclick = async () => {
  const err = $('err-rate');
  const name = word($('rate-name').value, 'a rate name', err);
  const value = name === null ? null : word($('rate-value').value, 'a rate', err);
  if (value !== null && (await cmd(selectedBoard(), `rate ${name} ${value}`, err))) loadRates();
};

// ---- group move ------------------------------------------------------------------------

function buildGroup() {
  const root = $('group-axes');
  root.textContent = '';
  const b = state.boards.find((x) => x.board === selectedBoard());
  if (!b) return;
  for (const name of b.axes) {
    const l = document.createElement('label');
    const i = document.createElement('input');
    i.size = 7;
    i.dataset.axis = name;
    i.placeholder = '—';
    l.append(name + ' ', i);
    root.append(l);
  }
}

function groupLine() {
  const err = $('err-group');
  const targets = [];
  for (const i of $('group-axes').querySelectorAll('input')) {
    const v = i.value.trim();
    if (!v) continue;
    if (/\s/.test(v)) { showErr(err, `${i.dataset.axis}: no spaces`); return null; }
    targets.push(`${i.dataset.axis}=${v}`);
  }
  if (!targets.length) { showErr(err, 'enter a target for at least one axis'); return null; }
  const opts = optsOrErr(err);
  if (opts === null) return null;
  const mode = document.querySelector('input[name=group-mode]:checked').value;
  return `group ${mode} ${targets.join(' ')}${$('group-sync').checked ? ' sync' : ''}${opts}`;
}
$('group-run').onclick = () => { const l = groupLine(); if (l) cmd(selectedBoard(), l, $('err-group')); };
$('group-preview').onclick = () => { const l = groupLine(); if (l) preview(selectedBoard(), l, $('err-group')); };

// ---- preview: series planned by the service ------------------------------------------

async function preview(board, line, errEl) {
  let r;
  try { r = await post('/api/preview', { board, line }); } catch (e) { showErr(errEl, 'no connection: ' + e.message); return; }
  if (!r.ok) { showErr(errEl, `error ${r.error.code}: ${r.error.message}`); return; }
  showErr(errEl, '');
  state.preview = { board, line };
  $('preview-title').textContent = line;
  $('preview-run').disabled = false;
  drawPreview(r.axes);
  $('preview-info').textContent = r.axes
    .map((a) => `${a.axis}: ${a.start} → ${a.target} (${a.steps} steps) in ${a.duration.toFixed(3)} s, peak ${a.peak_speed.toFixed(0)} steps/s, ${a.peak_accel.toFixed(0)} steps/s²`)
    .join(' · ');
}

$('preview-run').onclick = () => { if (state.preview) cmd(state.preview.board, state.preview.line, $('err-preview')); };

const COLORS = ['#1f5fbf', '#2f9e44', '#9c36b5', '#e67700', '#0b7285', '#c2255c'];

function drawPreview(axes) {
  const cv = $('preview-canvas');
  const g = cv.getContext('2d');
  const W = cv.width, H = cv.height, pad = 24;
  g.clearRect(0, 0, W, H);
  const T = Math.max(1e-9, ...axes.map((a) => a.duration));
  let vmax = 1, pmin = Infinity, pmax = -Infinity;
  for (const a of axes) {
    for (const v of a.velocity) vmax = Math.max(vmax, Math.abs(v));
    for (const p of a.position) { pmin = Math.min(pmin, p); pmax = Math.max(pmax, p); }
  }
  if (pmax - pmin < 1) { pmin -= 1; pmax += 1; }
  const x = (t) => pad + t / T * (W - 2 * pad);
  const yv = (v) => H / 2 - v / vmax * (H / 2 - pad);
  const yp = (p) => H - pad - (p - pmin) / (pmax - pmin) * (H - 2 * pad);
  g.strokeStyle = '#ccd1d9';
  g.beginPath(); g.moveTo(pad, H / 2); g.lineTo(W - pad, H / 2); g.stroke();
  axes.forEach((a, k) => {
    const c = COLORS[k % COLORS.length];
    g.strokeStyle = c; g.lineWidth = 2; g.setLineDash([]);
    g.beginPath(); a.t.forEach((t, i) => (i ? g.lineTo : g.moveTo).call(g, x(t), yv(a.velocity[i]))); g.stroke();
    g.lineWidth = 1; g.setLineDash([5, 4]);
    g.beginPath(); a.t.forEach((t, i) => (i ? g.lineTo : g.moveTo).call(g, x(t), yp(a.position[i]))); g.stroke();
    if (a.edge_rate) {
      // Step rate counted from the generated edges, drawn as dots on the velocity line.
      g.setLineDash([]); g.fillStyle = c;
      const w = a.duration / a.edge_rate.length;
      a.edge_rate.forEach((r, i) => { if (i % 4 === 0) g.fillRect(x((i + 0.5) * w) - 1, yv(r) - 1, 2, 2); });
    }
    g.fillStyle = c; g.font = '11px sans-serif';
    g.fillText(a.axis, W - pad - 30 * (axes.length - k), 14);
  });
  g.setLineDash([]);
  g.fillStyle = '#6b7280'; g.font = '10px sans-serif';
  g.fillText(`velocity (solid, ±${vmax.toFixed(0)} steps/s) · position (dashed, ${pmin.toFixed(0)}…${pmax.toFixed(0)}) · dots: edges counted`, pad, H - 6);
  g.fillText(`${T.toFixed(3)} s`, W - pad - 40, H / 2 - 4);
}

// ---- settings ------------------------------------------------------------------------

async function loadSettings(board, axis) {
  const form = $('settings-form');
  const r = await cmd(board, `get ${axis}`, $('err-top'));
  if (!r) return;
  $('settings-axis').textContent = `board ${board}, axis ${axis}`;
  form.textContent = '';
  form.dataset.axis = axis;
  for (const l of r.data) {
    const eq = l.indexOf('=');
    const key = l.slice(0, eq), value = l.slice(eq + 1);
    const label = document.createElement('label');
    label.textContent = key;
    const input = document.createElement('input');
    input.name = key;
    input.value = value;
    input.dataset.saved = value;
    const err = document.createElement('span');
    err.className = 'err';
    err.dataset.for = key;
    input.onchange = async () => {
      const v = input.value.trim();
      if (!v || /\s/.test(v)) { showErr(err, 'one word, no spaces ("none" clears an optional value)'); return; }
      if (await cmd(board, `set ${axis} ${key} ${v}`, err)) {
        const back = await cmd(board, `get ${axis} ${key}`, err);
        if (back) { const s = back.data[0].slice(key.length + 1); input.value = s; input.dataset.saved = s; }
      }
    };
    const field = document.createElement('div');
    field.className = 'field';
    field.append(label, input, err);
    form.append(field);
  }
}

setConn(false, 'connecting…');
connect();
