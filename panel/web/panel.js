// The lab panel's page: live state from /api/events (Server-Sent Events), commands as POSTs to
// /api/... with this page's client id (and the token when the panel asks for one). Every path is
// relative (api/..., js/...), so the page works at / (sirupp-panel) and under a prefix (the class
// server's /s/NAME/).
'use strict';

const $ = (id) => document.getElementById(id);
const fmt = (v, d = 1) => (v === undefined || v === null || Number.isNaN(v)) ? '-' : Number(v).toFixed(d);

// --- identity, token, requests ------------------------------------------------------------------
const params = new URLSearchParams(location.search);
if (params.get('token')) sessionStorage.setItem('sirupp-token', params.get('token'));
const token = sessionStorage.getItem('sirupp-token') || '';
let clientId = sessionStorage.getItem('sirupp-client');
if (!clientId) {
  clientId = 'c' + Math.random().toString(36).slice(2, 12);
  sessionStorage.setItem('sirupp-client', clientId);
}

function say(text, isError) {
  const m = $('message');
  m.textContent = text;
  m.className = isError ? 'error' : '';
}

async function getJson(path) {
  const r = await fetch(path, {headers: {'X-Sirupp-Client': clientId}});
  return r.json();
}

// POST; shows the answer; returns {status, body}.
async function post(path, body, quiet) {
  const headers = {'Content-Type': 'application/json', 'X-Sirupp-Client': clientId};
  if (token) headers['X-Sirupp-Token'] = token;
  let r, data;
  try {
    r = await fetch(path, {method: 'POST', headers, body: JSON.stringify(body || {})});
    data = await r.json();
  } catch (e) {
    say('request failed: ' + e, true);
    return {status: 0, body: {}};
  }
  if (!quiet || !r.ok) say(data.ok === false || !r.ok ? (data.error || r.status) : (data.message || 'ok'), !r.ok);
  return {status: r.status, body: data};
}

// --- state shared by the panels -----------------------------------------------------------------
let model = null;
let latest = null;         // newest state frame
let drawnGeneration = -1;
const stats = {frames: 0, fps: 0, latencies: [], received: 0, drawn: 0};
window.panelStats = stats;  // read by the benchmark and the browser tests

// --- tabs ---------------------------------------------------------------------------------------
for (const b of document.querySelectorAll('#tabs button')) {
  b.addEventListener('click', () => showTab(b.dataset.tab));
}
function showTab(name) {
  for (const b of document.querySelectorAll('#tabs button')) b.classList.toggle('active', b.dataset.tab === name);
  for (const t of document.querySelectorAll('.tab')) t.classList.toggle('active', t.id === 'tab-' + name);
  if (name === 'plots' && plot) plot.resize();
}
window.showTab = showTab;

// --- control lock and e-stop --------------------------------------------------------------------
$('lock-name').value = localStorage.getItem('sirupp-name') || 'student';
async function takeControl(takeOver) {
  localStorage.setItem('sirupp-name', $('lock-name').value);
  await post('api/lock', {name: $('lock-name').value, take_over: takeOver});
  refreshLock();
}
$('take-control').onclick = () => takeControl(false);
$('take-over').onclick = () => takeControl(true);
$('release-control').onclick = async () => { await post('api/unlock', {}); refreshLock(); };
let lockState = {held: false, mine: false};
async function refreshLock() {
  lockState = await getJson('api/lock');
  $('lock-state').textContent = lockState.mine ? 'you hold control'
    : lockState.held ? 'held by ' + lockState.holder : 'nobody holds control';
  $('take-over').hidden = !(lockState.held && !lockState.mine);
  $('release-control').hidden = !lockState.mine;
  $('take-control').hidden = lockState.mine;
}
$('estop').onclick = () => post('api/estop', {engaged: true, who: $('lock-name').value});
$('estop-release').onclick = () => post('api/estop', {engaged: false, who: $('lock-name').value});

