#include "logger/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>

#include "core/errors.hpp"
#include "logger/lcm_log.hpp"
#include "logger/plot.hpp"

namespace sirupp::logger {

namespace {

const PlotColor kStreamColors[kNumStreams] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44}};
const PlotColor kPairColors[kNumPairs] = {{255, 127, 14}, {44, 160, 44}, {214, 39, 40}};
constexpr double kPlotGapS = 0.05;  // samples further apart are not joined by a line

// Appends a point, first breaking the line (a NaN) if the previous point is over kPlotGapS back.
void AddPoint(PlotSeries& series, double x, double y) {
  if (!series.x.empty() && x - series.x.back() > kPlotGapS) {
    series.x.push_back(std::numeric_limits<double>::quiet_NaN());
    series.y.push_back(std::numeric_limits<double>::quiet_NaN());
  }
  series.x.push_back(x);
  series.y.push_back(y);
}

std::string Fixed(double value, int decimals) {
  if (!std::isfinite(value)) return "";
  if (std::abs(value) < 0.5 * std::pow(10.0, -decimals)) value = 0;  // never "-0.0"
  char text[48];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

// For Markdown cells: "-" where there is no value.
std::string Cell(double value, int decimals) {
  const std::string text = Fixed(value, decimals);
  return text.empty() ? "-" : text;
}

std::string CsvText(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::runtime_error(path + ": cannot write");
}

std::string JointName(const MoveResult& move) {
  const JointInfo& info = move.table->joints[static_cast<size_t>(move.joint - 1)];
  return info.name.empty() || info.name == "-" ? "" : info.name;
}

const char* Unit(const MoveResult& move) {
  return move.table->joints[static_cast<size_t>(move.joint - 1)].prismatic ? "mm" : "deg";
}

}  // namespace

namespace {

// A directory's data files (*.csv) and LCM logs (*.lcm) in the order they were written: by name,
// a restarted logger's continuation (NAME-03-set2.1.csv) right after the file it continues.
std::vector<std::string> FilesOfDirectory(const std::string& dir) {
  namespace fs = std::filesystem;
  struct Entry {
    std::string base;  // name without the continuation suffix and extension
    long suffix = 0;   // continuation number, 0 for none
    std::string path;
  };
  std::vector<Entry> entries;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string extension = entry.path().extension().string();
    if (!entry.is_regular_file() || (extension != ".csv" && extension != ".lcm")) continue;
    Entry e{entry.path().stem().string(), 0, entry.path().string()};
    const size_t dot = e.base.rfind('.');
    if (dot != std::string::npos && dot > 0 && dot + 1 < e.base.size() &&
        e.base.size() - dot <= 7 &&
        e.base.find_first_not_of("0123456789", dot + 1) == std::string::npos) {
      e.suffix = std::atol(e.base.c_str() + dot + 1);
      e.base.resize(dot);
    }
    e.base += extension;
    entries.push_back(e);
  }
  if (error) {
    throw core::ConfigError(core::SourceLocation{dir, 0, 0}, "",
                            "cannot list the directory: " + error.message());
  }
  if (entries.empty()) {
    throw core::ConfigError(core::SourceLocation{dir, 0, 0}, "",
                            "no data files (*.csv) or LCM logs (*.lcm) in this directory");
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.base != b.base ? a.base < b.base : a.suffix < b.suffix;
  });
  std::vector<std::string> files;
  for (const Entry& e : entries) files.push_back(e.path);
  return files;
}

}  // namespace

std::vector<RunTable> ReadInputs(const std::vector<std::string>& given,
                                 const ImportOptions& import) {
  std::vector<std::string> paths;
  for (const std::string& path : given) {
    if (std::filesystem::is_directory(path)) {
      for (const std::string& file : FilesOfDirectory(path)) paths.push_back(file);
    } else {
      paths.push_back(path);
    }
  }
  std::vector<RunTable> tables;
  for (const std::string& path : paths) {
    if (!std::filesystem::is_regular_file(path)) {
      throw core::ConfigError(
          core::SourceLocation{path, 0, 0}, "",
          std::filesystem::exists(path) ? "not a regular file" : "no such file");
    }
    if (LooksLikeLcmLog(path)) {
      for (RunTable& table : ImportLcmLog(path, import)) tables.push_back(std::move(table));
    } else {
      tables.push_back(ReadDataFile(path));
    }
  }
  return tables;
}

