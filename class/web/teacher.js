// The teacher's page: every rig of the class from one event stream (/teacher/api/events, twice a
// second whatever the number of rigs), a read-only link to each, stop / restart, e-stop all.
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
  const state = rig.state === 'running' ? 'running' : `${rig.state}${rig.last_stop ? ' (' + rig.last_stop + ')' : ''}`;
  const verb = rig.state === 'running' ? 'stop' : 'start';
  return `<tr id="rig-${text(rig.name)}" data-state="${text(rig.state)}">
    <td>${text(rig.name)}</td><td class="${text(rig.state)}">${text(state)}</td>
    <td>${text(c.state || '-')}</td><td>${text(plan)}</td><td>${text(faults || '-')}</td>
    <td>${rtf}</td><td>${rig.streams > 0 ? 'page open' : ago(rig.idle_s)}</td>
    <td>${rig.state === 'running' ? rig.cpu_percent.toFixed(0) + ' %' : '-'}</td>
    <td><a href="/s/${encodeURIComponent(rig.name)}/" target="_blank">open (read-only)</a>
      <button data-verb="${verb}" data-name="${text(rig.name)}">${verb}</button>
      <button data-verb="restart" data-name="${text(rig.name)}">restart</button></td></tr>`;
}

function show(c) {
  $('class-name').textContent = `Class ${c.class}` + (c.description ? `: ${c.description}` : '');
  $('summary').textContent = `${c.running} of at most ${c.max_rigs} rigs running; idle rigs stop after ${c.idle_timeout_s} s.`;
  $('rigs').innerHTML = c.rigs.map(row).join('');
  for (const b of document.querySelectorAll('#rigs button')) {
    b.onclick = () => post(`api/rigs/${encodeURIComponent(b.dataset.name)}/${b.dataset.verb}`, {});
  }
}

$('estop-all').onclick = () => post('api/estop', {engaged: true});
$('release-all').onclick = () => post('api/estop', {engaged: false});
const events = new EventSource('api/events');
events.onmessage = (e) => show(JSON.parse(e.data));
