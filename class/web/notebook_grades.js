// The teacher's page, "Notebook assignments": each student's counted submission of each notebook
// assignment (the latest graded), its score, each hidden test's result and its output, and the link to the
// gradebook's CSV (controller grade and every assignment, one row per student). From
// /teacher/api/notebook-grades every 5 s (class/notebook_submissions.hpp).
'use strict';
(() => {
  const box = document.getElementById('notebook-grades');
  if (!box) return;
  const text = (s) => String(s === undefined || s === null ? '' : s)
    .replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c]));
  // The output of a submission, fetched when its <details> is opened (the teacher's cookie opens
  // every student's routes read-only).
  box.addEventListener('toggle', async (event) => {
    const d = event.target;
    if (!d.open || !d.dataset.path || d.dataset.loaded) return;
    d.dataset.loaded = '1';
    const r = await fetch(d.dataset.path);
    const s = r.ok ? await r.json() : null;
    d.querySelector('pre').textContent = s && s.result ? s.result.output : 'no output';
  }, true);
  function cell(c, student, assignment) {
    if (!c || c.counted === undefined) {
      return `<td>${c && c.latest ? text('#' + c.latest.id + ' ' + c.latest.state) : 'no submission'}</td>`;
    }
    const score = c.score === undefined ? c.state : `${c.score} / ${c.max_score}`;
    const tests = (c.tests || []).map((t) =>
      `<li class="${t.passed ? 'submit-good' : 'submit-bad'}">${text(t.name)} ${t.points}/${t.max_points}` +
      `${t.passed ? '' : ': ' + text(t.message)}</li>`).join('');
    const latest = c.latest && c.latest.id !== c.counted ? ` (latest #${c.latest.id}: ${text(c.latest.state)})` : '';
    return `<td class="notebook-score"><b>${text(score)}</b> #${c.counted} ${text(c.submitted_at)}${latest}
      ${c.problem ? '<br>' + text(c.problem) : ''}<ul>${tests}</ul>
      <details data-path="/s/${encodeURIComponent(student)}/class/assignments/${encodeURIComponent(assignment)}/${c.counted}">
        <summary>output</summary><pre></pre></details></td>`;
  }
  let shown = '';
  async function refresh() {
    try {
      const r = await fetch('api/notebook-grades');
      if (!r.ok) return;
      const g = await r.json();
      if (JSON.stringify(g) === shown) return;  // unchanged: an opened output stays open
      shown = JSON.stringify(g);
      const head = g.assignments.map((a) => `<th>${text(a.name)} (${a.max_points} points)</th>`).join('');
      box.innerHTML = (g.assignments.length === 0
        ? '<p>No notebook assignments in the class file (notebooks: assignments:).</p>'
        : `<table class="rigs"><thead><tr><th>student</th>${head}</tr></thead><tbody>` +
          g.rows.map((row) => `<tr id="notebook-${text(row.student)}"><td>${text(row.student)}</td>` +
            g.assignments.map((a) => cell(row.assignments[a.name], row.student, a.name)).join('') + '</tr>').join('') +
          '</tbody></table>') +
        `<p>Every grade for a gradebook (Canvas, Moodle): <a id="grades-csv" href="grades.csv"
           download="grades.csv">grades.csv</a></p>`;
    } catch (e) { /* the next try */ }
  }
  refresh();
  setInterval(refresh, 5000);
})();