namespace {

// Every table analysed, with the notes of the inputs and of the analyses in input order.
struct Analyses {
  std::vector<Analysis> per_table;
  std::vector<std::string> notes;
  size_t moves = 0;
};

// Throws core::ConfigError (with the notes, which tell why) if no table holds a move to report.
Analyses AnalyzeTables(const std::vector<RunTable>& tables, const AnalysisOptions& options) {
  Analyses all;
  for (const RunTable& table : tables) {
    all.per_table.push_back(Analyze(table, options));
    all.moves += all.per_table.back().moves.size();
    for (const std::string& note : table.notes) all.notes.push_back(note);
    if (!table.continues.empty()) {
      all.notes.push_back(table.source + " continues " + table.continues +
                          " after a restart of the logger; the rows between the two were not "
                          "logged");
    }
    for (const std::string& note : all.per_table.back().notes) all.notes.push_back(note);
  }
  if (all.moves == 0) {
    std::string why;
    for (const std::string& note : all.notes) why += "\n  " + note;
    throw core::ConfigError(core::SourceLocation{tables.empty() ? "" : tables[0].source, 0, 0}, "",
                            "no move with a joint travelling at least " +
                                core::FormatApprox(options.min_travel) + " deg (mm) to report" +
                                why);
  }
  return all;
}

// One label per table, distinct even when two inputs hold the same set (it names the plots).
std::vector<std::string> DistinctLabels(const std::vector<RunTable>& tables) {
  std::map<std::string, int> label_uses;
  std::vector<std::string> keys;
  for (const RunTable& table : tables) {
    const int use = ++label_uses[table.label];
    keys.push_back(use == 1 ? table.label : table.label + "-" + std::to_string(use));
  }
  return keys;
}

// How the real arm's samples are timed (RunTable::RealSampleTimes).
std::string RealClockSource(const RunTable& table) {
  if (table.cells[static_cast<size_t>(Stream::kReal)] == 0) return "-";
  if (table.real_on_sim_clock) return "sim clock";
  if (table.real_clock_us.size() == table.rows() &&
      std::any_of(table.real_clock_us.begin(), table.real_clock_us.end(),
                  [](int64_t stamp) { return stamp != kNoClock; })) {
    return "own stamps";
  }
  return std::isfinite(table.realtime_factor) ? "file's factor" : "sim axis";
}

std::string InputsSection(const std::vector<RunTable>& tables,
                          const std::vector<std::string>& keys) {
  std::string md = "## Inputs\n\n";
  md +=
      "| input | set | rows | time_s (s) | set-point / virtual / real samples | lost in the set "
      "(set / virt / real) | closed | real-time factor | real arm timed by |\n"
      "|---|---|---|---|---|---|---|---|---|\n";
  for (size_t t = 0; t < tables.size(); ++t) {
    const RunTable& table = tables[t];
    md += "| `" + table.source + "` | " + keys[t] + " | " + std::to_string(table.rows()) + " | " +
          Fixed(table.time_s.front(), 3) + " to " + Fixed(table.time_s.back(), 3) + " | " +
          std::to_string(table.cells[0]) + " / " + std::to_string(table.cells[1]) + " / " +
          std::to_string(table.cells[2]) + " | " + std::to_string(table.LostInSet(0)) + " / " +
          std::to_string(table.LostInSet(1)) + " / " + std::to_string(table.LostInSet(2)) + " | " +
          (table.closed ? "yes" : "no") + " | " +
          (std::isfinite(table.realtime_factor) ? Fixed(table.realtime_factor, 3) : "-") + " | " +
          RealClockSource(table) + " |\n";
  }
  md +=
      "\nReal-time factor: sim time over wall time while the set was logged (1: the sim kept "
      "pace with the wall clock; below 1: it slipped). The real arm runs on the wall clock, so "
      "it is compared with the set-point and the virtual arm per move, from each move's own "
      "start, on its own clock: slipped sim time does not show as error. Real arm timed by: "
      "\"own stamps\" (each sample's wall-clock stamp, real_clock_us, counted from the move's "
      "start: exact however the slip varied), \"file's factor\" (files before format 2: the "
      "set's one real-time factor, exact only if the slip was steady), \"sim clock\" (a second "
      "sim as the real arm), \"sim axis\" (no factor known).\n";
  return md;
}

// Table II's heading, definitions and column header; its rows follow.
std::string TableIIHead(const AnalysisOptions& a, const std::optional<ReferenceColumn>& reference) {
  std::string md = "\n## Table II: error per movement set and joint\n\n";
  md +=
      "Error = second stream minus first, at the same sample time (rows that only repeat an older "
      "reading, as between two polls of a real arm, are left out); mean, RMS and maximum of its "
      "magnitude. Transient: from the move command until the joint's set-point reports move-done, "
      "plus " +
      core::FormatApprox(a.settle_window_s) +
      " s; steady state: from there until the next move or the end of the data. Degrees (mm for "
      "prismatic joints). \"-\": no common samples. Definitions: docs/logging.md.\n\n";
  md +=
      "| Set | Move | Joint | Movement | Pair | Mean error, transient | Mean error, steady state "
      "| ";
  if (reference) {
    md += "Transient, " + reference->title + " | Steady state, " + reference->title + " | ";
  }
  md += std::string("RMS | Max |\n|---|---|---|---|---|---|---|") + (reference ? "---|---|" : "") +
        "---|---|\n";
  return md;
}

// The response table's heading and definitions, then its rows.
std::string ResponseSection(const AnalysisOptions& a, const std::string& rows) {
  return "\n## Response per stream\n\nStart delay: from the move command until the stream has "
         "moved " +
         core::FormatApprox(a.start_threshold) +
         " deg (mm) from where it was. Settling time: from the move command until the stream "
         "stays within " +
         core::FormatApprox(a.settle_band_fraction * 100) +
         " % of the travel of its final value (its mean over the move's last " +
         core::FormatApprox(a.final_window_s) +
         " s). Overshoot: the farthest it went past that final value. Final error: final value "
         "minus the set-point's end.\n\n" +
         rows;
}

// Empty where no input holds a gain change.
std::string GainsSection(const std::vector<RunTable>& tables,
                         const std::vector<std::string>& keys) {
  std::string gains_md;
  for (size_t t = 0; t < tables.size(); ++t) {
    for (const std::string& line : tables[t].gains) {
      gains_md += "- " + keys[t] + " (`" + tables[t].source + "`): " + line.substr(7) + "\n";
    }
  }
  if (gains_md.empty()) return "";
  return "\n## Gain changes\n\nAs the logger heard them (chip units): requests on ARM_GAINS, the "
         "virtual servos' gains on CONTROLLER_GAINS, the real boards' on REAL_ARM_GAINS; sim "
         "time and wall clock.\n\n" +
         gains_md;
}

// One move of one table, with the texts its rows and plots share.
struct MoveRows {
  const RunTable& table;
  const std::string& key;  // the table's distinct label
  const MoveResult& move;
  std::string joint_text;  // "2 (shoulder)"
  std::string movement;    // "from 0.0 to 90.0 deg"
};

MoveRows RowsOf(const RunTable& table, const std::string& key, const MoveResult& move) {
  return {
      table, key, move,
      std::to_string(move.joint) + (JointName(move).empty() ? "" : " (" + JointName(move) + ")"),
      "from " + Fixed(move.from, 1) + " to " + Fixed(move.to, 1) + " " + Unit(move)};
}

// The reference's cells beside a Table II row: only virtual vs real rows have them.
std::string ReferenceCells(const ReferenceColumn& reference, const MoveRows& row, Pair pair) {
  const ReferenceRow* match = nullptr;
  for (const ReferenceRow& r : reference.rows) {
    if (pair == Pair::kVirtReal && r.set == row.table.label && r.joint == row.move.joint) {
      match = &r;
    }
  }
  return match ? Fixed(match->mean_transient, 2) + " | " + Fixed(match->mean_steady, 2) + " | "
               : std::string(" |  | ");
}

// Appends the move's Table II rows (one per pair) to `md` and `csv`.
void AddErrorRows(const MoveRows& row, const std::optional<ReferenceColumn>& reference,
                  std::string& md, std::string& csv) {
  const MoveResult& move = row.move;
  for (Pair pair : kAllPairs) {
    const PairMetrics& m = move.pairs[static_cast<size_t>(pair)];
    const bool first = pair == Pair::kSetVirt;
    md += "| " + (first ? row.key : "") + " | " + (first ? std::to_string(move.move_id) : "") +
          " | " + (first ? row.joint_text : "") + " | " + (first ? row.movement : "") + " | " +
          PairTitle(pair) + " | " + Cell(m.mean_transient, 2) + " | " + Cell(m.mean_steady, 2) +
          " | ";
    if (reference) md += ReferenceCells(*reference, row, pair);
    md += Cell(m.rms, 2) + " | " + Cell(m.max, 2) + " |\n";
    csv += CsvText(row.table.source) + "," + CsvText(row.key) + "," + std::to_string(move.move_id) +
           "," + std::to_string(move.joint) + "," + CsvText(JointName(move)) + "," + Unit(move) +
           "," + Fixed(move.from, 5) + "," + Fixed(move.to, 5) + "," + PairKey(pair) + "," +
           Fixed(m.mean_transient, 5) + "," + Fixed(m.mean_steady, 5) + "," + Fixed(m.rms, 5) +
           "," + Fixed(m.max, 5) + "," + std::to_string(m.transient_samples) + "," +
           std::to_string(m.steady_samples) + "," + Fixed(move.start_s, 6) + "," +
           Fixed(move.done_s, 6) + "," + Fixed(move.transient_end_s, 6) + "," +
           Fixed(move.end_s, 6) + "\n";
  }
}

// Appends the move's response rows (one per stream) to `md` and `csv`.
void AddResponseRows(const MoveRows& row, std::string& md, std::string& csv) {
  const MoveResult& move = row.move;
  for (Stream stream : kAllStreams) {
    const StreamResponse& r = move.streams[static_cast<size_t>(stream)];
    const bool first = stream == Stream::kSetpoint;
    md += "| " + (first ? row.key : "") + " | " + (first ? std::to_string(move.move_id) : "") +
          " | " + (first ? row.joint_text : "") + " | " + StreamTitle(stream) + " | ";
    if (!r.has()) {
      md += "no data | | | | |\n";
    } else {
      md += (std::isfinite(r.start_delay_s) ? Fixed(r.start_delay_s, 3) : "did not move") + " | " +
            (std::isfinite(r.settling_s) ? Fixed(r.settling_s, 3) : "not settled") + " | " +
            Cell(r.overshoot, 2) + " | " + Cell(r.overshoot_percent, 1) + " | " +
            Cell(r.final_error, 2) + " |\n";
    }
    csv += CsvText(row.table.source) + "," + CsvText(row.key) + "," + std::to_string(move.move_id) +
           "," + std::to_string(move.joint) + "," + CsvText(JointName(move)) + "," + Unit(move) +
           "," + StreamTitle(stream) + "," + std::to_string(r.samples) + "," +
           (r.has() ? Fixed(r.start_delay_s, 6) : "") + "," +
           (r.has() ? Fixed(r.settling_s, 6) : "") + "," + (r.has() ? Fixed(r.overshoot, 5) : "") +
           "," + (r.has() ? Fixed(r.overshoot_percent, 3) : "") + "," +
           (r.has() ? Fixed(r.final_value, 5) : "") + "," +
           (r.has() ? Fixed(r.final_error, 5) : "") + "\n";
  }
}

// The move's two plots: each stream's position, and each pair's error, against the time since the
// move command, from 0.1 s before it to the move's end (the paper's Fig. 6). Time is relative to
// the command.
struct MovePlots {
  PlotSpec angle;
  PlotSpec error;
};

MovePlots PlotsOf(const MoveRows& row) {
  const RunTable& table = row.table;
  const MoveResult& move = row.move;
  const double period = table.period_s();
  size_t first_row = move.begin;
  while (first_row > 0 && table.time_s[first_row - 1] >= move.start_s - 0.1) --first_row;
  const auto j = static_cast<size_t>(move.joint - 1);
  MovePlots plots;
  PlotSpec& angle = plots.angle;
  angle.title = row.key + ", move " + std::to_string(move.move_id) + ": joint " + row.joint_text +
                " " + row.movement;
  angle.x_label = "time since the move command (s)";
  angle.y_label =
      std::string("joint ") + std::to_string(move.joint) + " position (" + Unit(move) + ")";
  PlotSpec& error_plot = plots.error;
  error_plot.title =
      row.key + ", move " + std::to_string(move.move_id) + ": joint " + row.joint_text + " error";
  error_plot.x_label = angle.x_label;
  error_plot.y_label = std::string("error, second minus first (") + Unit(move) + ")";
  // Each sample is drawn once, at the time it was taken: rows that hold a sample over from an
  // earlier row (a real arm polled at 100 Hz) are skipped, so the line joins the samples; a
  // stretch without samples longer than kPlotGapS breaks it.
  for (Stream stream : kAllStreams) {
    const auto s = static_cast<size_t>(stream);
    if (!move.streams[s].has()) continue;
    PlotSeries series{StreamTitle(stream), {}, {}, kStreamColors[s]};
    // The real arm on its own clock from the move's start (see PairErrors).
    const std::vector<double> real_times =
        stream == Stream::kReal ? table.RealSampleTimes(move.begin, first_row, move.end)
                                : std::vector<double>{};
    for (size_t i = first_row; i < move.end; ++i) {
      if (!std::isfinite(table.position[j][s][i]) || !table.Fresh(stream, i, period)) continue;
      const double taken = stream == Stream::kReal ? real_times[i - first_row]
                                                   : table.time_s[i] - table.Age(stream, i);
      if (std::isfinite(taken)) AddPoint(series, taken - move.start_s, table.position[j][s][i]);
    }
    angle.series.push_back(std::move(series));
  }
  for (Pair pair : kAllPairs) {
    const auto p = static_cast<size_t>(pair);
    if (!move.pairs[p].has()) continue;
    PlotSeries series{PairTitle(pair), {}, {}, kPairColors[p]};
    for (const PairPoint& point :
         PairErrors(table, pair, j, first_row, move.end, period)) {  // as in Table II
      AddPoint(series, point.time_s - move.start_s, point.error);
    }
    error_plot.series.push_back(std::move(series));
  }
  const std::vector<PlotMarker> markers = {{0.0, "move"},
                                           {move.done_s - move.start_s, "move-done"},
                                           {move.transient_end_s - move.start_s, "steady state"}};
  angle.markers = markers;
  error_plot.markers = markers;
  return plots;
}

// Writes the move's plots into `out` (the error plot only if it has a line), adds their paths to
// `files` and returns their line of the report's plot list.
std::string WriteMovePlots(const MoveRows& row, const std::filesystem::path& out,
                           std::vector<std::string>& files) {
  const MovePlots plots = PlotsOf(row);
  const MoveResult& move = row.move;
  const std::string stem =
      row.key + "-m" + std::to_string(move.move_id) + "-j" + std::to_string(move.joint);
  const std::string angle_path = (out / (stem + "-angle.png")).string();
  const std::string error_path = (out / (stem + "-error.png")).string();
  WritePlot(plots.angle, angle_path);
  files.push_back(angle_path);
  std::string line = "- " + row.key + ", move " + std::to_string(move.move_id) + ", joint " +
                     std::to_string(move.joint) + ": `" + angle_path + "`";
  if (!plots.error.series.empty()) {
    WritePlot(plots.error, error_path);
    files.push_back(error_path);
    line += ", `" + error_path + "`";
  }
  return line + "\n";
}

std::filesystem::path MakeOutDir(const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (!std::filesystem::is_directory(dir)) {
    throw std::runtime_error("--out " + dir + ": cannot create the directory");
  }
  return dir;
}

}  // namespace

