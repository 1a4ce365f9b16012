#include "logger/data_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "core/errors.hpp"
#include "core/printable.hpp"

namespace sirupp::logger {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void AppendFixed(std::string& out, double value, int decimals) {
  if (std::abs(value) < 0.5 * std::pow(10.0, -decimals)) value = 0;  // "0.00000", not "-0.00000"
  char buffer[64];
  const auto result =
      std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed, decimals);
  if (result.ec == std::errc()) out.append(buffer, result.ptr);
}

void AppendInt(std::string& out, int64_t value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, result.ptr);
}

const char* VelocityUnit(const JointInfo& joint) { return joint.prismatic ? "mmps" : "dps"; }
const char* EffortUnit(const JointInfo& joint) { return joint.prismatic ? "n" : "nm"; }

std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    fields.push_back(
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

// The number a text starts with ("0.50012 (sim ...)"), NaN if none or not finite and > 0.
double LeadingNumber(const std::string& text) {
  const std::string word = text.substr(0, text.find(' '));
  double value = 0;
  const auto result = std::from_chars(word.data(), word.data() + word.size(), value);
  if (result.ec != std::errc() || result.ptr != word.data() + word.size() ||
      !std::isfinite(value) || !(value > 0)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return value;
}

std::string Trim(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  const size_t last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

// What a column of a data file holds.
struct ColumnRole {
  enum Kind {
    kTime,
    kPosition,
    kVelocity,
    kEffort,
    kMoveId,
    kDone,
    kLost,
    kAge,
    kRealClock,
    kSetRecv
  } kind = kTime;
  int joint = -1;  // 0-based
  int stream = -1;
};

}  // namespace

double JointInfo::scale() const { return prismatic ? 1000.0 : 180.0 / kPi; }

std::vector<std::string> ColumnLayout::Names() const {
  std::vector<std::string> names{"time_s"};
  const auto n = joints.size();
  for (size_t j = 0; j < n; ++j) {
    for (Stream stream : kAllStreams) {
      names.push_back("j" + std::to_string(j + 1) + "_" + StreamKey(stream) + "_" +
                      joints[j].unit());
    }
  }
  names.push_back("move_id");
  for (size_t j = 0; j < n; ++j) names.push_back("j" + std::to_string(j + 1) + "_done");
  for (Stream stream : kAllStreams) names.push_back(std::string(StreamKey(stream)) + "_lost");
  for (Stream stream : kAllStreams) names.push_back(std::string(StreamKey(stream)) + "_age_us");
  names.push_back("real_clock_us");
  names.push_back("set_recv_us");
  if (velocities) {
    for (size_t j = 0; j < n; ++j) {
      for (Stream stream : kAllStreams) {
        names.push_back("j" + std::to_string(j + 1) + "_" + StreamKey(stream) + "_vel_" +
                        VelocityUnit(joints[j]));
      }
    }
  }
  if (efforts) {
    for (size_t j = 0; j < n; ++j) {
      for (Stream stream : kAllStreams) {
        names.push_back("j" + std::to_string(j + 1) + "_" + StreamKey(stream) + "_effort_" +
                        EffortUnit(joints[j]));
      }
    }
  }
  return names;
}

void ColumnLayout::AppendRow(const Row& row, std::string& out) const {
  AppendFixed(out, static_cast<double>(row.time_us) * 1e-6, 6);
  const size_t n = joints.size();
  for (size_t j = 0; j < n; ++j) {
    for (size_t s = 0; s < kNumStreams; ++s) {
      const Sample* sample = row.cell[s];
      out += ',';
      if (sample != nullptr && j < sample->position.size() && std::isfinite(sample->position[j])) {
        AppendFixed(out, sample->position[j] * joints[j].scale(), 5);
      }
    }
  }
  const Sample* set = row.cell[static_cast<size_t>(Stream::kSetpoint)];
  out += ',';
  if (set != nullptr) AppendInt(out, set->move_id);
  for (size_t j = 0; j < n; ++j) {
    out += ',';
    if (set != nullptr && j < set->done.size()) out += set->done[j] ? '1' : '0';
  }
  for (size_t s = 0; s < kNumStreams; ++s) {
    out += ',';
    AppendInt(out, row.lost[s]);
  }
  for (size_t s = 0; s < kNumStreams; ++s) {
    out += ',';
    if (row.cell[s] != nullptr) AppendInt(out, row.age_us[s]);
  }
  out += ',';
  const Sample* real = row.cell[static_cast<size_t>(Stream::kReal)];
  if (real != nullptr) AppendInt(out, real->utime);
  out += ',';
  if (set != nullptr && set->recv_utime > 0) AppendInt(out, set->recv_utime);
  if (velocities) {
    for (size_t j = 0; j < n; ++j) {
      for (size_t s = 0; s < kNumStreams; ++s) {
        const Sample* sample = row.cell[s];
        out += ',';
        if (sample != nullptr && j < sample->velocity.size()) {
          AppendFixed(out, sample->velocity[j] * joints[j].scale(), 4);
        }
      }
    }
  }
  if (efforts) {
    for (size_t j = 0; j < n; ++j) {
      for (size_t s = 0; s < kNumStreams; ++s) {
        const Sample* sample = row.cell[s];
        out += ',';
        if (sample != nullptr && j < sample->effort.size()) {
          AppendFixed(out, sample->effort[j], 5);
        }
      }
    }
  }
  out += '\n';
}

void RunTable::Reset(const std::vector<JointInfo>& joint_list) {
  joints = joint_list;
  time_s.clear();
  position.assign(joints.size(), {});
  move_id.clear();
  done.assign(joints.size(), {});
  for (std::vector<double>& ages : age_s) ages.clear();
  real_clock_us.clear();
  set_recv_us.clear();
  lost = {};
  lost_at_start = {};
  cells = {};
}

void RunTable::Append(const Row& row) {
  time_s.push_back(static_cast<double>(row.time_us) * 1e-6);
  const Sample* set = row.cell[static_cast<size_t>(Stream::kSetpoint)];
  move_id.push_back(set != nullptr ? set->move_id : -1);
  for (size_t j = 0; j < joints.size(); ++j) {
    for (size_t s = 0; s < kNumStreams; ++s) {
      const Sample* sample = row.cell[s];
      const bool has = sample != nullptr && j < sample->position.size();
      position[j][s].push_back(has ? sample->position[j] * joints[j].scale() : kNaN);
    }
    done[j].push_back(set != nullptr && j < set->done.size() ? (set->done[j] ? 1 : 0) : -1);
  }
  for (size_t s = 0; s < kNumStreams; ++s) {
    if (row.cell[s] != nullptr) ++cells[s];
    age_s[s].push_back(row.cell[s] != nullptr ? static_cast<double>(row.age_us[s]) * 1e-6 : kNaN);
  }
  const Sample* real = row.cell[static_cast<size_t>(Stream::kReal)];
  real_clock_us.push_back(real != nullptr ? real->utime : kNoClock);
  set_recv_us.push_back(set != nullptr && set->recv_utime > 0 ? set->recv_utime : kNoClock);
  if (time_s.size() == 1) lost_at_start = row.lost;
  lost = row.lost;
}

double RunTable::RealClockScale() const {
  if (real_on_sim_clock || !std::isfinite(realtime_factor) || !(realtime_factor > 0)) return 1.0;
  return realtime_factor;
}

namespace {

// The real arm's clock (us) at time `at` on the axis, from the stamped real samples of the rows
// around `row` (their axis time, row time minus age, against their stamps): interpolated between
// the last taken at or before `at` and the first after it, else carried from the nearest one at
// the file's factor. nullopt without stamped samples.
std::optional<double> RealClockAt(const RunTable& table, size_t row, double at) {
  const size_t n = table.rows();
  auto taken = [&](size_t k) { return table.time_s[k] - table.Age(Stream::kReal, k); };
  auto stamped = [&](size_t k) { return table.real_clock_us[k] != kNoClock; };
  std::optional<size_t> before, after;
  for (size_t k = row; k < n && !after; ++k) {
    if (!stamped(k)) continue;
    if (taken(k) <= at) {
      before = k;
    } else {
      after = k;
    }
  }
  for (size_t k = row; !before && k-- > 0;) {
    if (stamped(k) && taken(k) <= at) before = k;
  }
  if (!before && !after) return std::nullopt;
  const size_t a = before ? *before : *after;
  const double base = static_cast<double>(table.real_clock_us[a]);
  double clock = base + (at - taken(a)) * 1e6 / table.RealClockScale();
  if (before && after) {
    const double span_axis = taken(*after) - taken(a);
    const auto span_clock =
        static_cast<double>(table.real_clock_us[*after] - table.real_clock_us[a]);
    clock = base + (at - taken(a)) / span_axis * span_clock;
  }
  // The set-point's receive time at `row`, when `at` is that row's time: the wall clock when the
  // sim was there, measured rather than estimated; used when the real arm's stamps are on the
  // same clock (the aligner's rule: within 1 s).
  constexpr double kSameClockUs = 1e6;
  if (table.set_recv_us.size() == n && table.set_recv_us[row] != kNoClock &&
      std::abs(table.time_s[row] - at) < 1e-9) {
    const auto received = static_cast<double>(table.set_recv_us[row]);
    if (std::abs(received - clock) < kSameClockUs) return received;
  }
  return clock;
}

}  // namespace

std::vector<double> RunTable::RealSampleTimes(size_t anchor, size_t begin, size_t end) const {
  end = std::min(end, rows());
  std::vector<double> times(end > begin ? end - begin : 0, kNaN);
  if (times.empty() || anchor >= rows()) return times;
  const double start = time_s[anchor];
  const bool have_clock = real_clock_us.size() == rows();
  const std::optional<double> clock_at_start =
      have_clock ? RealClockAt(*this, anchor, start) : std::nullopt;
  const double scale = RealClockScale();
  for (size_t i = begin; i < end; ++i) {
    if (clock_at_start && real_clock_us[i] != kNoClock) {
      times[i - begin] = start + (static_cast<double>(real_clock_us[i]) - *clock_at_start) * 1e-6;
    } else if (!joints.empty() &&
               std::isfinite(position[0][static_cast<size_t>(Stream::kReal)][i])) {
      times[i - begin] = start + (time_s[i] - Age(Stream::kReal, i) - start) / scale;
    }
  }
  return times;
}

std::vector<size_t> RunTable::MoveStarts() const {
  std::vector<size_t> starts;
  int64_t current = -2;
  for (size_t i = 0; i < rows(); ++i) {
    const int64_t id = move_id[i];
    if (id < 0) continue;
    if (current != -2 && id != current) starts.push_back(i);
    current = id;
  }
  return starts;
}

double RunTable::period_s() const {
  double period = 0;
  for (size_t i = 1; i < time_s.size(); ++i) {
    const double step = time_s[i] - time_s[i - 1];
    if (step > 0 && (period == 0 || step < period)) period = step;
  }
  return period;
}

double RunTable::Age(Stream stream, size_t i) const {
  const std::vector<double>& ages = age_s[static_cast<size_t>(stream)];
  return i < ages.size() && !std::isnan(ages[i]) ? ages[i] : 0.0;
}

bool RunTable::Fresh(Stream stream, size_t i, double period) const {
  if (period <= 0) return true;             // a single row: nothing is held over
  return Age(stream, i) < period - 0.5e-6;  // ages are whole microseconds, times have 6 decimals
}

std::string PlanLabel(const std::string& plan_name) {
  if (plan_name.empty()) return "manual";
  std::string stem = std::filesystem::path(plan_name).stem().string();
  for (char& c : stem) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_';
    if (!ok) c = '_';
  }
  return stem.empty() ? "plan" : stem;
}

// ---- Writer
// --------------------------------------------------------------------------------------

DataFileWriter::DataFileWriter(const std::string& path,
                               const std::vector<std::string>& header_lines, ColumnLayout layout)
    : path_(path), layout_(std::move(layout)) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw std::runtime_error(path + ": cannot create the data file: " + std::strerror(errno) +
                             (errno == EEXIST ? " (choose another --name or --out)" : ""));
  }
  std::string text = std::string(kFileMagic) + "; the column line is line " +
                     std::to_string(header_lines.size() + 2) + "\n";
  for (const std::string& line : header_lines) text += "# " + line + "\n";
  const std::vector<std::string> names = layout_.Names();
  for (size_t i = 0; i < names.size(); ++i) text += (i ? "," : "") + names[i];
  text += "\n";
  WriteAll(text);
}