// --- joints panel -------------------------------------------------------------------------------
function buildJoints() {
  const body = $('joints-table').tBodies[0];
  body.innerHTML = '';
  model.joints.forEach((j, i) => {
    const tr = document.createElement('tr');
    tr.id = 'joint-' + (i + 1);
    const step = j.unit === 'deg' ? 0.1 : 1;
    tr.innerHTML = `<td title="${j.name}">${i + 1} ${j.name}</td>
      <td><input type="range" class="slider" min="${j.min}" max="${j.max}" step="${step}" value="${j.home}"></td>
      <td><input type="number" class="value" min="${j.min}" max="${j.max}" step="${step}" value="${j.home}"> ${j.unit}</td>
      <td><button class="jog-minus">-</button><button class="jog-plus">+</button></td>
      <td class="sp">-</td><td class="vq">-</td><td class="rq">-</td>
      <td><button class="apply">Apply</button></td>`;
    const slider = tr.querySelector('.slider'), value = tr.querySelector('.value');
    slider.title = `${fmt(j.min)} .. ${fmt(j.max)} ${j.unit}`;
    slider.addEventListener('input', () => { value.value = slider.value; });
    slider.addEventListener('change', () => { value.value = slider.value; if ($('follow-slider').checked) moveJoint(i); });
    value.addEventListener('change', () => { slider.value = value.value; });
    tr.querySelector('.apply').onclick = () => moveJoint(i);
    const jog = (sign) => {
      const base = latest && latest.setpoint ? latest.setpoint.goal[i] : Number(value.value);
      const v = Math.min(j.max, Math.max(j.min, base + sign * Number($('jog-step').value)));
      value.value = fmt(v, 2); slider.value = v; moveJoint(i);
    };
    tr.querySelector('.jog-minus').onclick = () => jog(-1);
    tr.querySelector('.jog-plus').onclick = () => jog(1);
    body.appendChild(tr);
  });
  const poses = $('named-pose');
  poses.innerHTML = '';
  for (const name of Object.keys(model.named_poses)) poses.add(new Option(name, name));
}
function jointInputs(i) { return $('joint-' + (i + 1)).querySelector('.value'); }
function speed() { return Math.min(1, Math.max(0.01, Number($('speed').value) / 100)); }
function moveJoint(i) {
  const targets = model.joints.map((_, k) => (k === i ? Number(jointInputs(k).value) : null));
  return post('api/move/joints', {targets, speed: speed()});
}
$('apply-all').onclick = () => post('api/move/joints',
  {targets: model.joints.map((_, k) => Number(jointInputs(k).value)), speed: speed()});
$('go-pose').onclick = () => {
  const q = model.named_poses[$('named-pose').value];
  if (q) post('api/move/joints', {targets: q, speed: speed()});
};
$('targets-from-arm').onclick = () => {
  if (!latest || !latest.virtual) return;
  latest.virtual.q.forEach((v, i) => {
    jointInputs(i).value = fmt(v, 2);
    $('joint-' + (i + 1)).querySelector('.slider').value = v;
  });
};
function updateJoints(s) {
  if (!model || !$('tab-joints').classList.contains('active')) return;
  model.joints.forEach((j, i) => {
    const tr = $('joint-' + (i + 1));
    if (!tr) return;
    tr.querySelector('.sp').textContent = s.setpoint ? fmt(s.setpoint.q[i], 2) : '-';
    tr.querySelector('.vq').textContent = s.virtual ? fmt(s.virtual.q[i], 2) : '-';
    tr.querySelector('.rq').textContent = s.real ? fmt(s.real.q[i], 2) : '-';
  });
}

// --- tool panel ---------------------------------------------------------------------------------
const toolIds = ['tx', 'ty', 'tz', 'troll', 'tpitch', 'tyaw'];
function toolTarget() { return toolIds.map((id) => Number($(id).value)); }
$('tool-from-arm').onclick = () => {
  if (!latest || !latest.virtual) return;
  latest.virtual.tool.forEach((v, i) => { $(toolIds[i]).value = fmt(v, i < 3 ? 4 : 2); });
};
$('ik-solve').onclick = async () => {
  const r = await post('api/ik', {pose: toolTarget()}, true);
  const b = r.body, body = $('ik-table').tBodies[0];
  body.innerHTML = '';
  if (r.status !== 200) return;
  $('ik-summary').textContent = `${b.solver} solver: ` + (b.ok ? `${b.solutions.length} solutions, nearest ${b.nearest}` : b.reason);
  const select = $('ik-config');
  select.innerHTML = '<option value="nearest">nearest</option>';
  const rows = b.configurations.length ? b.configurations : b.solutions.map((s) => ({config: s.config, reachable: true, within_limits: s.within_limits}));
  for (const c of rows) {
    const sol = b.solutions.find((s) => s.config === c.config);
    const tr = document.createElement('tr');
    tr.dataset.config = c.config;
    tr.innerHTML = `<td>${c.config}</td><td class="${c.reachable ? 'yes' : 'no'}">${c.reachable ? 'yes' : 'no'}</td>
      <td class="${c.within_limits ? 'yes' : 'no'}">${c.within_limits ? 'yes' : 'no'}</td>
      <td>${sol ? sol.q.map((v) => fmt(v, 1)).join(' ') : '-'}</td>`;
    body.appendChild(tr);
    if (c.within_limits) select.add(new Option(c.config, c.config));
  }
};
$('tool-apply').onclick = () => post('api/move/pose', {pose: toolTarget(), config: $('ik-config').value, speed: speed()});

