// "My controller" on a student's page (loaded by class/web/student.js): write or load one C++ or
// Python file, submit it (the server builds C++ and shows the compiler's errors at their lines),
// run a submission on the rig in place of the PIC-SERVO law or go back to the built-in law, and
// see every submission's grade, report and plots. API: class/submissions, class/run
// (class/submissions.hpp). docs/student-controllers.md.
'use strict';
(() => {
  const bar = document.getElementById('class-bar');
  if (!bar) return;
  const clientId = 'submit-' + Math.random().toString(36).slice(2);
  const text = (s) => String(s === undefined || s === null ? '' : s)
    .replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c]));
  const style = document.createElement('style');
  style.textContent = `
    .submit-panel { background: #f1faee; color: #1d3557; border-bottom: 2px solid #1d3557; padding: 6px 10px;
      font: 13px sans-serif; max-height: 75vh; overflow: auto; }
    .submit-editor { display: flex; border: 1px solid #999; height: 22em; background: white; }
    .submit-editor pre, .submit-editor textarea { margin: 0; font: 13px/1.35 monospace; padding: 4px; }
    .submit-editor pre { text-align: right; color: #888; background: #eee; overflow: hidden; min-width: 3em;
      user-select: none; }
    .submit-editor pre span.error-line { background: #e63946; color: white; display: block; cursor: help; }
    .submit-editor textarea { flex: 1; border: none; resize: none; white-space: pre; overflow: auto; }
    #submit-errors li { color: #b00020; cursor: pointer; font-family: monospace; }
    #submit-list { border-collapse: collapse; margin: 6px 0; }
    #submit-list td, #submit-list th { border: 1px solid #bbb; padding: 2px 6px; }
    #submit-list tr.running { background: #d8f3dc; }
    #submit-report img { max-width: 45%; margin: 2px; border: 1px solid #ccc; }
    #submit-report pre { white-space: pre-wrap; background: white; padding: 4px; }
    .submit-bad { color: #b00020; } .submit-good { color: #2a9d8f; }`;
  document.head.appendChild(style);

  const toggle = document.createElement('button');
  toggle.id = 'submit-toggle';
  toggle.textContent = 'My controller';
  bar.appendChild(toggle);
  const panel = document.createElement('div');
  panel.id = 'submit-panel';
  panel.className = 'submit-panel';
  panel.hidden = true;
  panel.innerHTML = `
    <div>Language <select id="submit-language"><option value="cpp">C++ (one file, include/sirupp/controller.h)</option>
      <option value="python">Python (one file, class Controller)</option></select>
      load a file <input type="file" id="submit-file" accept=".cpp,.cc,.cxx,.py">
      <button id="submit-send">Submit</button> <span id="submit-answer"></span></div>
    <div class="submit-editor"><pre id="submit-gutter">1</pre><textarea id="submit-source" spellcheck="false"
      placeholder="Your controller's source: paste it, type it, or load a file."></textarea></div>
    <ul id="submit-errors"></ul>
    <p><span id="submit-running" data-running="">Your rig runs the built-in PIC-SERVO law.</span>
      <button id="submit-builtin">Back to the built-in law</button></p>
    <p id="submit-real-arm"></p>
    <p id="submit-grading"></p>
    <table id="submit-list"><thead><tr><th>#</th><th>language</th><th>sent</th><th>state</th><th>score</th>
      <th>safety tasks</th><th></th></tr></thead><tbody></tbody></table>
    <div id="submit-report"></div>`;
  bar.insertAdjacentElement('afterend', panel);
  toggle.onclick = () => { panel.hidden = !panel.hidden; if (!panel.hidden) refresh(); };

  const $ = (id) => document.getElementById(id);
  const source = $('submit-source');
  const gutter = $('submit-gutter');
  let errorLines = new Map();  // line -> messages (of the shown source)

  function drawGutter() {
    const lines = source.value.split('\n').length;
    let html = '';
    for (let i = 1; i <= lines; ++i) {
      const messages = errorLines.get(i);
      html += messages ? `<span class="error-line" data-line="${i}" title="${text(messages.join('\n'))}">${i}</span>`
                       : `${i}\n`;
    }
    gutter.innerHTML = html;
    gutter.scrollTop = source.scrollTop;
  }
  source.addEventListener('input', () => { errorLines = new Map(); drawGutter(); });
  source.addEventListener('scroll', () => { gutter.scrollTop = source.scrollTop; });

  function selectLine(line) {
    const lines = source.value.split('\n');
    let start = 0;
    for (let i = 0; i < line - 1 && i < lines.length; ++i) start += lines[i].length + 1;
    source.focus();
    source.setSelectionRange(start, start + (lines[line - 1] || '').length);
    const height = source.scrollHeight / Math.max(1, lines.length);
    source.scrollTop = Math.max(0, (line - 5) * height);
  }

  function showErrors(sub) {
    errorLines = new Map();
    const list = $('submit-errors');
    list.innerHTML = '';
    for (const e of sub.errors || []) {
      const item = document.createElement('li');
      item.textContent = `${e.file}:${e.line}:${e.column}: error: ${e.message}`;
      item.dataset.line = e.line;
      if (/^controller\.(cpp|py)$/.test(e.file)) {
        if (!errorLines.has(e.line)) errorLines.set(e.line, []);
        errorLines.get(e.line).push(e.message);
        item.onclick = () => selectLine(e.line);
      }
      list.appendChild(item);
    }
    if (sub.state === 'build failed' && !(sub.errors || []).length) {
      const item = document.createElement('li');
      item.textContent = sub.problem;
      list.appendChild(item);
    }
    drawGutter();
  }

  $('submit-file').onchange = async (e) => {
    const file = e.target.files[0];
    if (!file) return;
    source.value = await file.text();
    if (/\.py$/.test(file.name)) $('submit-language').value = 'python';
    else $('submit-language').value = 'cpp';
    errorLines = new Map();
    drawGutter();
  };

  async function post(path, body) {
    const r = await fetch(path, {method: 'POST', body: JSON.stringify(body),
                                 headers: {'X-Sirupp-Client': clientId, 'Content-Type': 'application/json'}});
    let answer;
    try { answer = await r.json(); } catch (e) { answer = {error: `HTTP ${r.status}`}; }
    return {ok: r.ok, answer};
  }

  $('submit-send').onclick = async () => {
    const answer = $('submit-answer');
    answer.textContent = $('submit-language').value === 'cpp' ? 'building...' : 'sending...';
    answer.className = '';
    $('submit-send').disabled = true;
    try {
      const r = await post('class/submissions', {language: $('submit-language').value, source: source.value});
      if (!r.ok) {
        answer.textContent = r.answer.error;
        answer.className = 'submit-bad';
        return;
      }
      const sub = r.answer;
      answer.dataset.id = sub.id;
      answer.dataset.state = sub.state;
      if (sub.state === 'build failed') {
        answer.textContent = `submission ${sub.id} does not build: ${(sub.errors || []).length} error(s), marked at their lines`;
        answer.className = 'submit-bad';
      } else {
        answer.textContent = `submission ${sub.id}: ${sub.state}` +
          (sub.build_seconds ? ` (built in ${sub.build_seconds.toFixed(1)} s)` : '');
        answer.className = 'submit-good';
      }
      showErrors(sub);
      refresh();
    } finally {
      $('submit-send').disabled = false;
    }
  };

  async function run(id) {
    $('submit-running').textContent = id === null ? 'going back to the built-in law...' : `starting submission ${id} on your rig...`;
    const r = await post('class/run', {id});
    if (!r.ok) $('submit-running').textContent = r.answer.error;
    else if (r.answer.rig_problem) $('submit-running').textContent = 'your rig did not start: ' + r.answer.rig_problem;
    refresh();
  }
  $('submit-builtin').onclick = () => run(null);

  async function showReport(id) {
    const box = $('submit-report');
    const r = await fetch(`class/submissions/${id}/report.md`);
    if (!r.ok) { box.textContent = (await r.json()).error; return; }
    const md = await r.text();
    const plots = [...md.matchAll(/!\[[^\]]*\]\((plots\/[A-Za-z0-9_.-]+\.png)\)/g)].map((m) => m[1]);
    box.innerHTML = `<h3 id="submit-report-title" data-id="${id}">Report of submission ${id}</h3>` +
      plots.map((p) => `<img alt="${text(p)}" src="class/submissions/${id}/${text(p)}">`).join('') +
      `<pre>${text(md)}</pre>`;
  }
  async function showSource(id) {
    const r = await fetch(`class/submissions/${id}/source`);
    if (!r.ok) return;
    source.value = await r.text();
    const sub = shown.find((s) => s.id === id);
    if (sub) { $('submit-language').value = sub.language; showErrors(sub); } else drawGutter();
  }

  let shown = [];
  function row(sub, running) {
    const g = sub.grade;
    const score = g ? `${g.score.toFixed(1)} (${g.passed}/${g.tasks_total})` : '-';
    const safety = g ? (g.safety_passed ? '<span class="submit-good">passed</span>'
                                       : `<span class="submit-bad">failed: ${text(g.safety_failed.join('; '))}</span>`) : '-';
    const state = sub.state + (sub.problem ? ': ' + sub.problem : '') + (g && g.problem ? ': ' + g.problem : '');
    const runnable = !['build failed', 'building', 'new'].includes(sub.state);
    return `<tr data-id="${sub.id}" data-state="${text(sub.state)}" class="${sub.id === running ? 'running' : ''}">
      <td>${sub.id}</td><td>${text(sub.language)}</td><td>${text(sub.submitted_at)}</td>
      <td class="submit-state">${text(state)}</td><td class="submit-score">${score}</td><td>${safety}</td>
      <td>${runnable && sub.id !== running ? `<button class="submit-run" data-id="${sub.id}">run on my rig</button>` : ''}
        ${sub.id === running ? '<b>on your rig</b>' : ''}
        <button class="submit-show" data-id="${sub.id}">source</button>
        ${sub.report_url ? `<button class="submit-report" data-id="${sub.id}">report</button>` : ''}</td></tr>`;
  }

  async function refresh() {
    let list;
    try {
      const r = await fetch('class/submissions');
      if (!r.ok) return;
      list = await r.json();
    } catch (e) { return; }
    shown = list.submissions;
    const running = list.running;
    const label = $('submit-running');
    label.dataset.running = running === null ? '' : String(running);
    label.textContent = running === null ? 'Your rig runs the built-in PIC-SERVO law.'
      : `Your rig runs your submission ${running} in place of the PIC-SERVO law (in the sandbox).`;
    $('submit-builtin').hidden = running === null;
    $('submit-real-arm').textContent = list.real_arm ? 'Real arm: ' + list.real_arm
      : 'Real arm: allowed with what your rig runs.';
    $('submit-grading').textContent = list.grading
      ? `Graded with the class's suite ${list.grading.suite} (${list.grading.tasks} tasks; safety tasks: ` +
        `${list.grading.safety_tasks.join(', ')}), in the background, one submission at a time` +
        (list.queue ? ` (${list.queue} waiting)` : '') + '. The latest graded submission counts.'
      : 'This class has no grading suite: submissions run on your rig but are not graded.';
    $('submit-list').querySelector('tbody').innerHTML = shown.map((s) => row(s, running)).join('');
    for (const b of document.querySelectorAll('#submit-list button.submit-run')) b.onclick = () => run(Number(b.dataset.id));
    for (const b of document.querySelectorAll('#submit-list button.submit-show')) b.onclick = () => showSource(Number(b.dataset.id));
    for (const b of document.querySelectorAll('#submit-list button.submit-report')) b.onclick = () => showReport(Number(b.dataset.id));
  }
  drawGutter();
  refresh();
  setInterval(() => { if (!panel.hidden) refresh(); }, 3000);
})();
