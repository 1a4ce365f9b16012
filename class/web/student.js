// The class server's bar on a student's page (class/class_server.cpp inserts it into the panel's
// page): who and which rig this is, whether the rig was started again (and why it had stopped),
// and a button to start it again when it is stopped; and the real arm's queue when the class has
// one (place, wait, the turn's time left, e-stop of the real arm). The panel itself is unchanged.
'use strict';
(() => {
  const status = document.getElementById('class-status');
  const clientId = 'class-' + Math.random().toString(36).slice(2);
  let shownStarts = null;
  let waited = false;
  const text = (s) => String(s).replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c]));
  async function startAgain() {
    status.textContent = 'starting your rig...';
    const r = await fetch('class/start', {method: 'POST', headers: {'X-Sirupp-Client': clientId}});
    if (r.ok) location.reload();
    else status.textContent = (await r.json()).error;
  }
  async function refresh() {
    let s;
    try {
      const r = await fetch('class/status');
      if (!r.ok) { status.textContent = 'class server: ' + (await r.json()).error; return; }
      s = await r.json();
    } catch (e) { status.textContent = 'class server unreachable'; return; }
    const who = s.role === 'teacher' ? `teacher's read-only view of ${text(s.name)}'s rig` : text(s.name);
    let rig;
    if (s.state === 'running') {
      rig = `<span id="class-rig-state">running</span> (ready in ${s.start_s.toFixed(1)} s at ${text(s.started_at)})`;
      if (s.starts > 1 || (s.last_stop && s.last_stop !== '')) {
        rig += ` <span id="class-restarted" class="warn">started again; before: ${text(s.last_stop || 'a server restart')}. ` +
               `Your files are kept (${s.files} in your folder).</span>`;
      } else if (s.files > 0) {
        rig += ` <span id="class-restarted" class="warn">a new rig on your folder: ${s.files} file(s) from earlier sessions kept.</span>`;
      }
    } else if (s.state === 'pending' || s.state === 'unknown' || s.state === 'starting') {
      // A rig that runs as a job on the class's cluster (docs/cluster.md) waits for a node.
      const what = s.state === 'unknown' ? 'state unknown' : 'waiting for the cluster';
      rig = `<span id="class-rig-state" class="warn">${what}</span> (${text(s.waiting || s.state)})`;
      waited = true;
    } else {
      rig = `<span id="class-rig-state" class="warn">${text(s.state)}</span> (${text(s.last_stop || 'not started')}); your files are kept.`;
      if (s.role === 'student') rig += ' <button id="class-start">Start my rig again</button>';
    }
    // The class's notebooks (class file notebooks.hub_url): the hub on its own hostname.
    const notebooks = s.notebooks_url
      ? ` &middot; <a id="class-notebooks" href="${text(s.notebooks_url)}" target="_blank" rel="noopener">Notebooks</a>`
      : '';
    status.innerHTML = `Class ${text(s.class)} &middot; ${who} &middot; rig: ${rig}${notebooks}`;
    const button = document.getElementById('class-start');
    if (button) button.onclick = startAgain;
    if (shownStarts !== null && s.state === 'running' && s.starts !== shownStarts) location.reload();
    if (waited && s.state === 'running') location.reload();  // the page connects to the ready rig
    shownStarts = s.state === 'running' ? s.starts : shownStarts;
  }
  refresh();
  setInterval(refresh, 2000);

  // The real arm's queue (class/real_arm.hpp): join, leave, end my turn, e-stop the real arm.
  const queue = document.getElementById('real-arm-queue');
  const minutes = (s) => (s < 90 ? `${Math.round(s)} s` : `${Math.round(s / 60)} min`);
  async function turnCommand(verb) {
    const r = await fetch('class/turns/' + verb, {method: 'POST', headers: {'X-Sirupp-Client': clientId}});
    const answer = await r.json();
    if (!r.ok) document.getElementById('turn-answer').textContent = answer.error;
    else showTurns(answer);
  }
  function showTurns(t) {
    if (!t.enabled) { queue.hidden = true; return; }
    queue.hidden = false;
    const you = t.you;
    let line;
    let buttons = '';
    if (t.stopped) {
      line = `<span class="warn" id="turn-line">The queue is stopped: ${text(t.stopped)}. The teacher has been told.</span>`;
    } else if (you.in_turn) {
      const last = t.warn_before_s.length ? Math.max(...t.warn_before_s) : 0;
      line = `<strong id="turn-line" class="${you.turn_left_s <= last ? 'warn' : ''}">YOUR TURN on the real arm: ` +
             `${minutes(you.turn_left_s)} left.</strong> Your moves and plans drive the real arm too.`;
      buttons = '<button id="turn-done">End my turn</button>';
    } else if (you.holder) {
      line = `<span id="turn-line">Your turn is being prepared: ${text(you.step || t.phase)}...</span>`;
    } else if (you.place > 0) {
      line = `<span id="turn-line">You are number ${you.place} in the queue (about ${minutes(you.estimated_wait_s)}).</span>`;
      buttons = '<button id="turn-leave">Leave the queue</button>';
    } else {
      const who = t.holder ? `${text(t.holder)}'s turn (${text(t.phase)})` : 'free';
      line = `<span id="turn-line">The real arm: ${who}; ${t.queue_length} waiting. Turns of ${minutes(t.turn_s)}.</span>`;
      buttons = '<button id="turn-join">Join the queue</button>';
    }
    if (t.paused && !t.stopped) line += ' <span class="warn">(the teacher paused the queue)</span>';
    const latest = t.events.length ? `<span class="turn-event" id="turn-event">${text(t.events[t.events.length - 1])}</span>` : '';
    queue.innerHTML = `${line} ${buttons} <button id="turn-estop" class="estop-real">E-STOP THE REAL ARM</button> ` +
                      `<span id="turn-answer" class="warn"></span> ${latest}`;
    for (const verb of ['join', 'leave', 'done', 'estop']) {
      const b = document.getElementById('turn-' + verb);
      if (b) b.onclick = () => turnCommand(verb);
    }
  }
  async function refreshTurns() {
    try {
      const r = await fetch('class/turns');
      if (r.ok) showTurns(await r.json());
    } catch (e) { /* the bar above says the server is unreachable */ }
  }
  refreshTurns();
  setInterval(refreshTurns, 1000);
})();
// Controllers from the browser (class/web/submit.js: submit, errors at their lines, run, grades).
document.body.appendChild(Object.assign(document.createElement('script'), {src: 'submit.js'}));
// Notebook assignments (class/web/assignments.js: submit a notebook, its scores and output).
document.body.appendChild(Object.assign(document.createElement('script'), {src: 'assignments.js'}));