// --- plan panel ---------------------------------------------------------------------------------
let planSteps = [];  // lines of the checked plan's steps
let planError = 0;
function renderListing() {
  const lines = $('plan-text').value.split('\n');
  const runningLine = latest && latest.controller && latest.controller.plan_name === $('plan-name').value
    && (latest.controller.state !== 'idle') ? latest.controller.plan_line : 0;
  const listing = $('plan-listing');
  if (listing.childElementCount !== lines.length) {
    listing.innerHTML = '';
    lines.forEach((text, i) => {
      const div = document.createElement('div');
      div.className = 'line';
      div.dataset.line = i + 1;
      div.innerHTML = `<span class="no">${i + 1}</span>`;
      div.appendChild(document.createTextNode(text || ' '));
      listing.appendChild(div);
    });
  }
  [...listing.children].forEach((div, i) => {
    const n = i + 1;
    div.classList.toggle('step', planSteps.includes(n));
    div.classList.toggle('running', n === runningLine);
    div.classList.toggle('error', n === planError);
    if (div.childNodes[1] && div.childNodes[1].textContent !== (lines[i] || ' ')) div.childNodes[1].textContent = lines[i] || ' ';
  });
}
$('plan-text').addEventListener('input', () => { planSteps = []; planError = 0; renderListing(); });
function showPlanAnswer(r) {
  const b = r.body;
  planError = 0;
  if (b.line) {
    planError = b.line;
    const lines = $('plan-text').value.split('\n');
    const start = lines.slice(0, b.line - 1).join('\n').length + (b.line > 1 ? 1 : 0);
    $('plan-text').setSelectionRange(start, start + (lines[b.line - 1] || '').length);
  }
  planSteps = b.steps ? b.steps.map((s) => s.line) : [];
  $('plan-result').textContent = b.ok ? b.message : b.error;
  $('plan-result').className = b.ok ? '' : 'error';
  renderListing();
}
const planBody = () => ({name: $('plan-name').value, text: $('plan-text').value});
$('plan-check').onclick = async () => showPlanAnswer(await post('api/plan/check', planBody(), true));
$('plan-run').onclick = async () => showPlanAnswer(await post('api/plan/run', planBody()));
for (const verb of ['pause', 'resume', 'abort', 'clear-fault']) {
  $('plan-' + verb).onclick = () => post('api/plan/' + verb, {});
}
$('plan-open').onclick = async () => {
  const path = $('plan-files').value;
  const r = await getJson('api/file?path=' + encodeURIComponent(path));
  if (r.error) return say(r.error, true);
  $('plan-text').value = r.text;
  $('plan-name').value = path.split('/').pop();
  planSteps = []; planError = 0; renderListing();
};
$('plan-upload').onchange = (e) => {
  const f = e.target.files[0];
  if (!f) return;
  f.text().then((text) => { $('plan-text').value = text; $('plan-name').value = f.name; planSteps = []; planError = 0; renderListing(); });
};
function updatePlan(s) {
  const c = s.controller;
  if (!c) return;
  $('plan-progress').textContent = c.plan_name
    ? `${c.plan_name}: step ${Math.min(c.plan_step + 1, c.plan_steps)}/${c.plan_steps} (line ${c.plan_line}), ${c.state}`
    : `no plan; controller ${c.state}`;
  renderListing();
}

