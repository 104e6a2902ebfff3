// The telescope panel: each board's [[alpaca.telescope]] mounts (its `devices` answer),
// read with `mount K` once a second and driven with `mount K …` lines, so the page and a
// terminal drive the same mount model (docs/PROTOCOL.md "Mount").
'use strict';

const MOUNT_POLL_MS = 1000;
const mount = { list: [], shape: '', timer: null };

// `mount ra=… dec=…` as key → value.
function mountFields(line) {
  const f = {};
  for (const kv of line.replace(/^mount /, '').split(' ')) {
    const eq = kv.indexOf('=');
    if (eq > 0) f[kv.slice(0, eq)] = kv.slice(eq + 1);
  }
  return f;
}

// Hours or degrees as ±hh:mm:ss.s.
function sexagesimal(x, sign) {
  const s = x < 0 ? '-' : sign ? '+' : '';
  let t = Math.round(Math.abs(x) * 36000);
  const tenths = t % 10; t = (t - tenths) / 10;
  const sec = t % 60; t = (t - sec) / 60;
  const min = t % 60; const deg = (t - min) / 60;
  const two = (n) => String(n).padStart(2, '0');
  return `${s}${two(deg)}:${two(min)}:${two(sec)}.${tenths}`;
}

function selectedMount() {
  const v = $('mount-sel').value;
  if (!v) return null;
  const [board, k] = v.split(':').map(Number);
  return { board, k };
}

// The telescopes of every board, from the boards' `devices` answers.
async function loadMounts() {
  const found = [];
  for (const b of state.boards) {
    const r = await cmd(b.board, 'devices', $('err-mount'));
    if (!r || !r.data.length) continue;
    let section;
    try { section = JSON.parse(r.data[0]); } catch (e) { continue; }
    (section.telescope || []).forEach((t, k) => {
      found.push({ board: b.board, k, name: t.name || `${b.name || 'board ' + b.board} telescope ${t.ra_axis}` });
    });
  }
  const shape = JSON.stringify(found);
  if (shape === mount.shape) return;
  mount.shape = shape;
  mount.list = found;
  const sel = $('mount-sel');
  const keep = sel.value;
  sel.textContent = '';
  for (const m of found) sel.append(new Option(m.name, `${m.board}:${m.k}`));
  if (found.some((m) => `${m.board}:${m.k}` === keep)) sel.value = keep;
  $('panel-mount').hidden = found.length === 0;
}

async function mountLine(words) {
  const m = selectedMount();
  if (!m) return null;
  return cmd(m.board, `mount ${m.k}${words ? ' ' + words : ''}`, $('err-mount'));
}

async function readMount() {
  const m = selectedMount();
  if (!m) return;
  // A failed read leaves the last values and says why.
  let r;
  try { r = await post('/api/cmd', { board: m.board, line: `mount ${m.k}` }); } catch (e) { return; }
  if (!r.ok || !r.data.length) return;
  const f = mountFields(r.data[0]);
  const panel = $('panel-mount');
  panel.dataset.ra = f.ra; panel.dataset.dec = f.dec; panel.dataset.lst = f.lst;
  $('mount-ra').textContent = sexagesimal(Number(f.ra), false);
  $('mount-dec').textContent = sexagesimal(Number(f.dec), true);
  $('mount-alt').textContent = Number(f.alt).toFixed(3) + '°';
  $('mount-az').textContent = Number(f.az).toFixed(3) + '°';
  $('mount-lst').textContent = sexagesimal(Number(f.lst), false);
  $('mount-side').textContent = f.side;
  const tracking = f.tracking === '1';
  badge($('mount-tracking'), tracking ? `tracking ${f.rate}` : 'not tracking', tracking ? 'ok' : '');
  const what = f.parked === '1' ? 'parked' : f.slewing === '1' ? 'slewing' : f.guiding === '1' ? 'guiding' : 'still';
  badge($('mount-state'), what, what === 'still' ? '' : what === 'parked' ? 'warn' : 'busy');
  panel.dataset.state = what;
  panel.dataset.tracking = tracking ? '1' : '0';
  if (document.activeElement !== $('mount-rate')) $('mount-rate').value = f.rate;
}

function pollMount() {
  clearTimeout(mount.timer);
  readMount().finally(() => { mount.timer = setTimeout(pollMount, MOUNT_POLL_MS); });
}

// After a command: read at once, not at the next tick.
async function mountDo(words) {
  const r = await mountLine(words);
  pollMount();
  return r;
}

$('mount-sel').onchange = pollMount;
$('mount-track-on').onclick = () => mountDo(`track on ${$('mount-rate').value}`);
$('mount-track-off').onclick = () => mountDo('track off');
$('mount-rate').onchange = () => mountDo(`track ${$('panel-mount').dataset.tracking === '1' ? 'on' : 'off'} ${$('mount-rate').value}`);
$('mount-park').onclick = () => mountDo('park');
$('mount-unpark').onclick = () => mountDo('unpark');
$('mount-abort').onclick = () => mountDo('abort');
$('mount-slew').onclick = async () => {
  const err = $('err-mount');
  const ra = word($('mount-ra-in').value, 'RA (hours)', err);
  const dec = word($('mount-dec-in').value, 'Dec (degrees)', err);
  if (ra === null || dec === null) return;
  // The mount slews while tracking (and tracks there after).
  if ($('panel-mount').dataset.tracking !== '1' && !(await mountLine(`track on ${$('mount-rate').value}`))) return;
  mountDo(`slew ${ra} ${dec}`);
};
for (const b of document.querySelectorAll('.mount-guide')) {
  b.onclick = () => {
    const ms = word($('mount-guide-ms').value, 'guide ms', $('err-mount'));
    if (ms !== null) mountDo(`pulse ${b.dataset.dir} ${ms}`);
  };
}

// The boards arrive with the page's first connection, and again after a reconnection.
setInterval(() => {
  if (!state.boards.length) return;
  const shape = JSON.stringify(state.boards);
  if (shape !== mount.boards) {
    mount.boards = shape;
    loadMounts().then(pollMount).catch((e) => showErr($('err-mount'), e.message));
  }
}, 500);
