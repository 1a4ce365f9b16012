#include "class/gradebook.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace sirupp::classroom {
namespace {

// At most two decimals, no trailing zeros: 83.33, 6, 0.5.
std::string GradeText(double grade) {
  if (!std::isfinite(grade)) return "";
  char text[48];
  std::snprintf(text, sizeof text, "%.2f", grade);
  std::string out = text;
  while (out.back() == '0') out.pop_back();
  if (out.back() == '.') out.pop_back();
  return out == "-0" ? "0" : out;
}

}  // namespace

std::string CsvField(const std::string& text) {
  const bool formula =
      !text.empty() && (text[0] == '=' || text[0] == '+' || text[0] == '-' || text[0] == '@');
  if (!formula && text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  // A formula's leading character is kept, behind a quote mark a spreadsheet shows as text.
  if (formula) quoted += "'";
  for (const char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

std::string GradebookCsv(const std::vector<GradebookColumn>& columns,
                         const std::vector<GradebookRow>& rows) {
  std::string csv = "Student,ID,SIS User ID,SIS Login ID,Section";
  for (const GradebookColumn& column : columns) csv += "," + CsvField(column.name);
  csv += "\r\n";
  for (const GradebookRow& row : rows) {
    if (row.grades.size() != columns.size()) {
      throw std::invalid_argument("gradebook: " + row.student + " has " +
                                  std::to_string(row.grades.size()) + " grades for " +
                                  std::to_string(columns.size()) + " columns");
    }
    const std::string name = CsvField(row.student);
    csv += name + ",,," + name + ",";
    for (const std::optional<double>& grade : row.grades) {
      csv += ",";
      if (grade) csv += GradeText(*grade);
    }
    csv += "\r\n";
  }
  return csv;
}

}  // namespace sirupp::classroom