// --- gains --------------------------------------------------------------------------------------
const gainFields = ['kp', 'kd', 'ki', 'il', 'ol', 'el', 'db'];
// --- planning around objects and the C-space view (docs/planning.md) -----------------------------
const planning = {plan: null, cspace: null};  // the last answers (read by the browser tests)
window.panelPlanning = planning;
function planGoal() {
  const values = $('pp-goal').value.trim().split(/[\s,]+/).filter((w) => w !== '').map(Number);
  const body = {config: $('pp-config').value.trim() || 'nearest', planner: $('pp-planner').value,
    seed: Number($('pp-seed').value)};
  body[$('pp-kind').value] = values;
  return body;
}
$('pp-make').onclick = async () => {
  $('pp-result').textContent = 'planning ...';
  $('pp-result').className = '';
  const r = await post('api/plan/make', planGoal(), true);
  if (r.status !== 200) {
    $('pp-result').textContent = r.body.error || ('HTTP ' + r.status);
    $('pp-result').className = 'error';
    $('pp-run').disabled = true;
    return;
  }
  planning.plan = r.body;
  $('pp-result').textContent = `${r.body.message}; around ${r.body.environment || 'no objects'}`;
  $('plan-name').value = 'around.plan';
  $('plan-text').value = r.body.text;
  planSteps = []; planError = 0; renderListing();
  View3d.setPath(r.body.tool_path, r.body.tool_waypoints);
  $('pp-run').disabled = false;
  if (planning.cspace) drawCSpace();
};
$('pp-run').onclick = async () => {
  if (!planning.plan) return;
  showPlanAnswer(await post('api/plan/run', {name: 'around.plan', text: planning.plan.text}));
};
$('pp-clear').onclick = () => {
  planning.plan = null;
  View3d.setPath(null);
  $('pp-run').disabled = true;
  $('pp-result').textContent = '';
  if (planning.cspace) drawCSpace();
};
function fillCSpaceJoints() {
  for (const [id, chosen] of [['cs-a', 1], ['cs-b', 2]]) {
    const select = $(id);
    const keep = select.value;
    select.innerHTML = model.joints.map((j, i) => `<option value="${i + 1}">${i + 1} ${j.name}</option>`).join('');
    select.value = keep || String(chosen + 1);
  }
}
const cellColours = ['#ffffff', '#8e2424', '#f0a030', '#5c7cfa'];
function drawCSpace() {
  const c = planning.cspace;
  const canvas = $('cs-canvas');
  const g = canvas.getContext('2d');
  const na = c.values_a.length, nb = c.values_b.length;
  const w = canvas.width, h = canvas.height;
  const a0 = c.values_a[0], a1 = c.values_a[na - 1], b0 = c.values_b[0], b1 = c.values_b[nb - 1];
  const x = (v) => (v - a0) / (a1 - a0) * w;
  const y = (v) => h - (v - b0) / (b1 - b0) * h;
  g.fillStyle = cellColours[0];
  g.fillRect(0, 0, w, h);
  const cw = w / na, ch = h / nb;
  for (let ib = 0; ib < nb; ib++) {
    for (let ia = 0; ia < na; ia++) {
      const cell = c.cells.charCodeAt(ib * na + ia) - 48;
      if (cell === 0) continue;
      g.fillStyle = cellColours[cell];
      g.fillRect(ia * cw, h - (ib + 1) * ch, cw + 0.5, ch + 0.5);
    }
  }
  const p = planning.plan;
  if (p) {
    const ja = c.joint_a, jb = c.joint_b;
    g.strokeStyle = 'rgba(90, 90, 90, 0.45)';
    g.lineWidth = 1;
    g.beginPath();
    for (const [i, k] of p.tree.edges) {
      const u = p.tree.vertices[i], v = p.tree.vertices[k];
      g.moveTo(x(u[ja]), y(u[jb]));
      g.lineTo(x(v[ja]), y(v[jb]));
    }
    g.stroke();
    g.strokeStyle = '#d81b60';
    g.lineWidth = 2.5;
    g.beginPath();
    p.waypoints.forEach((q, i) => (i === 0 ? g.moveTo(x(q[ja]), y(q[jb])) : g.lineTo(x(q[ja]), y(q[jb]))));
    g.stroke();
  }
  const q = latest && latest.setpoint ? latest.setpoint.q : c.fixed;
  g.fillStyle = '#2e7d32';
  g.beginPath();
  g.arc(x(q[c.joint_a]), y(q[c.joint_b]), 4, 0, 2 * Math.PI);
  g.fill();
}
$('cs-show').onclick = async () => {
  $('cs-result').textContent = 'computing ...';
  const r = await post('api/cspace', {joint_a: Number($('cs-a').value), joint_b: Number($('cs-b').value),
    step: Number($('cs-step').value)}, true);
  if (r.status !== 200) {
    $('cs-result').textContent = r.body.error || ('HTTP ' + r.status);
    $('cs-result').className = 'error';
    return;
  }
  planning.cspace = r.body;
  const names = [r.body.joint_a, r.body.joint_b].map((j) => `${j + 1} ${model.joints[j].name}`);
  $('cs-result').className = '';
  $('cs-result').textContent = `${r.body.message}; x: joint ${names[0]}, y: joint ${names[1]}, ` +
    `the other joints where the goals are now` + (planning.plan ? '; the last plan and its tree projected on these two joints' : '');
  drawCSpace();
};

async function loadGains() {
  const g = await getJson('api/gains');
  const body = $('gains-table').tBodies[0];
  if (!g.virtual) { body.innerHTML = '<tr><td colspan="9">no CONTROLLER_GAINS heard</td></tr>'; return g; }
  body.innerHTML = '';
  g.virtual.forEach((row, i) => {
    const tr = document.createElement('tr');
    tr.id = 'gains-' + (i + 1);
    tr.innerHTML = `<td>${i + 1}</td>` + gainFields.map((f) => `<td><input type="number" class="${f}" value="${row[f]}" step="1"></td>`).join('') +
      '<td><button class="apply">Apply</button></td>';
    tr.querySelector('.apply').onclick = async () => {
      const values = {};
      for (const f of gainFields) {
        const v = Number(tr.querySelector('.' + f).value);
        if (v !== row[f]) values[f] = v;
      }
      if (!Object.keys(values).length) return say('nothing changed on joint ' + (i + 1));
      await post('api/gains', {joint: i + 1, values});
      setTimeout(loadGains, 1500);  // the controller repeats its gains at 1 Hz
    };
    body.appendChild(tr);
  });
  const real = $('real-gains-table').tBodies[0];
  real.innerHTML = g.real ? g.real.map((row, i) => `<tr><td>${i + 1}</td>` + gainFields.map((f) => `<td>${f} ${row[f]}</td>`).join('') + '</tr>').join('')
    : '<tr><td>no REAL_ARM_GAINS heard (no bridge)</td></tr>';
  return g;
}
window.loadGains = loadGains;
document.querySelector('[data-tab=gains]').addEventListener('click', loadGains);

