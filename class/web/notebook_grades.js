// The teacher's page, "Notebook assignments": each student's counted submission of each notebook
// assignment (the latest graded), its score and each hidden test's result, and the link to the
// gradebook's CSV (controller grade and every assignment, one row per student). From
// /teacher/api/notebook-grades every 5 s (class/notebook_submissions.hpp).
'use strict';
(() => {
  const box = document.getElementById('notebook-grades');
  if (!box) return;
  const text = (s) => String(s === undefined || s === null ? '' : s)
    .replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c]));
  function cell(c) {
    if (!c || c.counted === undefined) {
      return `<td>${c && c.latest ? text('#' + c.latest.id + ' ' + c.latest.state) : 'no submission'}</td>`;
    }
    const score = c.score === undefined ? c.state : `${c.score} / ${c.max_score}`;
    const tests = (c.tests || []).map((t) =>
      `<li class="${t.passed ? 'submit-good' : 'submit-bad'}">${text(t.name)} ${t.points}/${t.max_points}` +
      `${t.passed ? '' : ': ' + text(t.message)}</li>`).join('');
    const latest = c.latest && c.latest.id !== c.counted ? ` (latest #${c.latest.id}: ${text(c.latest.state)})` : '';
    return `<td class="notebook-score"><b>${text(score)}</b> #${c.counted} ${text(c.submitted_at)}${latest}
      ${c.problem ? '<br>' + text(c.problem) : ''}<ul>${tests}</ul></td>`;
  }
  async function refresh() {
    try {
      const r = await fetch('api/notebook-grades');
      if (!r.ok) return;
      const g = await r.json();
      const head = g.assignments.map((a) => `<th>${text(a.name)} (${a.max_points} points)</th>`).join('');
      box.innerHTML = (g.assignments.length === 0
        ? '<p>No notebook assignments in the class file (notebooks: assignments:).</p>'
        : `<table class="rigs"><thead><tr><th>student</th>${head}</tr></thead><tbody>` +
          g.rows.map((row) => `<tr id="notebook-${text(row.student)}"><td>${text(row.student)}</td>` +
            g.assignments.map((a) => cell(row.assignments[a.name])).join('') + '</tr>').join('') +
          '</tbody></table>') +
        `<p>Every grade for a gradebook (Canvas, Moodle): <a id="grades-csv" href="grades.csv"
           download="grades.csv">grades.csv</a></p>`;
    } catch (e) { /* the next try */ }
  }
  refresh();
  setInterval(refresh, 5000);
})();
