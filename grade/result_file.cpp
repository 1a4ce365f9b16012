#include "grade/result_file.hpp"

#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "grade/metrics.hpp"

namespace sirupp::grade {
namespace {

constexpr char kMagic[] = "SIRUPP-GRADE-RESULT 1\n";

class Writer {
 public:
  void U64(uint64_t value) { Raw(&value, sizeof value); }
  void I64(int64_t value) { Raw(&value, sizeof value); }
  void Double(double value) { Raw(&value, sizeof value); }
  void Bool(bool value) { U64(value ? 1 : 0); }
  void String(const std::string& text) {
    U64(text.size());
    Raw(text.data(), text.size());
  }
  void Doubles(const std::vector<double>& values) {
    U64(values.size());
    Raw(values.data(), values.size() * sizeof(double));
  }
  const std::string& bytes() const { return bytes_; }

 private:
  void Raw(const void* data, size_t size) { bytes_.append(static_cast<const char*>(data), size); }
  std::string bytes_;
};

class Reader {
 public:
  Reader(std::string bytes, std::string file) : bytes_(std::move(bytes)), file_(std::move(file)) {}
  uint64_t U64() {
    uint64_t value = 0;
    Raw(&value, sizeof value);
    return value;
  }
  int64_t I64() {
    int64_t value = 0;
    Raw(&value, sizeof value);
    return value;
  }
  double Double() {
    double value = 0;
    Raw(&value, sizeof value);
    return value;
  }
  bool Bool() { return U64() != 0; }
  std::string String() {
    const uint64_t size = Count(1);
    std::string text(size, '\0');
    Raw(text.data(), size);
    return text;
  }
  std::vector<double> Doubles() {
    const uint64_t size = Count(sizeof(double));
    std::vector<double> values(size);
    Raw(values.data(), size * sizeof(double));
    return values;
  }
  // A count of items of `item_size` bytes that the rest of the file can hold.
  uint64_t Count(size_t item_size) {
    const uint64_t count = U64();
    if (count > (bytes_.size() - at_) / item_size) Fail("a length past its end");
    return count;
  }
  bool AtEnd() const { return at_ == bytes_.size(); }
  [[noreturn]] void Fail(const std::string& what) const {
    throw std::runtime_error(file_ + ": not a grade result this program can read (" + what +
                             " at byte " + std::to_string(at_) + ")");
  }

 private:
  void Raw(void* data, size_t size) {
    if (size > bytes_.size() - at_) Fail("cut short");
    if (size > 0) std::memcpy(data, bytes_.data() + at_, size);
    at_ += size;
  }
  std::string bytes_;
  std::string file_;
  size_t at_ = 0;
};

void WriteRecord(Writer& out, const TaskRecord& record) {
  out.Bool(record.completed);
  out.String(record.failure);
  out.I64(record.num_joints);
  out.Double(record.tick_s);
  out.Bool(record.has_reference);
  out.Bool(record.track);
  out.Doubles(record.time_s);
  out.Doubles(record.position);
  out.Doubles(record.reference);
  out.Doubles(record.goal);
  out.Doubles(record.effort);
  out.I64(record.missing_rows);
  out.Double(record.setpoint_deviation);
}

TaskRecord ReadRecord(Reader& in) {
  TaskRecord record;
  record.completed = in.Bool();
  record.failure = in.String();
  const int64_t joints = in.I64();
  if (joints < 0 || joints > 64) in.Fail("a joint count of " + std::to_string(joints));
  record.num_joints = static_cast<int>(joints);
  record.tick_s = in.Double();
  record.has_reference = in.Bool();
  record.track = in.Bool();
  record.time_s = in.Doubles();
  record.position = in.Doubles();
  record.reference = in.Doubles();
  record.goal = in.Doubles();
  record.effort = in.Doubles();
  record.missing_rows = in.I64();
  record.setpoint_deviation = in.Double();
  const size_t cells = record.time_s.size() * static_cast<size_t>(record.num_joints);
  for (const std::vector<double>* column :
       {&record.position, &record.reference, &record.goal, &record.effort}) {
    if (!column->empty() && column->size() != cells) in.Fail("a record whose columns differ");
  }
  return record;
}

}  // namespace

void WriteResultFile(const std::string& file, const ControllerResult& result,
                     const std::string& problem) {
  Writer out;
  out.String(problem);
  out.String(result.label);
  out.U64(result.tasks.size());
  for (const TaskResult& task : result.tasks) {
    out.String(task.task);
    out.String(task.ended);
    WriteRecord(out, task.record);
  }
  const std::string temporary = file + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream stream(temporary, std::ios::binary | std::ios::trunc);
    stream << kMagic;
    stream.write(out.bytes().data(), static_cast<std::streamsize>(out.bytes().size()));
    if (!stream.flush()) throw std::runtime_error("cannot write " + temporary);
  }
  std::error_code error;
  std::filesystem::rename(temporary, file, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    throw std::runtime_error("cannot write " + file + ": " + error.message());
  }
}

ReadResult ReadResultFile(const std::string& file, const Suite& suite,
                          const core::RobotModel& model) {
  std::ifstream stream(file, std::ios::binary);
  if (!stream) throw std::runtime_error(file + ": missing or not readable");
  std::ostringstream text;
  text << stream.rdbuf();
  std::string bytes = text.str();
  const size_t magic = sizeof kMagic - 1;
  if (bytes.compare(0, magic, kMagic) != 0) {
    throw std::runtime_error(file + ": not a grade result (it does not start with " +
                             std::string(kMagic, magic - 1) + ")");
  }
  Reader in(bytes.substr(magic), file);
  ReadResult read;
  read.problem = in.String();
  read.result.label = in.String();
  const uint64_t count = in.U64();
  if (count != suite.tasks.size() && !(count == 0 && !read.problem.empty())) {
    in.Fail(std::to_string(count) + " tasks where the suite " + suite.name + " has " +
            std::to_string(suite.tasks.size()));
  }
  read.result.tasks.resize(count);
  for (size_t t = 0; t < count; ++t) {
    TaskResult& task = read.result.tasks[t];
    task.task = in.String();
    if (task.task != suite.tasks[t].name) {
      in.Fail("task " + std::to_string(t + 1) + " '" + task.task.substr(0, 40) +
              "' where the suite has '" + suite.tasks[t].name + "'");
    }
    task.ended = in.String();
    task.record = ReadRecord(in);
    if (task.ended.empty()) {
      task.metrics = ComputeMetrics(model, task.record, suite.tasks[t].pass);
      task.passed = task.metrics.passed();
    }
  }
  if (!in.AtEnd()) in.Fail("more than one result");
  return read;
}

}  // namespace sirupp::grade