DataFileWriter::~DataFileWriter() {
  if (fd_ >= 0) {
    try {
      Flush();
    } catch (const std::exception&) {  // nothing sensible to do in a destructor
    }
    ::close(fd_);
  }
}

void DataFileWriter::Append(const Row& row) {
  const double t = static_cast<double>(row.time_us) * 1e-6;
  if (rows_ == 0) first_time_s_ = t;
  last_time_s_ = t;
  ++rows_;
  layout_.AppendRow(row, buffer_);
}

void DataFileWriter::AppendComment(const std::string& text) {
  buffer_ += "# ";
  for (char c : text) buffer_ += c == '\n' || c == '\r' ? ' ' : c;
  buffer_ += '\n';
}

void DataFileWriter::Flush() {
  if (buffer_.empty() || fd_ < 0) return;
  std::string text;
  text.swap(buffer_);
  WriteAll(text);
}

void DataFileWriter::Close(const std::string& end_line) {
  if (fd_ < 0) return;
  Flush();
  WriteAll("# end: " + end_line + "\n");
  ::close(fd_);
  fd_ = -1;
}

void DataFileWriter::WriteAll(const std::string& text) {
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(path_ + ": write failed: " + std::strerror(errno));
    }
    done += static_cast<size_t>(n);
  }
}

