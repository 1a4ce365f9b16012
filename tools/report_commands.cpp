#include "tools/report_commands.hpp"

#include <cmath>
#include <ostream>

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
           .OneOf({"paper"})},
      kReportAbout);
  const std::vector<std::string>& files = args.Values("files", -1);

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
  const logger::ReportOutput output = logger::WriteReport(tables, options);
  out << output.markdown;
  err << "sirupp report: " << output.moves << " joint moves; wrote";
  for (const std::string& file : output.files) err << " " << file;
  err << "\n";
  return 0;
}

}  // namespace sirupp::tools
