// "My assignments" on a student's page (loaded by class/web/student.js): each notebook assignment
// of the class, its hidden tests' names and points, a notebook submitted (a file from this
// computer, or the copy in the notebooks folder the notebook server keeps), and every
// submission's scores, failing tests' messages and output. API: class/assignments
// (class/notebook_submissions.hpp). docs/notebook-assignments.md.
'use strict';
(() => {
  const bar = document.getElementById('class-bar');
  if (!bar) return;
  const clientId = 'assignments-' + Math.random().toString(36).slice(2);
  const text = (s) => String(s === undefined || s === null ? '' : s)
    .replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c]));
  const toggle = document.createElement('button');
  toggle.id = 'assignments-toggle';
  toggle.textContent = 'My assignments';
  const panel = document.createElement('div');
  panel.id = 'assignments-panel';
  panel.className = 'submit-panel';
  panel.hidden = true;
  let timer = null;

  function results(s) {
    if (!s) return '<p>Nothing submitted yet.</p>';
    const r = s.result;
    let html = `<p>Submission #${s.id} (${text(s.source)}, ${text(s.submitted_at)}): <b>${text(s.state)}</b>`;
    if (r) html += ` &mdash; <b class="assignment-score">${r.score} of ${r.max_score} points</b>`;
    html += '</p>';
    if (s.problem) html += `<p class="submit-bad">${text(s.problem)}</p>`;
    if (r) {
      html += '<table class="assignment-tests"><thead><tr><th>hidden test</th><th>points</th><th>result</th></tr></thead><tbody>' +
        r.tests.map((t) => `<tr><td>${text(t.name)}</td><td>${t.points} / ${t.max_points}</td>` +
          `<td class="${t.passed ? 'submit-good' : 'submit-bad'}">${t.passed ? 'passed' : text(t.message)}</td></tr>`).join('') +
        '</tbody></table>';
      if (r.cell_errors.length) {
        html += '<ul>' + r.cell_errors.map((e) => `<li class="submit-bad">code cell ${e.cell}: ${text(e.error)}</li>`).join('') + '</ul>';
      }
      html += `<details><summary>your notebook's output</summary><pre>${text(r.output)}</pre></details>`;
    }
    return html;
  }

  function show(list) {
    panel.innerHTML = list.assignments.length === 0 ? '<p>This class has no notebook assignments.</p>' :
      list.assignments.map((a) => `<section class="assignment" data-name="${text(a.name)}">
        <h3>${text(a.name)} (${text(a.notebook)}, ${a.max_points} points)</h3>
        <p>Hidden tests: ${a.tests.map((t) => text(t.name) + ' (' + t.points + ')').join(', ')}.
          Your notebook runs from the top in a fresh kernel, then these tests (at most ${a.timeout_s} s).</p>
        <p>Submit <input type="file" accept=".ipynb" class="assignment-file">
          <button class="assignment-upload">this file</button>
          <button class="assignment-folder" ${a.in_notebooks_folder ? '' : 'disabled'}>my notebooks folder's ${text(a.notebook)}</button>
          <span class="assignment-answer"></span></p>
        ${results(a.latest)}
        <p>${a.submissions.map((s) => `#${s.id} ${text(s.state)}${s.result ? ' ' + s.result.score + '/' + s.result.max_score : ''}`).join(' &middot; ')}</p>
      </section>`).join('');
    for (const section of panel.querySelectorAll('section.assignment')) {
      const name = section.dataset.name;
      const answer = section.querySelector('.assignment-answer');
      const send = async (path, body) => {
        answer.textContent = 'sending...';
        const r = await fetch(path, {method: 'POST', body,
          headers: {'X-Sirupp-Client': clientId, 'Content-Type': 'application/x-ipynb+json'}});
        const reply = await r.json().catch(() => ({}));
        answer.textContent = r.ok ? `submission #${reply.id} queued` : (reply.error || r.statusText);
        refresh();
      };
      section.querySelector('.assignment-upload').onclick = () => {
        const file = section.querySelector('.assignment-file').files[0];
        if (!file) { answer.textContent = 'choose a .ipynb file first'; return; }
        file.text().then((body) => send('class/assignments/' + encodeURIComponent(name), body));
      };
      section.querySelector('.assignment-folder').onclick =
        () => send('class/assignments/' + encodeURIComponent(name) + '/from-notebooks', '');
    }
  }

  async function refresh() {
    try {
      const r = await fetch('class/assignments');
      if (r.ok) show(await r.json());
    } catch (e) { /* the bar says the server is unreachable */ }
  }
  toggle.onclick = () => {
    panel.hidden = !panel.hidden;
    clearInterval(timer);
    if (!panel.hidden) { refresh(); timer = setInterval(refresh, 3000); }
  };
  // The button only in a class with notebook assignments.
  fetch('class/assignments').then((r) => (r.ok ? r.json() : null)).then((list) => {
    if (!list || list.assignments.length === 0) return;
    bar.appendChild(toggle);
    bar.insertAdjacentElement('afterend', panel);
  }).catch(() => {});
})();