// ---- Reader
// --------------------------------------------------------------------------------------

namespace {

class FileReader {
 public:
  explicit FileReader(std::string path) : path_(std::move(path)) {}

  RunTable Read() {
    const Lines lines = ReadLines();
    const size_t column_index = ReadHeader(lines);
    const int column_line = static_cast<int>(column_index + 1);
    ParseColumns(column_line, lines.text[column_index]);
    table_.label = !table_.plan_name.empty() ? PlanLabel(table_.plan_name)
                                             : std::filesystem::path(path_).stem().string();
    ReadBody(lines, column_index);
    if (lines.partial_last && lines.text.size() > static_cast<size_t>(column_line)) {
      table_.notes.push_back(path_ + ":" + std::to_string(lines.text.size()) +
                             ": the last line has no line end (the logger stopped while writing "
                             "it); ignored");
    }
    if (table_.rows() == 0) Fail(column_line, "no data rows after the column line");
    if (!std::isfinite(table_.realtime_factor)) table_.realtime_factor = factor_so_far_;
    if (!table_.closed) {
      table_.notes.push_back(path_ +
                             ": no '# end:' line: the logger did not close this file "
                             "(killed?); its " +
                             std::to_string(table_.rows()) + " complete rows are used");
    }
    return std::move(table_);
  }