// --- plots --------------------------------------------------------------------------------------
const plotWindowS = 10;
let plotData = [];  // [t, sp1, v1, r1, ...] per joint
let plot = null, plotPaused = false, plotJoints = [1, 2, 3];
function plotLabels() {
  const labels = ['t'];
  for (const j of plotJoints) {
    if ($('plot-errors').checked) labels.push(`err${j} sp-virtual`, `err${j} sp-real`);
    else labels.push(`sp${j}`, `virtual${j}`, `real${j}`);
  }
  return labels;
}
function plotRows() {
  return plotData.map((d) => {
    const row = [d.t];
    for (const j of plotJoints) {
      const sp = d.sp ? d.sp[j - 1] : null, v = d.v ? d.v[j - 1] : null, r = d.r ? d.r[j - 1] : null;
      if ($('plot-errors').checked) row.push(sp !== null && v !== null ? sp - v : null, sp !== null && r !== null ? sp - r : null);
      else row.push(sp, v, r);
    }
    return row;
  });
}
function buildPlots() {
  const box = $('plot-joints');
  box.innerHTML = 'joints: ';
  model.joints.forEach((j, i) => {
    const label = document.createElement('label');
    label.innerHTML = `<input type="checkbox" value="${i + 1}" ${plotJoints.includes(i + 1) ? 'checked' : ''}>${i + 1} `;
    label.querySelector('input').onchange = () => {
      plotJoints = [...box.querySelectorAll('input:checked')].map((x) => Number(x.value));
      redrawPlot(true);
    };
    box.appendChild(label);
  });
}
function redrawPlot(rebuild) {
  const rows = plotRows();
  if (!rows.length || !plotJoints.length) return;
  if (!plot || rebuild) {
    if (plot) plot.destroy();
    plot = new Dygraph($('plot'), rows, {labels: plotLabels(), xlabel: 'sim time s', ylabel: model.joints[0].unit,
      connectSeparatedPoints: false, legend: 'always', animatedZooms: false});
  } else {
    plot.updateOptions({file: rows});
  }
}
$('plot-errors').onchange = () => redrawPlot(true);
$('plot-pause').onclick = () => { plotPaused = !plotPaused; $('plot-pause').textContent = plotPaused ? 'Resume' : 'Pause'; };
$('plot-csv').onclick = () => {
  const lines = [plotLabels().join(',')].concat(plotRows().map((r) => r.map((v) => (v === null ? '' : v)).join(',')));
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([lines.join('\n') + '\n'], {type: 'text/csv'}));
  a.download = 'sirupp-plot.csv';
  a.click();
};
function addPlotSample(s) {
  if (plotPaused || s.sim_utime === undefined) return;
  const t = s.sim_utime / 1e6;
  if (plotData.length && t < plotData[plotData.length - 1].t) plotData = [];  // the sim restarted
  plotData.push({t, sp: s.setpoint ? s.setpoint.q : null, v: s.virtual ? s.virtual.q : null, r: s.real ? s.real.q : null});
  while (plotData.length && plotData[0].t < t - plotWindowS) plotData.shift();
}
setInterval(() => { if (!plotPaused && $('tab-plots').classList.contains('active')) redrawPlot(false); }, 250);

// --- real arm -----------------------------------------------------------------------------------
for (const verb of ['connect', 'calibrate', 'arm', 'disarm', 'link', 'unlink', 'home', 'clear-faults']) {
  const b = document.createElement('button');
  b.textContent = verb;
  b.id = 'hw-' + verb;
  b.onclick = () => post('api/hardware/' + verb, {who: $('lock-name').value});
  $('hw-buttons').appendChild(b);
}
function updateHardware(s) {
  const h = s.hardware;
  if (!h || !$('tab-real').classList.contains('active')) return;
  const lost = h.age_s > 1 ? `LOST: no status from sirupp-hardware for ${h.age_s.toFixed(1)} s; last heard: ` : '';
  $('hw-status').textContent = lost + `bridge ${h.state}, ${h.calibrated ? 'calibrated' : 'not calibrated'}, port ${h.port} ${h.baud} baud, ` +
    `${h.checksum_errors} checksum errors, ${h.timeouts} timeouts` + (h.last_error ? `; last error: ${h.last_error}` : '');
  $('hw-modules').tBodies[0].innerHTML = h.modules.map((m, i) =>
    `<tr><td>${i + 1}</td><td>0x${m.status.toString(16)}</td><td>0x${m.aux.toString(16)}</td><td>${m.counts}</td><td>${m.error_counts}</td></tr>`).join('');
}

