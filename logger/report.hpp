#pragma once
// `sirupp report`: the Table II layout for every movement set and joint, as Markdown and CSV, and
// PNG plots (docs/logging.md, "Report"). Reads our data files and LCM log files alike.

#include <optional>
#include <string>
#include <vector>

#include "logger/analysis.hpp"
#include "logger/data_file.hpp"
#include "logger/log_import.hpp"

namespace sirupp::logger {

// Published numbers to read a run against (e.g. the SIRUPP paper's Table II): per movement set
// (the table's label, "set1") and joint, the mean virtual-vs-real error in the transient and the
// steady state. Shown beside the virtual-vs-real rows of Table II.
struct ReferenceRow {
  std::string set;
  int joint = 0;  // 1-based
  double mean_transient = 0;
  double mean_steady = 0;
};
struct ReferenceColumn {
  std::string title;  // e.g. "paper"
  std::string note;   // one paragraph under the table: where the numbers come from
  std::vector<ReferenceRow> rows;
};

struct ReportOptions {
  AnalysisOptions analysis;
  ImportOptions import;  // for LCM log files
  std::string out_dir = "report";
  bool plots = true;
  std::optional<ReferenceColumn> reference;  // unset: no reference columns
};

struct ReportOutput {
  std::string markdown;            // also written as OUT/report.md
  std::vector<std::string> files;  // everything written, report.md first
  size_t moves = 0;                // joint moves analysed
};

// Reads each input (a data file, or an LCM log: told apart by their first bytes; a directory
// stands for its *.csv and *.lcm files, a restarted logger's continuation files right after the
// file they continue). Throws
// core::ConfigError "FILE:LINE: problem" (or "FILE: byte N (event K): problem") for bad input,
// before anything is written.
std::vector<RunTable> ReadInputs(const std::vector<std::string>& paths,
                                 const ImportOptions& import);

// Analyses, writes OUT/report.md, OUT/report_errors.csv, OUT/report_response.csv and the plots.
// Throws core::ConfigError if no input holds a move to report, std::runtime_error if a file cannot
// be written.
ReportOutput WriteReport(const std::vector<RunTable>& tables, const ReportOptions& options);

}  // namespace sirupp::logger