 private:
  struct Lines {
    std::vector<std::string> text;
    bool partial_last = false;  // the last line has no line end
  };

  // The file's lines, checked to be a data file by its first line.
  Lines ReadLines() const {
    std::ifstream in(path_, std::ios::binary);
    if (!in) Fail(0, "cannot open the file");
    std::ostringstream content;
    content << in.rdbuf();
    const std::string text = content.str();
    if (text.empty()) Fail(0, "the file is empty; expected a sirupp-logger data file");

    Lines lines;
    size_t start = 0;
    while (start < text.size()) {
      const size_t end = text.find('\n', start);
      if (end == std::string::npos) {
        lines.text.push_back(text.substr(start));
        lines.partial_last = true;
        break;
      }
      lines.text.push_back(text.substr(start, end - start));
      start = end + 1;
    }
    if (lines.text[0].rfind(kFileMagic, 0) != 0 && lines.text[0].rfind(kFileMagicFormat1, 0) != 0) {
      Fail(1, "not a sirupp-logger data file: the first line must start with '" +
                  std::string(kFileMagic) +
                  "' (or format 1) (an LCM log starts with the sync word 0xEDA1DA01)");
    }
    return lines;
  }

  // The '# key: value' lines after the first; returns the index of the column line.
  size_t ReadHeader(const Lines& lines) {
    table_.source = path_;
    size_t index = 1;
    int declared_joints = -1;
    for (; index < lines.text.size() && !lines.text[index].empty() && lines.text[index][0] == '#';
         ++index) {
      const std::string& line = lines.text[index];
      const size_t colon = line.find(':');
      if (colon == std::string::npos) continue;
      const std::string key = Trim(line.substr(1, colon - 1));
      const std::string value = Trim(line.substr(colon + 1));
      if (key == "joints") declared_joints = ParseJoints(static_cast<int>(index + 1), value);
      if (key == "plan") table_.plan_name = value == "(none)" ? "" : value;
      if (key == "continues") table_.continues = value.substr(0, value.find(' '));
      if (key == "mode") {
        const size_t real = value.find("real arm: ");
        table_.real_on_sim_clock = real != std::string::npos && value.substr(real + 10) == "sim";
      }
      if (key == "real-time factor so far") factor_so_far_ = LeadingNumber(value);
    }
    const int column_line = static_cast<int>(index + 1);
    if (index >= lines.text.size() || (lines.partial_last && index == lines.text.size() - 1)) {
      Fail(column_line, "the file ends inside its header, before the column line (truncated)");
    }
    if (declared_joints < 0) {
      Fail(column_line, "the header has no '# joints:' line; it is needed to check the columns");
    }
    return index;
  }