// --- processes ----------------------------------------------------------------------------------
async function loadProcesses() {
  const p = await getJson('api/processes');
  $('rtf').textContent = p.realtime_factor !== undefined ? 'sim real-time factor ' + fmt(p.realtime_factor, 3) : '';
  $('processes-table').tBodies[0].innerHTML = p.processes.map((r) =>
    `<tr class="${r.alive ? '' : 'limit'}"><td>${r.process}</td><td>${r.host}</td><td>${r.pid}</td><td>${r.alive ? r.state : 'silent ' + fmt(r.silent_s, 0) + ' s'}</td>
     <td>${fmt(r.uptime_s, 0)}</td><td>${r.rejected}</td><td>${r.late}</td><td>${r.decode_errors}</td>
     <td style="text-align:left">${Object.entries(r.rates).map(([c, v]) => `${c} ${fmt(v, 0)}`).join('<br>')}</td><td>${r.detail}</td></tr>`).join('');
}

// --- model and environment ----------------------------------------------------------------------
function showModel() {
  $('model-name').textContent = model.name;
  $('model-summary').textContent = `${model.name}: ${model.description} (${model.source_file}, ${model.dh_convention} DH, ` +
    `base at ${model.base_position.map((v) => fmt(v, 3)).join(' ')} m, servo tick ${model.servo_tick_s * 1000} ms)`;
  $('model-dh').innerHTML = '<tr><th>joint</th><th>a mm</th><th>alpha deg</th><th>d mm</th><th>theta deg</th></tr>' +
    model.joints.map((j, i) => `<tr><td>${i + 1} ${j.name}</td><td>${fmt(j.dh.a_mm, 2)}</td><td>${fmt(j.dh.alpha_deg, 1)}</td><td>${fmt(j.dh.d_mm, 2)}</td><td>${fmt(j.dh.theta_deg, 1)}</td></tr>`).join('');
  $('model-joints').innerHTML = '<tr><th>joint</th><th>type</th><th>min</th><th>max</th><th>max speed /s</th><th>default speed</th><th>accel</th><th>effort max</th><th>static</th><th>coulomb +/-</th><th>viscous</th></tr>' +
    model.joints.map((j, i) => `<tr><td>${i + 1} ${j.name}</td><td>${j.type}</td><td>${fmt(j.min)} ${j.unit}</td><td>${fmt(j.max)} ${j.unit}</td><td>${fmt(j.velocity_max)}</td><td>${fmt(j.default_velocity)}</td><td>${fmt(j.default_acceleration)}</td>` +
      `<td>${fmt(j.effort_max, 2)}</td><td>${fmt(j.friction.static, 3)}</td><td>${fmt(j.friction.coulomb_positive, 3)}/${fmt(j.friction.coulomb_negative, 3)}</td><td>${fmt(j.friction.viscous, 4)}</td></tr>`).join('');
  $('model-links').innerHTML = '<tr><th>link</th><th>mass kg</th><th>centre of mass m</th><th>shapes</th></tr>' +
    model.links.map((l) => `<tr><td>${l.name}</td><td>${fmt(l.mass, 3)}</td><td>${l.com.map((v) => fmt(v, 3)).join(' ')}</td><td>${l.shapes.map((s) => s.type + ' ' + s.size.map((v) => fmt(v, 3)).join('x')).join(', ')}</td></tr>`).join('');
}
async function loadEnvironment() {
  const env = await getJson('api/environment');
  View3d.setEnvironment(env);
  $('env-summary').textContent = env.loaded ? `${env.name || '(none)'} from ${env.source_file || '-'}: ${env.objects.length} objects` : 'no ENVIRONMENT heard';
  $('env-table').tBodies[0].innerHTML = env.objects.map((o) =>
    `<tr><td>${o.name}</td><td>${o.shape.type}</td><td>${o.shape.position.map((v) => fmt(v, 3)).join(' ')}</td><td>${o.shape.size.map((v) => fmt(v, 3)).join(' ')}</td><td>${o.static ? 'yes' : 'no'}</td><td>${fmt(o.mass, 2)}</td></tr>`).join('');
}
$('env-open').onclick = async () => {
  const path = $('env-files').value;
  const f = await getJson('api/file?path=' + encodeURIComponent(path));
  if (f.error) return say(f.error, true);
  const r = await post('api/environment/check', {name: path, text: f.text}, true);
  $('env-result').className = r.body.ok ? '' : 'error';
  $('env-result').textContent = r.body.ok ? `${path}: ${r.body.objects.length} objects, drawn as wireframes (start the sim with --environment ${path} to use it)` : r.body.error;
  View3d.setPreview(r.body.ok ? r.body.objects : null);
};
$('env-clear').onclick = () => { View3d.setPreview(null); $('env-result').textContent = ''; };
$('env-load').onclick = async () => {
  const path = $('env-files').value;
  const f = await getJson('api/file?path=' + encodeURIComponent(path));
  if (f.error) return say(f.error, true);
  const r = await post('api/environment/load', {name: path, text: f.text});
  $('env-result').className = r.status === 200 ? '' : 'error';
  $('env-result').textContent = r.status === 200 ? r.body.message : r.body.error;
  if (r.status === 200) { View3d.setPreview(null); setTimeout(loadEnvironment, 300); }
};

