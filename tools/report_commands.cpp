#include "tools/report_commands.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <sstream>

#include "core/channels.hpp"
#include "core/errors.hpp"
#include "lab/experiment.hpp"
#include "logger/report.hpp"
#include "runtime/args.hpp"

namespace sirupp::tools {

const char* const kReportAbout =
    "The paper's Table II for every movement set and joint in the files: mean error in the\n"
    "transient and in the steady state, RMS and maximum error, for set-point vs virtual,\n"
    "set-point vs real and virtual vs real; start delay, settling time and overshoot per stream.\n"
    "FILE: data files of sirupp-logger (CSV) or LCM logs of lcm-logger, told apart by content;\n"
    "a directory stands for its *.csv and *.lcm files (a restarted logger's continuation files\n"
    "right after the file they continue).\n"
    "Prints Markdown and writes DIR/report.md, report_errors.csv, report_response.csv and PNG\n"
    "plots (angle and error against time per move and joint); DIR default report.\n"
    "--compare FILE|DIR...: another run of the same sets (e.g. the demo before `sirupp identify`,\n"
    "FILE the run after): its virtual-vs-real means beside ours in Table II, and a section\n"
    "comparing the two per set and joint (the last move of each), with the means over the rows\n"
    "both have and the change in %.\n"
    "Definitions: docs/logging.md. Exit 0, or 2 naming FILE:LINE for bad input.\n";

logger::ReferenceColumn PaperReference() {
  logger::ReferenceColumn column;
  column.title = "paper";
  column.note =
      "Paper: the SIRUPP paper's Table II (Nugraha 2009), virtual vs real on the real PUMA 260, "
      "mean error in degrees. Its rows for sets V and VI name the set's first and second joint, "
      "here joints 1 and 3 (V) and 2 and 3 (VI) as config/plans moves them "
      "(docs/emulator-fit.md). Its joint 1 started 0.35-0.4 s after the command.";
  for (const lab::PaperRow& row : lab::PaperTable()) {
    column.rows.push_back(
        {"set" + std::to_string(row.set), row.joint, row.transient_deg, row.steady_deg});
  }
  return column;
}

namespace {

// --settle-window, --start-threshold, --band-percent, --min-travel, --last-move, --joints (each
// value checked by its declaration).
logger::AnalysisOptions AnalysisOptionsFrom(const runtime::Args& args) {
  logger::AnalysisOptions a;
  a.settle_window_s = args.Number("settle-window", a.settle_window_s);
  a.start_threshold = args.Number("start-threshold", a.start_threshold);
  a.settle_band_fraction = args.Number("band-percent", a.settle_band_fraction * 100) / 100;
  a.min_travel = args.Number("min-travel", a.min_travel);
  a.last_move_only = args.Switch("last-move");
  if (args.Has("joints")) {
    for (double joint : args.Numbers("joints", -1)) a.joints.push_back(static_cast<int>(joint));
  }
  return a;
}

// How LCM logs are read: --prefix, --rate, --max-age, --whole-log.
logger::ImportOptions ImportOptionsFrom(const runtime::Args& args) {
  logger::ImportOptions import;
  try {
    import.channels = core::Channels::WithPrefix(args.Has("prefix") ? args.String("prefix") : "");
  } catch (const std::invalid_argument& error) {
    throw core::UsageError(std::string("report: --prefix: ") + error.what());
  }
  if (args.Has("rate")) {  // (0, 1e6] by its declaration
    import.aligner.period_us = std::max<int64_t>(1, std::llround(1e6 / args.Number("rate", 0)));
  }
  if (args.Has("max-age"))
    import.aligner.max_age_us = std::llround(args.Number("max-age", 0) * 1e6);
  import.split_per_plan = !args.Switch("whole-log");
  return import;
}

// One run's virtual-vs-real means per set (the table's label) and joint: the last move of each.
std::vector<logger::ReferenceRow> VirtualVsReal(const std::vector<logger::RunTable>& tables,
                                                const logger::AnalysisOptions& options) {
  std::vector<logger::ReferenceRow> rows;
  for (const logger::RunTable& table : tables) {
    for (const logger::MoveResult& move : logger::Analyze(table, options).moves) {
      const logger::PairMetrics& m = move.pairs[static_cast<size_t>(logger::Pair::kVirtReal)];
      const logger::ReferenceRow row{table.label, move.joint, m.mean_transient, m.mean_steady};
      auto same = [&](const logger::ReferenceRow& r) {
        return r.set == row.set && r.joint == row.joint;
      };
      const auto at = std::find_if(rows.begin(), rows.end(), same);
      if (at == rows.end()) {
        rows.push_back(row);
      } else {
        *at = row;
      }
    }
  }
  return rows;
}

std::string Cell(double v) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << v;
  return s.str();
}

}  // namespace