  // The complete lines after the column line: data rows and the comments the logger writes
  // between them (gains, real-time factor, end).
  void ReadBody(const Lines& lines, size_t column_index) {
    const size_t last_complete = lines.partial_last ? lines.text.size() - 1 : lines.text.size();
    for (size_t index = column_index + 1; index < last_complete; ++index) {
      const int line_number = static_cast<int>(index + 1);
      const std::string& line = lines.text[index];
      if (line.empty()) Fail(line_number, "empty line inside the data");
      if (line[0] == '#') {
        if (line.rfind("# end:", 0) == 0) table_.closed = true;
        if (line.rfind("# gains: ", 0) == 0) table_.gains.push_back(line.substr(2));
        if (line.rfind("# real-time factor: ", 0) == 0) {
          const double factor = LeadingNumber(line.substr(20));
          if (std::isfinite(factor)) table_.realtime_factor = factor;
        }
        continue;
      }
      if (table_.closed) Fail(line_number, "data after the '# end:' line");
      ParseRow(line_number, line);
    }
  }

  [[noreturn]] void Fail(int line, const std::string& problem) const {
    throw core::ConfigError(core::SourceLocation{path_, line, 0}, "", core::Printable(problem));
  }

  // "6: j1 waist deg; j2 shoulder deg; ..." -> the joints; returns their count.
  int ParseJoints(int line, const std::string& value) {
    const size_t colon = value.find(':');
    int count = -1;
    const std::string count_text = Trim(value.substr(0, colon));
    const auto result =
        std::from_chars(count_text.data(), count_text.data() + count_text.size(), count);
    if (colon == std::string::npos || result.ec != std::errc() ||
        result.ptr != count_text.data() + count_text.size() || count < 1 || count > 64) {
      Fail(line,
           "joints: expected 'N: j1 NAME UNIT; ...' with N from 1 to 64, got '" + value + "'");
    }
    std::vector<JointInfo> joints(static_cast<size_t>(count));
    std::stringstream entries(value.substr(colon + 1));
    std::string entry;
    int index = 0;
    while (std::getline(entries, entry, ';')) {
      std::istringstream words(entry);
      std::string id, name, unit;
      words >> id >> name >> unit;
      if (index >= count || id != "j" + std::to_string(index + 1) ||
          (unit != "deg" && unit != "mm")) {
        Fail(line, "joints: entry " + std::to_string(index + 1) + " '" + Trim(entry) +
                       "': expected 'j" + std::to_string(index + 1) + " NAME deg' or '... mm' (" +
                       std::to_string(count) + " entries)");
      }
      joints[static_cast<size_t>(index)] = {name, unit == "mm"};
      ++index;
    }
    if (index != count) {
      Fail(line,
           "joints: " + std::to_string(count) + " declared, " + std::to_string(index) + " listed");
    }
    table_.Reset(joints);
    return count;
  }

