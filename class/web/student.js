// The class server's bar on a student's page (class/class_server.cpp inserts it into the panel's
// page): who and which rig this is, whether the rig was started again (and why it had stopped),
// and a button to start it again when it is stopped. The panel itself is unchanged.
'use strict';
(() => {
  const status = document.getElementById('class-status');
  const clientId = 'class-' + Math.random().toString(36).slice(2);
  let shownStarts = null;
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
    } else {
      rig = `<span id="class-rig-state" class="warn">${text(s.state)}</span> (${text(s.last_stop || 'not started')}); your files are kept.`;
      if (s.role === 'student') rig += ' <button id="class-start">Start my rig again</button>';
    }
    status.innerHTML = `Class ${text(s.class)} &middot; ${who} &middot; rig: ${rig}`;
    const button = document.getElementById('class-start');
    if (button) button.onclick = startAgain;
    if (shownStarts !== null && s.state === 'running' && s.starts !== shownStarts) location.reload();
    shownStarts = s.state === 'running' ? s.starts : shownStarts;
  }
  refresh();
  setInterval(refresh, 2000);
})();
// Controllers from the browser (class/web/submit.js: submit, errors at their lines, run, grades).
document.body.appendChild(Object.assign(document.createElement('script'), {src: 'submit.js'}));
