// The teacher's page, "Controllers": each student's counted submission (the latest built or
// graded), its score, the safety tasks and the class table as CSV and Markdown (the format of
// `sirupp grade --batch`). From /teacher/api/grades every 5 s (class/submissions.hpp).
'use strict';
(() => {
  const box = document.getElementById('grades');
  if (!box) return;
  const text = (s) => String(s === undefined || s === null ? '' : s)
    .replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c]));
  function row(r) {
    const g = r.grade;
    const score = g ? `${g.score.toFixed(1)} (${g.passed}/${g.tasks_total})` : '-';
    const safety = g ? (g.safety_passed ? 'passed' : 'failed: ' + g.safety_failed.join('; ')) : '-';
    const counted = r.counted === undefined ? '-' : `#${r.counted} ${r.language} ${r.submitted_at}`;
    const latest = r.latest && r.latest.id !== r.counted ? ` (latest #${r.latest.id}: ${r.latest.state})` : '';
    const problem = r.problem || (g && g.problem) || (g ? g.failed_tasks.join(' ') : '');
    return `<tr id="grade-${text(r.student)}"><td>${text(r.student)}</td><td>${text(counted + latest)}</td>
      <td>${text(r.state || 'no submission')}</td><td class="grade-score">${text(score)}</td><td>${text(safety)}</td>
      <td>${text(problem)}</td><td>${r.running === null ? 'built-in law' : '#' + r.running}</td></tr>`;
  }
  async function refresh() {
    try {
      const r = await fetch('api/grades');
      if (!r.ok) return;
      const g = await r.json();
      box.innerHTML = g.suite === null ? '<p>No grading suite in the class file (grading: suite:).</p>'
        : `<p>Suite ${text(g.suite)}; safety tasks (for the real arm): ${text(g.safety_tasks.join(', '))}.
             Class table: <a id="class-csv" href="api/class.csv" download="class.csv">class.csv</a>
             <a id="class-md" href="api/class.md" download="class.md">class.md</a></p>
           <table class="rigs"><thead><tr><th>student</th><th>counted submission</th><th>state</th><th>score</th>
             <th>safety tasks</th><th>failed tasks / problem</th><th>rig runs</th></tr></thead>
           <tbody>${g.rows.map(row).join('')}</tbody></table>`;
    } catch (e) { /* the next try */ }
  }
  refresh();
  setInterval(refresh, 5000);
})();