  void ParseColumns(int line, const std::string& text) {
    const std::vector<std::string> names = SplitFields(text);
    std::map<std::string, int> seen;
    for (size_t c = 0; c < names.size(); ++c) {
      const std::string& name = names[c];
      const std::string where = "column " + std::to_string(c + 1) + " '" + name + "'";
      if (seen.count(name)) {
        Fail(line, where + ": repeats column " + std::to_string(seen[name] + 1));
      }
      seen[name] = static_cast<int>(c);
      if (c == 0 && name != "time_s") Fail(line, where + ": the first column must be time_s");
      roles_.push_back(c == 0 ? ColumnRole{} : RoleOf(line, where, name));
      has_clock_column_ |= roles_.back().kind == ColumnRole::kRealClock;
      has_recv_column_ |= roles_.back().kind == ColumnRole::kSetRecv;
      names_.push_back(name);
    }
    const int n = static_cast<int>(table_.joints.size());
    for (int j = 0; j < n; ++j) {
      for (Stream stream : kAllStreams) {
        const std::string want = "j" + std::to_string(j + 1) + "_" + StreamKey(stream) + "_" +
                                 table_.joints[static_cast<size_t>(j)].unit();
        if (!seen.count(want))
          Fail(line, "no column " + want + " (every joint needs set, virt and real)");
      }
    }
    if (!seen.count("move_id")) Fail(line, "no column move_id");
  }

  // What a column after time_s holds, from its name.
  ColumnRole RoleOf(int line, const std::string& where, const std::string& name) const {
    ColumnRole role;
    if (name == "move_id") {
      role.kind = ColumnRole::kMoveId;
    } else if (name.size() > 5 && name.compare(name.size() - 5, 5, "_lost") == 0) {
      role.kind = ColumnRole::kLost;
      role.stream = StreamIndex(name.substr(0, name.size() - 5));
      if (role.stream < 0) Fail(line, where + ": unknown; allowed set_lost, virt_lost, real_lost");
    } else if (name.size() > 7 && name.compare(name.size() - 7, 7, "_age_us") == 0) {
      role.kind = ColumnRole::kAge;
      role.stream = StreamIndex(name.substr(0, name.size() - 7));
      if (role.stream < 0)
        Fail(line, where + ": unknown; allowed set_age_us, virt_age_us, real_age_us");
    } else if (name == "real_clock_us") {
      role.kind = ColumnRole::kRealClock;
    } else if (name == "set_recv_us") {
      role.kind = ColumnRole::kSetRecv;
    } else if (name.size() > 1 && name[0] == 'j') {
      role = JointRoleOf(line, where, name);
    } else {
      Fail(line, where + ": unknown column" + kAllowed);
    }
    return role;
  }