// --- model editing ------------------------------------------------------------------------------
let modelFields = null;  // {path, units, fields: [{key, group, value, line}]}
async function loadModelFields() {
  if (!model) return;
  const r = await getJson('api/model/fields?path=' + encodeURIComponent(model.source_file));
  const box = $('model-edit');
  if (r.error) { box.textContent = 'not editable here: ' + r.error; modelFields = null; return; }
  modelFields = r;
  $('model-edit-file').textContent = r.path;
  $('model-edit-units').textContent = r.units;
  const groups = {dh: 'DH rows', joints: 'Joints: limits, speed, effort, friction', links: 'Links: mass'};
  box.innerHTML = '';
  for (const [group, title] of Object.entries(groups)) {
    const fields = r.fields.filter((f) => f.group === group);
    if (!fields.length) continue;
    const div = document.createElement('div');
    div.className = 'edit-group';
    div.innerHTML = `<h5>${title}</h5>`;
    for (const f of fields) {
      const label = document.createElement('label');
      label.className = 'edit-field';
      label.title = `${r.path}:${f.line}`;
      label.innerHTML = `<span>${f.key}</span> <input data-key="${f.key}" size="9">`;
      const input = label.querySelector('input');
      input.value = f.value;
      input.dataset.original = f.value;
      input.addEventListener('input', () => input.classList.toggle('changed', input.value !== input.dataset.original));
      div.appendChild(label);
    }
    box.appendChild(div);
  }
}
function modelEdits() {
  const edits = {};
  for (const input of document.querySelectorAll('#model-edit input')) {
    input.classList.remove('bad');
    if (input.value !== input.dataset.original) edits[input.dataset.key] = input.value;
  }
  return edits;
}
function showModelAnswer(r) {
  const b = r.body;
  $('model-result').className = r.status === 200 ? '' : 'error';
  $('model-result').textContent = r.status === 200 ? b.message : b.error;
  if (b.field) {
    const input = document.querySelector(`#model-edit input[data-key="${b.field}"]`);
    if (input) { input.classList.add('bad'); input.focus(); }
  }
}
$('model-check').onclick = async () => {
  if (!modelFields) return;
  showModelAnswer(await post('api/model/check', {path: modelFields.path, edits: modelEdits()}, true));
};
let savedModel = null;  // the file the last Save wrote: what Apply loads
$('model-save').onclick = async () => {
  if (!modelFields) return;
  const r = await post('api/model/save', {path: modelFields.path, edits: modelEdits(), name: $('model-save-name').value}, true);
  showModelAnswer(r);
  if (r.status === 200) {
    savedModel = r.body.path;
    $('model-apply').disabled = false;
    $('model-apply').textContent = 'Apply ' + savedModel + ' to the running sim';
  }
};
$('model-apply').onclick = async () => {
  if (!savedModel) return;
  const r = await post('api/model/apply', {path: savedModel});
  $('model-result').className = r.status === 200 ? '' : 'error';
  $('model-result').textContent = r.status === 200 ? r.body.message : r.body.error;
  // The new ROBOT_MODEL raises model_version: onState reloads the model, sliders and 3D view.
};
$('model-reset').onclick = () => loadModelFields();