std::string CompareSection(const std::vector<logger::ReferenceRow>& ours,
                           const std::vector<logger::ReferenceRow>& other,
                           const std::string& ours_name, const std::string& other_name) {
  std::string md = "\n## Comparison: virtual vs real, " + other_name + " (A) and " + ours_name +
                   " (B)\n\n| Set | Joint | Transient A | Transient B | Steady A | Steady B |\n"
                   "|---|---|---:|---:|---:|---:|\n";
  double sum_a = 0, sum_b = 0;
  int n = 0;
  for (const logger::ReferenceRow& b : ours) {
    const logger::ReferenceRow* a = nullptr;
    for (const logger::ReferenceRow& r : other) {
      if (r.set == b.set && r.joint == b.joint) a = &r;
    }
    if (a == nullptr) {
      md += "| " + b.set + " | " + std::to_string(b.joint) + " | - | " + Cell(b.mean_transient) +
            " | - | " + Cell(b.mean_steady) + " |\n";
      continue;
    }
    md += "| " + b.set + " | " + std::to_string(b.joint) + " | " + Cell(a->mean_transient) + " | " +
          Cell(b.mean_transient) + " | " + Cell(a->mean_steady) + " | " + Cell(b.mean_steady) +
          " |\n";
    for (const auto& [x, y] : {std::pair{a->mean_transient, b.mean_transient},
                               std::pair{a->mean_steady, b.mean_steady}}) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      sum_a += x;
      sum_b += y;
      ++n;
    }
  }
  for (const logger::ReferenceRow& a : other) {
    const bool shared = std::any_of(ours.begin(), ours.end(), [&](const logger::ReferenceRow& b) {
      return b.set == a.set && b.joint == a.joint;
    });
    if (!shared) {
      md += "| " + a.set + " | " + std::to_string(a.joint) + " | " + Cell(a.mean_transient) +
            " | - | " + Cell(a.mean_steady) + " | - |\n";
    }
  }
  if (n == 0) return md + "\nNo set and joint is in both runs: nothing to compare.\n";
  const double mean_a = sum_a / n, mean_b = sum_b / n;
  md += "\nMean over the " + std::to_string(n) + " transient and steady means both runs have: A " +
        Cell(mean_a) + " deg, B " + Cell(mean_b) + " deg";
  if (mean_a > 0) {
    std::ostringstream change;
    change << std::showpos << std::fixed << std::setprecision(1)
           << 100 * (mean_b - mean_a) / mean_a;
    md += ", change " + change.str() + " %";
  }
  return md + ".\n";
}

namespace {

// --compare: the other run's virtual-vs-real means become the report's extra columns
// (options.reference); returns the comparison section that follows the report.
std::string Compare(const std::vector<std::string>& others, const std::vector<std::string>& files,
                    const std::vector<logger::RunTable>& tables, logger::ReportOptions& options) {
  const std::vector<logger::RunTable> other = logger::ReadInputs(others, options.import);
  const std::vector<logger::ReferenceRow> rows = VirtualVsReal(other, options.analysis);
  std::string names;
  for (const std::string& f : others) names += (names.empty() ? "" : " ") + f;
  logger::ReferenceColumn column;
  column.title = "compared";
  column.note = "Compared: the virtual-vs-real means of " + names +
                " (the last move of each set and joint), beside ours.";
  column.rows = rows;
  options.reference = column;
  std::string ours;
  for (const std::string& f : files) ours += (ours.empty() ? "" : " ") + f;
  return CompareSection(VirtualVsReal(tables, options.analysis), rows, ours, names);
}

}  // namespace