  // A joint's column: jN_done or jN_{set,virt,real}_{position|vel_...|effort_...} in its units.
  ColumnRole JointRoleOf(int line, const std::string& where, const std::string& name) const {
    const int n = static_cast<int>(table_.joints.size());
    ColumnRole role;
    size_t pos = 1;
    while (pos < name.size() && std::isdigit(static_cast<unsigned char>(name[pos]))) ++pos;
    int joint = 0;
    std::from_chars(name.data() + 1, name.data() + pos, joint);
    if (pos == 1 || pos >= name.size() || name[pos] != '_') {
      Fail(line, where + ": unknown column" + kAllowed);
    }
    if (joint < 1 || joint > n) {
      Fail(line, where + ": unknown joint j" + name.substr(1, pos - 1) + ": the header declares " +
                     std::to_string(n) + " joints (j1 to j" + std::to_string(n) + ")");
    }
    role.joint = joint - 1;
    const JointInfo& info = table_.joints[static_cast<size_t>(role.joint)];
    const std::string rest = name.substr(pos + 1);
    if (rest == "done") {
      role.kind = ColumnRole::kDone;
      return role;
    }
    const size_t underscore = rest.find('_');
    role.stream = StreamIndex(rest.substr(0, underscore));
    const std::string what = underscore == std::string::npos ? "" : rest.substr(underscore + 1);
    if (role.stream < 0) Fail(line, where + ": unknown column" + kAllowed);
    if (what == info.unit()) {
      role.kind = ColumnRole::kPosition;
    } else if (what == std::string("vel_") + VelocityUnit(info)) {
      role.kind = ColumnRole::kVelocity;
    } else if (what == std::string("effort_") + EffortUnit(info)) {
      role.kind = ColumnRole::kEffort;
    } else {
      Fail(line,
           where + ": unknown column for joint j" + std::to_string(joint) + " (" +
               (info.prismatic ? "prismatic, positions in mm" : "revolute, positions in deg") +
               ")" + kAllowed);
    }
    return role;
  }

  static int StreamIndex(const std::string& key) {
    for (Stream stream : kAllStreams) {
      if (key == StreamKey(stream)) return static_cast<int>(stream);
    }
    return -1;
  }

