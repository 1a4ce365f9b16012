// The teacher's page: every rig of the class from one event stream (/teacher/api/events, twice a
// second whatever the number of rigs), a read-only link to each, stop / restart, e-stop all; and
// the real arm's queue when the class has one (end a turn, skip, pause, resume, e-stop).
'use strict';
const $ = (id) => document.getElementById(id);
const clientId = 'teacher-' + Math.random().toString(36).slice(2);
const text = (s) => String(s === undefined || s === null ? '' : s)
  .replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c]));

async function post(path, body) {
  const r = await fetch(path, {method: 'POST', headers: {'X-Sirupp-Client': clientId, 'Content-Type': 'application/json'},
                               body: JSON.stringify(body || {})});
  const answer = await r.json();
  $('answer').textContent = r.ok ? '' : answer.error;
  return answer;
}

function ago(seconds) {
  if (seconds < 2) return 'now';
  if (seconds < 120) return Math.round(seconds) + ' s ago';
  return Math.round(seconds / 60) + ' min ago';
}

function row(rig) {
  const c = rig.controller || {};
  const faults = [c.last_error, rig.estop && rig.estop.engaged ? 'E-STOP (' + rig.estop.reason + ')' : '',
                  rig.state === 'failed' ? rig.last_stop : ''].filter((x) => x).join('; ');
  const plan = c.plan_name ? `${c.plan_name} ${c.plan_step}/${c.plan_steps}` : '-';
  const rtf = rig.sim ? rig.sim.realtime_factor.toFixed(3) : '-';
  // A rig that runs as a cluster job (docs/cluster.md) may be pending (waiting for the cluster,
  // Slurm's reason in `waiting`) or unknown (the cluster did not answer); it can be stopped then.
  const waits = rig.state === 'pending' || rig.state === 'unknown' || rig.state === 'starting';
  const state = rig.state === 'running' ? 'running'
      : waits ? `${rig.state === 'unknown' ? 'state unknown' : 'waiting for the cluster'}${rig.waiting ? ' (' + rig.waiting + ')' : ''}`
      : `${rig.state}${rig.last_stop ? ' (' + rig.last_stop + ')' : ''}`;
  const verb = rig.state === 'running' || waits ? 'stop' : 'start';
  return `<tr id="rig-${text(rig.name)}" data-state="${text(rig.state)}">
    <td>${text(rig.name)}</td><td class="${text(rig.state)}">${text(state)}</td>
    <td>${text(c.state || '-')}</td><td>${text(plan)}</td><td>${text(faults || '-')}</td>
    <td>${rtf}</td><td>${rig.streams > 0 ? 'page open' : ago(rig.idle_s)}</td>
    <td>${rig.state === 'running' ? rig.cpu_percent.toFixed(0) + ' %' +
          (rig.on_cpu >= 0 ? ` (CPU ${rig.on_cpu})` : '') : '-'}</td>
    <td><a href="/s/${encodeURIComponent(rig.name)}/" target="_blank">open (read-only)</a>
      <button data-verb="${verb}" data-name="${text(rig.name)}">${verb}</button>
      <button data-verb="restart" data-name="${text(rig.name)}">restart</button></td></tr>`;
}

const clock = (us) => (us ? new Date(us / 1000).toLocaleTimeString() : '-');

// The real arm's queue (class/real_arm.hpp), from the same stream.
function showTurns(t) {
  $('real-arm-queue').hidden = !t.enabled;
  if (!t.enabled) return;
  let state = `Phase: <strong>${text(t.phase)}</strong>`;
  if (t.holder) state += `, holder <strong>${text(t.holder)}</strong>`;
  if (t.phase === 'turn') state += ` (${Math.round(t.turn_left_s)} s left)`;
  if (t.step) state += `, step: ${text(t.step)}`;
  if (t.paused) state += ', <strong>paused</strong>';
  state += `. Bridge: ${text(t.bridge)}. Turns of ${t.turn_s} s.`;
  if (t.stopped) state += `<br><span class="stopped" id="turn-stopped">STOPPED: ${text(t.stopped)}</span> ` +
                          '(see to the arm, then release its e-stop if engaged and resume the queue)';
  $('turn-state').innerHTML = state;
  $('turn-queue').innerHTML = t.queue.length ? t.queue.map((w) =>
    `<li>${text(w.student)} (about ${Math.round(w.estimated_wait_s)} s) <button data-skip="${text(w.student)}">skip</button></li>`).join('')
    : '<li class="empty">nobody waiting</li>';
  for (const b of document.querySelectorAll('#turn-queue button')) {
    b.onclick = () => post('api/turns/skip', {student: b.dataset.skip});
  }
  $('turn-history').innerHTML = t.history.map((h) => `<tr><td>${text(h.student)}</td><td>${clock(h.start_us)}</td>
    <td>${clock(h.end_us)}</td><td>${text(h.ended || 'running')}</td><td>${text(h.plans.join(', ') || '-')}</td>
    <td>${h.handover_in_s.toFixed(1)} s</td><td>${h.handover_out_s ? h.handover_out_s.toFixed(1) + ' s' : '-'}</td>
    <td>${text(h.handover || '-')}</td></tr>`).join('');
  $('turn-events').innerHTML = t.events.map((e) => `<li>${text(e)}</li>`).join('');
}
for (const verb of ['end', 'pause', 'resume', 'estop', 'release']) {
  $('turn-' + verb).onclick = () => post('api/turns/' + verb, {});
}

function show(c) {
  $('class-name').textContent = `Class ${c.class}` + (c.description ? `: ${c.description}` : '');
  $('summary').textContent = `${c.running} of at most ${c.max_rigs} rigs running; idle rigs stop after ${c.idle_timeout_s} s.`;
  $('rigs').innerHTML = c.rigs.map(row).join('');
  showTurns(c.real_arm);
  for (const b of document.querySelectorAll('#rigs button')) {
    b.onclick = () => post(`api/rigs/${encodeURIComponent(b.dataset.name)}/${b.dataset.verb}`, {});
  }
}

$('estop-all').onclick = () => post('api/estop', {engaged: true});
$('release-all').onclick = () => post('api/estop', {engaged: false});
const events = new EventSource('api/events');
events.onmessage = (e) => show(JSON.parse(e.data));
