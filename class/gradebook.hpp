#pragma once
// The class's grades as one CSV a gradebook imports (docs/notebook-assignments.md, "Grades as
// CSV"): one header row, then one row per student.
//
//   Student,ID,SIS User ID,SIS Login ID,Section,controller,fk3
//   alice,,,alice,,83.3,6
//
// The first five columns are those of Canvas's gradebook export, which its import takes back
// (Canvas matches a row by ID, SIS User ID or SIS Login ID; a column after them that names no
// assignment becomes a new one): the class's name of the student goes in Student and SIS Login
// ID, the others stay empty. Moodle's CSV import maps any column to its user field ("Identify
// user by": SIS Login ID to username) and any other column to a grade item. A grade is a plain
// number with a '.' and at most two decimals (no unit, no %); a cell is empty when there is nothing
// graded. Fields with a comma, a quote or a line break are quoted (RFC 4180), and so is one
// starting with = + - @ (spreadsheets would read it as a formula).

#include <optional>
#include <string>
#include <vector>

namespace sirupp::classroom {

struct GradebookColumn {
  std::string name;  // the header: "controller", an assignment's name
  double max_points = 0;
};

struct GradebookRow {
  std::string student;
  std::vector<std::optional<double>> grades;  // one per column; none = not graded
};

// The CSV, lines ended by CRLF as RFC 4180 has them. Throws std::invalid_argument when a row has
// not one grade per column.
std::string GradebookCsv(const std::vector<GradebookColumn>& columns,
                         const std::vector<GradebookRow>& rows);

// One field as written: quoted when it must be (see above).
std::string CsvField(const std::string& text);

}  // namespace sirupp::classroom