  void ParseRow(int line, const std::string& text) {
    const std::vector<std::string> fields = SplitFields(text);
    if (fields.size() != roles_.size()) {
      Fail(line, std::to_string(fields.size()) + " fields; the column line has " +
                     std::to_string(roles_.size()));
    }
    std::vector<double> row_position(table_.joints.size() * kNumStreams, kNaN);
    int64_t move = -1;
    std::vector<int8_t> row_done(table_.joints.size(), -1);
    std::array<int64_t, kNumStreams> row_lost = table_.lost;
    std::array<double, kNumStreams> row_age = {kNaN, kNaN, kNaN};
    int64_t row_clock = kNoClock;
    int64_t row_recv = kNoClock;
    double time = kNaN;
    for (size_t c = 0; c < fields.size(); ++c) {
      const std::string& field = fields[c];
      const ColumnRole& role = roles_[c];
      if (field.empty()) {
        if (role.kind == ColumnRole::kTime)
          Fail(line, "column time_s: empty; every row needs a time");
        continue;
      }
      if (role.kind == ColumnRole::kMoveId || role.kind == ColumnRole::kDone ||
          role.kind == ColumnRole::kLost || role.kind == ColumnRole::kAge ||
          role.kind == ColumnRole::kRealClock || role.kind == ColumnRole::kSetRecv) {
        int64_t value = 0;
        const auto result = std::from_chars(field.data(), field.data() + field.size(), value);
        const int64_t low = role.kind == ColumnRole::kMoveId ? -1 : 0;
        const int64_t high = role.kind == ColumnRole::kDone ? 1 : INT64_MAX;
        if (result.ec != std::errc() || result.ptr != field.data() + field.size() || value < low ||
            value > high) {
          Fail(line, "column " + std::to_string(c + 1) + " (" + names_[c] + "): '" + field +
                         "' is not allowed; " +
                         (role.kind == ColumnRole::kDone     ? "expected 0 or 1"
                          : role.kind == ColumnRole::kMoveId ? "expected a whole number >= -1"
                                                             : "expected a whole number >= 0"));
        }
        if (role.kind == ColumnRole::kMoveId) move = value;
        if (role.kind == ColumnRole::kDone)
          row_done[static_cast<size_t>(role.joint)] = static_cast<int8_t>(value);
        if (role.kind == ColumnRole::kLost) row_lost[static_cast<size_t>(role.stream)] = value;
        if (role.kind == ColumnRole::kAge) {
          row_age[static_cast<size_t>(role.stream)] = static_cast<double>(value) * 1e-6;
        }
        if (role.kind == ColumnRole::kRealClock) row_clock = value;
        if (role.kind == ColumnRole::kSetRecv) row_recv = value;
        continue;
      }
      double value = 0;
      const auto result = std::from_chars(field.data(), field.data() + field.size(), value);
      if (result.ec != std::errc() || result.ptr != field.data() + field.size() ||
          !std::isfinite(value)) {
        Fail(line, "column " + std::to_string(c + 1) + " (" + names_[c] + "): '" + field +
                       "' is not a finite decimal number");
      }
      if (role.kind == ColumnRole::kTime) time = value;
      if (role.kind == ColumnRole::kPosition) {
        row_position[static_cast<size_t>(role.joint) * kNumStreams +
                     static_cast<size_t>(role.stream)] = value;
      }
    }
    if (!table_.time_s.empty() && !(time > table_.time_s.back())) {
      Fail(line, "time_s " + core::FormatNumber(time) + " is not after the previous row's " +
                     core::FormatNumber(table_.time_s.back()) + " (rows must go forward in time)");
    }
    table_.time_s.push_back(time);
    table_.move_id.push_back(move);
    for (size_t j = 0; j < table_.joints.size(); ++j) {
      for (size_t s = 0; s < kNumStreams; ++s) {
        const double value = row_position[j * kNumStreams + s];
        table_.position[j][s].push_back(value);
        if (j == 0 && !std::isnan(value)) ++table_.cells[s];
      }
      table_.done[j].push_back(row_done[j]);
    }
    for (size_t s = 0; s < kNumStreams; ++s) table_.age_s[s].push_back(row_age[s]);
    if (has_clock_column_) table_.real_clock_us.push_back(row_clock);
    if (has_recv_column_) table_.set_recv_us.push_back(row_recv);
    if (table_.time_s.size() == 1) table_.lost_at_start = row_lost;
    table_.lost = row_lost;
  }

  static constexpr const char* kAllowed =
      "; allowed: time_s, jN_{set,virt,real}_{deg|mm}, jN_{set,virt,real}_vel_{dps|mmps}, "
      "jN_{set,virt,real}_effort_{nm|n}, move_id, jN_done, {set,virt,real}_lost, "
      "{set,virt,real}_age_us, real_clock_us, set_recv_us";

  std::string path_;
  RunTable table_;
  double factor_so_far_ = kNaN;    // from the header, used when no later line gives the factor
  bool has_clock_column_ = false;  // real_clock_us (format 2)
  bool has_recv_column_ = false;   // set_recv_us (format 2)
  std::vector<ColumnRole> roles_;
  std::vector<std::string> names_;
};

}  // namespace

RunTable ReadDataFile(const std::string& path) { return FileReader(path).Read(); }

}  // namespace sirupp::logger