ReportOutput WriteReport(const std::vector<RunTable>& tables, const ReportOptions& options) {
  const Analyses analyses = AnalyzeTables(tables, options.analysis);
  const std::filesystem::path out = MakeOutDir(options.out_dir);
  ReportOutput output;
  output.moves = analyses.moves;
  const std::vector<std::string> keys = DistinctLabels(tables);
  const std::optional<ReferenceColumn>& reference = options.reference;

  std::string md = "# SIRUPP report\n\n" + InputsSection(tables, keys);
  md += TableIIHead(options.analysis, reference);
  std::string errors_csv =
      "input,set,move_id,joint,joint_name,unit,from,to,pair,mean_transient,mean_steady,rms,max,"
      "transient_samples,steady_samples,move_start_s,move_done_s,transient_end_s,move_end_s\n";
  std::string response_md =
      "| Set | Move | Joint | Stream | Start delay (s) | Settling time (s) | Overshoot | "
      "Overshoot (%) | Final error |\n|---|---|---|---|---|---|---|---|---|\n";
  std::string response_csv =
      "input,set,move_id,joint,joint_name,unit,stream,samples,start_delay_s,settling_s,overshoot,"
      "overshoot_percent,final_value,final_error\n";
  std::string plots_md;
  for (size_t t = 0; t < tables.size(); ++t) {
    for (const MoveResult& move : analyses.per_table[t].moves) {
      const MoveRows row = RowsOf(tables[t], keys[t], move);
      AddErrorRows(row, reference, md, errors_csv);
      AddResponseRows(row, response_md, response_csv);
      if (options.plots) plots_md += WriteMovePlots(row, out, output.files);
    }
  }
  if (reference && !reference->note.empty()) md += "\n" + reference->note + "\n";
  md += ResponseSection(options.analysis, response_md);
  md += GainsSection(tables, keys);
  if (!plots_md.empty()) md += "\n## Plots\n\n" + plots_md;
  if (!analyses.notes.empty()) {
    md += "\n## Notes\n\n";
    for (const std::string& note : analyses.notes) md += "- " + note + "\n";
  }

  const std::string md_path = (out / "report.md").string();
  const std::string errors_path = (out / "report_errors.csv").string();
  const std::string response_path = (out / "report_response.csv").string();
  WriteText(md_path, md);
  WriteText(errors_path, errors_csv);
  WriteText(response_path, response_csv);
  output.files.insert(output.files.begin(), {md_path, errors_path, response_path});
  output.markdown = md;
  return output;
}

}  // namespace sirupp::logger