// --- record -------------------------------------------------------------------------------------
function sizeText(bytes) {
  return bytes >= 1048576 ? fmt(bytes / 1048576, 1) + ' MiB' : bytes >= 1024 ? fmt(bytes / 1024, 1) + ' KiB' : bytes + ' B';
}
async function loadRecord() {
  const r = await getJson('api/record');
  $('record-logger').textContent = r.logger ? `sirupp-logger ${r.logger.state} on ${r.logger.host}: ${r.logger.detail}` : 'no sirupp-logger heard (start it, e.g. from the lab layout)';
  $('record-logger').className = r.logger ? '' : 'error';
  const body = $('record-runs').tBodies[0];
  if (!r.results_dir) { body.innerHTML = '<tr><td colspan="4">no results folder (sirupp-panel --results DIR)</td></tr>'; return r; }
  body.innerHTML = '';
  for (const run of r.runs) {
    const tr = document.createElement('tr');
    tr.className = run.recording ? 'recording' : '';
    tr.dataset.run = run.name;
    const links = run.files.map((f) => {
      const name = f.path.split('/').pop();
      return `<a href="api/download?path=${encodeURIComponent(f.path)}" download="${name}">${name}</a> (${sizeText(f.size)})`;
    }).join('<br>');
    tr.innerHTML = `<td>${run.name}${run.recording ? ' <b>recording</b>' : ''}</td><td style="text-align:left">${links}</td><td>${sizeText(run.bytes)}</td><td></td>`;
    if (!run.recording) {
      const b = document.createElement('button');
      b.textContent = 'Report';
      b.className = 'report';
      b.onclick = async () => {
        const a = await post('api/record/report', {run: run.name});
        $('record-report').textContent = a.status === 200 ? a.body.markdown : a.body.error;
      };
      tr.lastChild.appendChild(b);
    }
    body.appendChild(tr);
  }
  return r;
}
window.loadRecord = loadRecord;
$('record-start').onclick = async () => {
  const r = await post('api/record/start', {name: $('record-name').value});
  $('record-result').className = r.status === 200 ? '' : 'error';
  $('record-result').textContent = r.status === 200 ? r.body.message : r.body.error;
  loadRecord();
};
$('record-stop').onclick = async () => {
  const r = await post('api/record/stop', {});
  $('record-result').className = r.status === 200 ? '' : 'error';
  $('record-result').textContent = r.status === 200 ? r.body.message : r.body.error;
  loadRecord();
};
document.querySelector('[data-tab=record]').addEventListener('click', loadRecord);
setInterval(() => { if ($('tab-record').classList.contains('active')) loadRecord(); }, 1000);
async function loadFileLists() {
  for (const [dir, select] of [['plans', 'plan-files'], ['environments', 'env-files']]) {
    const r = await getJson('api/files?dir=' + dir);
    $(select).innerHTML = '';
    for (const f of r.files || []) $(select).add(new Option(f, f));
  }
}

// --- live state ---------------------------------------------------------------------------------
async function loadModel() {
  const m = await getJson('api/model');
  if (!m.loaded) return false;
  model = m;
  View3d.setModel(model);
  buildJoints();
  buildPlots();
  showModel();
  fillCSpaceJoints();
  loadModelFields();
  return true;
}

function onState(s) {
  stats.received++;
  latest = s;
  if (!model || s.model_version !== model.version) { loadModel(); return; }
  const c = s.controller;
  $('controller').textContent = c ? `controller: ${c.mode}, ${c.state}` + (c.last_error ? ` (${c.last_error})` : '') : 'controller: not heard';
  const estop = (s.sim && s.sim.estop) || (s.estop && s.estop.engaged);
  $('estop').classList.toggle('engaged', !!estop);
  $('estop').textContent = estop ? 'E-STOP (engaged)' : 'E-STOP';
  if (s.virtual) $('tool-live').textContent = 'tool: ' + s.virtual.tool.slice(0, 3).map((v) => fmt(v, 4)).join(' ') +
    ' m, rpy ' + s.virtual.tool.slice(3).map((v) => fmt(v, 1)).join(' ') + ' deg';
  addPlotSample(s);
}

function frame() {
  requestAnimationFrame(frame);
  stats.frames++;
  const s = latest;
  if (s && model && s.generation !== drawnGeneration && s.model_version === model.version) {
    drawnGeneration = s.generation;
    View3d.pose('virtual', s.virtual);
    View3d.pose('setpoint', s.setpoint);
    View3d.pose('real', s.real);
    // The tables change text at most 10 times a second (reading them faster helps nobody, and
    // each change costs the page a layout).
    const now = performance.now();
    if (now - lastTables >= 100) {
      lastTables = now;
      updateJoints(s);
      updatePlan(s);
      updateHardware(s);
    }
    if (s.recv_ms) {
      stats.latencies.push(performance.timeOrigin + performance.now() - s.recv_ms);
      if (stats.latencies.length > 5000) stats.latencies.shift();
    }
  }
  if (View3d.render()) stats.drawn++;
}
let lastTables = 0;

let fpsCount = 0;
setInterval(() => {
  stats.fps = stats.frames - fpsCount;
  fpsCount = stats.frames;
  $('fps').textContent = stats.fps + ' fps';
}, 1000);

function connect() {
  const hz = Number(params.get('hz')) || 60;
  const events = new EventSource('api/events?hz=' + hz);
  events.onopen = () => { $('connection').textContent = 'live'; $('connection').className = 'good'; };
  events.onmessage = (e) => onState(JSON.parse(e.data));
  events.onerror = () => { $('connection').textContent = 'reconnecting'; $('connection').className = 'bad'; };
}

View3d.init($('view'));
loadModel();
loadEnvironment();
loadFileLists();
refreshLock();
loadProcesses();
setInterval(() => { loadProcesses(); refreshLock(); }, 1000);
setInterval(loadEnvironment, 10000);
connect();
requestAnimationFrame(frame);
window.panelReady = true;