int RunReport(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const runtime::Args args(
      argv, "report",
      {runtime::Flag("files", "data files, folders or LCM logs").Positional("FILE|DIR", -1),
       runtime::Flag("out", "folder for report.md, CSVs and plots (report)").Takes("DIR"),
       runtime::Flag("no-plots", "no PNG plots").Switch(),
       runtime::Flag("joints", "only these joints (1-based)")
           .Takes("N", -1)
           .Integer(1, runtime::Flag::kMany),
       runtime::Flag("last-move",
                     "only the last move of each movement set (the one Table II measures)")
           .Switch(),
       runtime::Flag("settle-window", "the transient ends S after move-done (0.25)")
           .Takes("S")
           .AtLeast(0),
       runtime::Flag("start-threshold", "a stream has started once it moved this far (0.5)")
           .Takes("DEG")
           .AtLeast(0),
       runtime::Flag("band-percent", "settling band, percent of the travel (2)")
           .Takes("P")
           .AtLeast(0),
       runtime::Flag("min-travel", "joints whose set-point travels less are not reported (0.5)")
           .Takes("DEG")
           .AtLeast(0),
       runtime::Flag("prefix", "LCM logs: channel prefix of the rig").Takes("PREFIX"),
       runtime::Flag("rate", "LCM logs: sample clock (default the 0.512 ms servo tick)")
           .Takes("HZ")
           .Above(0, 1e6),
       runtime::Flag("max-age", "LCM logs: a stream older than S leaves its cell empty (0.025)")
           .Takes("S")
           .AtLeast(0),
       runtime::Flag("whole-log", "LCM logs: one set, not one per plan run").Switch(),
       runtime::Flag("reference",
                     "the SIRUPP paper's own Table II (virtual vs real, real PUMA 260) as two "
                     "more columns beside our virtual-vs-real rows, per set and joint")
           .Takes("WHICH")
           .OneOf({"paper"}),
       runtime::Flag("compare",
                     "another run's data files or folders: its virtual-vs-real means beside "
                     "ours, and a comparison section (the change in %)")
           .Takes("FILE|DIR", -1)},
      kReportAbout);
  const std::vector<std::string>& files = args.Values("files", -1);
  if (args.Has("compare") && args.Has("reference")) {
    throw core::UsageError("report: give --compare or --reference, not both (one column)");
  }

  logger::ReportOptions options;
  if (args.Has("out")) options.out_dir = args.String("out");
  options.plots = !args.Switch("no-plots");
  if (args.Has("reference")) options.reference = PaperReference();  // "paper": declared
  options.analysis = AnalysisOptionsFrom(args);
  options.import = ImportOptionsFrom(args);

  const std::vector<logger::RunTable> tables = logger::ReadInputs(files, options.import);
  for (const logger::RunTable& table : tables) {
    for (const std::string& note : table.notes) err << "sirupp report: note: " << note << "\n";
  }
  const std::string compared =
      args.Has("compare") ? Compare(args.Values("compare", -1), files, tables, options) : "";
  const logger::ReportOutput output = logger::WriteReport(tables, options);
  out << output.markdown << compared;
  if (!compared.empty()) {
    std::ofstream report(output.files.front(), std::ios::app);
    report << compared;
    if (!report) throw std::runtime_error("report: cannot write " + output.files.front());
  }
  err << "sirupp report: " << output.moves << " joint moves; wrote";
  for (const std::string& file : output.files) err << " " << file;
  err << "\n";
  return 0;
}

}  // namespace sirupp::tools
