// The report (logger/analysis.hpp, logger/report.hpp): its numbers on synthetic data with known
// answers (a pure delay, a step with overshoot, a constant offset), LCM log files read like data
// files, the malformed-input corpus tests/data/bad_logs/ with its messages, and the paper's set VII
// run closed-loop (sirupp-sim and sirupp-control logic in lockstep, sirupp-logger logic writing the
// file) then reported with plots.

#include <gtest/gtest.h>
#include <lcm/eventlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sstream>

#include "control/control_node.hpp"
#include "control/plan.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "logger/analysis.hpp"
#include "logger/lcm_log.hpp"
#include "logger/log_import.hpp"
#include "logger/logger_node.hpp"
#include "logger/report.hpp"
#include "sim/sim_node.hpp"
#include "tests/helpers.hpp"

namespace sirupp::logger {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr size_t kSet = 0, kVirt = 1, kReal = 2;

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char pattern[] = "/tmp/sirupp_report_test_XXXXXX";
    path = mkdtemp(pattern);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

// One joint sampled every millisecond for 3 s; move 1 until 0.5 s, move 2 from then on.
// Each stream is a function of time (NaN = no sample); done from `done_s` on.
template <class Set, class Virt, class Real>
RunTable Synthetic(Set set, Virt virt, Real real, double done_s) {
  RunTable table;
  table.source = "synthetic";
  table.label = "synthetic";
  table.Reset({{"waist", false}});
  for (int i = 0; i <= 3000; ++i) {
    const double t = i * 1e-3;
    table.time_s.push_back(t);
    table.position[0][kSet].push_back(set(t));
    table.position[0][kVirt].push_back(virt(t));
    table.position[0][kReal].push_back(real(t));
    const bool second = i >= 500;
    table.move_id.push_back(second ? 2 : 1);
    table.done[0].push_back(!second || t >= done_s - 1e-9 ? 1 : 0);
  }
  for (size_t s = 0; s < 3; ++s) {
    table.cells[s] = std::count_if(table.position[0][s].begin(), table.position[0][s].end(),
                                   [](double v) { return !std::isnan(v); });
  }
  return table;
}

// 0 -> 90 deg at 90 deg/s from 0.5 s (done at 1.5 s).
double Ramp(double t) { return std::clamp(90.0 * (t - 0.5), 0.0, 90.0); }
double None(double) { return NAN; }

const MoveResult& OnlyMove(const Analysis& analysis) {
  EXPECT_EQ(analysis.moves.size(), 1u);
  return analysis.moves.at(0);
}

TEST(ReportNumbers, APureDelay) {
  const RunTable table = Synthetic(
      Ramp, [](double t) { return Ramp(t - 0.1); }, None, 1.5);
  const Analysis analysis = Analyze(table, AnalysisOptions{});
  const MoveResult& move = OnlyMove(analysis);
  EXPECT_EQ(move.move_id, 2);
  EXPECT_EQ(move.joint, 1);
  EXPECT_DOUBLE_EQ(move.start_s, 0.5);
  EXPECT_DOUBLE_EQ(move.done_s, 1.5);
  EXPECT_DOUBLE_EQ(move.from, 0.0);
  EXPECT_DOUBLE_EQ(move.to, 90.0);
  const PairMetrics& m = move.pairs[static_cast<size_t>(Pair::kSetVirt)];
  // |error| = 9 deg while both ramp, 0 -> 9 -> 0 over 0.1 s at either end: 9 deg*s in the
  // transient of 1.25 s (until done + 0.25 s): mean 7.2; steady state 0; RMS over the move's
  // window (until done + 0.25 s + the 1 s steady window, 2.25 s; the file goes on to 3 s):
  // sqrt((81 * 0.9 + 2 * 8100 * 0.1^3 / 3) / 2.25) = 5.8992.
  EXPECT_NEAR(m.mean_transient, 7.2, 0.01);
  EXPECT_NEAR(m.mean_steady, 0.0, 1e-12);
  EXPECT_NEAR(m.max, 9.0, 1e-9);
  EXPECT_NEAR(m.rms, 5.8992, 0.005);
  EXPECT_EQ(m.transient_samples, 1251);
  EXPECT_FALSE(move.pairs[static_cast<size_t>(Pair::kSetReal)].has());
  const StreamResponse& set = move.streams[kSet];
  const StreamResponse& virt = move.streams[kVirt];
  EXPECT_NEAR(virt.start_delay_s - set.start_delay_s, 0.1, 1e-9);  // the delay itself
  EXPECT_NEAR(set.start_delay_s, 0.5 / 90, 1e-9);                  // 0.5 deg at 90 deg/s
  EXPECT_NEAR(set.settling_s, 0.98, 1e-9);                         // within 2 % of 90 deg of 90 deg
  EXPECT_NEAR(virt.settling_s, 1.08, 1e-9);
  EXPECT_NEAR(virt.overshoot, 0.0, 1e-12);
  EXPECT_NEAR(virt.final_error, 0.0, 1e-12);
  EXPECT_FALSE(move.streams[kReal].has());
}

TEST(ReportNumbers, AStepWithOvershoot) {
  // The set-point jumps to 90 at 0.5 s; the arm rises linearly to 99 at 1.0 s, returns to 90
  // at 1.1 s and stays.
  auto step = [](double t) { return t >= 0.5 - 1e-9 ? 90.0 : 0.0; };
  auto arm = [](double t) {
    if (t < 0.5) return 0.0;
    if (t < 1.0) return 198.0 * (t - 0.5);
    if (t < 1.1) return 99.0 - 90.0 * (t - 1.0);
    return 90.0;
  };
  const MoveResult move = OnlyMove(Analyze(Synthetic(step, arm, None, 0.5), AnalysisOptions{}));
  const StreamResponse& set = move.streams[kSet];
  const StreamResponse& virt = move.streams[kVirt];
  EXPECT_DOUBLE_EQ(set.start_delay_s, 0.0);
  EXPECT_DOUBLE_EQ(set.settling_s, 0.0);
  EXPECT_DOUBLE_EQ(set.overshoot, 0.0);
  EXPECT_NEAR(virt.start_delay_s, 0.5 / 198, 1e-9);  // 0.5 deg at 198 deg/s, between two rows
  EXPECT_NEAR(virt.overshoot, 9.0, 1e-9);
  EXPECT_NEAR(virt.overshoot_percent, 10.0, 1e-9);
  EXPECT_NEAR(virt.settling_s, 0.58, 1e-9);  // 91.8 deg on the way back at 1.08 s
  // Transient: 0.5 to 0.75 s (done at once + 0.25 s): |error| falls linearly 90 -> 40.5.
  EXPECT_NEAR(move.pairs[0].mean_transient, 65.25, 1e-9);
  EXPECT_NEAR(move.pairs[0].max, 90.0, 1e-9);
}

TEST(ReportNumbers, AConstantOffset) {
  const RunTable table = Synthetic(
      Ramp, Ramp, [](double t) { return Ramp(t) + 2.0; }, 1.5);
  const MoveResult move = OnlyMove(Analyze(table, AnalysisOptions{}));
  for (Pair pair : {Pair::kSetReal, Pair::kVirtReal}) {
    const PairMetrics& m = move.pairs[static_cast<size_t>(pair)];
    EXPECT_NEAR(m.mean_transient, 2.0, 1e-9) << PairTitle(pair);
    EXPECT_NEAR(m.mean_steady, 2.0, 1e-9) << PairTitle(pair);
    EXPECT_NEAR(m.rms, 2.0, 1e-9) << PairTitle(pair);
    EXPECT_NEAR(m.max, 2.0, 1e-9) << PairTitle(pair);
  }
  EXPECT_NEAR(move.pairs[0].max, 0.0, 1e-12);
  EXPECT_NEAR(move.streams[kReal].final_error, 2.0, 1e-9);
  EXPECT_DOUBLE_EQ(move.streams[kReal].start_delay_s, move.streams[kVirt].start_delay_s);
}

// A real arm polled every 10 ms: each sample is held in the rows until the next one, with its age
// in the file. Compared only where it is current, an arm that follows the set-point exactly shows
// no error; the held rows would have shown the set-point's travel since the poll (up to 0.9 deg
// here, 0.32 deg on average in the transient).
TEST(ReportNumbers, ARealArmPolledEvery10msIsComparedAtItsOwnSampleTimes) {
  const auto polled = [](double offset_s) {
    RunTable table = Synthetic(
        Ramp, Ramp,
        [offset_s](double t) {
          return Ramp(std::floor((t - offset_s) / 0.01 + 1e-9) * 0.01 + offset_s);
        },
        1.5);
    for (size_t s = 0; s < 3; ++s) table.age_s[s].assign(table.rows(), 0.0);
    for (size_t i = 0; i < table.rows(); ++i) {
      const double t = table.time_s[i];
      const double taken = std::floor((t - offset_s) / 0.01 + 1e-9) * 0.01 + offset_s;
      table.age_s[kReal][i] = std::round((t - taken) * 1e6) * 1e-6;
    }
    return table;
  };
  const RunTable on_rows = polled(0.0);
  const MoveResult move = OnlyMove(Analyze(on_rows, AnalysisOptions{}));
  const PairMetrics& set_real = move.pairs[static_cast<size_t>(Pair::kSetReal)];
  EXPECT_NEAR(set_real.mean_transient, 0.0, 1e-9);
  EXPECT_NEAR(set_real.max, 0.0, 1e-9);
  EXPECT_EQ(set_real.transient_samples, 126);  // one row in ten from 0.5 s to 1.75 s
  EXPECT_NEAR(move.pairs[static_cast<size_t>(Pair::kVirtReal)].rms, 0.0, 1e-9);
  EXPECT_EQ(move.pairs[static_cast<size_t>(Pair::kSetVirt)].transient_samples, 1251);
  EXPECT_FALSE(on_rows.Fresh(Stream::kReal, 501, on_rows.period_s()));
  EXPECT_TRUE(on_rows.Fresh(Stream::kReal, 510, on_rows.period_s()));

  // Polls half a row after the rows: the start delay is timed by the polls (0.5015 s at 0.135
  // deg, 0.5115 s at 1.035 deg: 0.5 deg crossed at 0.50556 s), not by the rows that show them
  // (0.502 and 0.512 s).
  const RunTable between_rows = polled(0.0015);
  const MoveResult late = OnlyMove(Analyze(between_rows, AnalysisOptions{}));
  EXPECT_NEAR(late.streams[kReal].start_delay_s, 0.5 / 90, 1e-9);
  EXPECT_NEAR(late.streams[kSet].start_delay_s, 0.5 / 90, 1e-9);
}

// The start delay is when the stream crossed start_threshold, between the first sample past it and
// the one before, not the first sample past it: that one is late by up to the gap between two
// polls, which on a busy PC grows beyond the bridge's 10 ms (measured in `sirupp demo` with one
// busy loop per core, run as a user without real-time priority: polls up to 66 ms apart, joint 1
// of set V timed 14.5 ms late by its first poll past 0.5 deg). A ramp polled every 30 ms, the
// poll before the crossing 0.5, 2.5 or 5 ms into the ramp: it starts at 0.5 deg / 90 deg/s
// whatever the phase, as the set-point does (the first poll past 0.5 deg: 30.5 to 35 ms).
TEST(ReportNumbers, TheStartDelayIsTheThresholdCrossingBetweenTwoPollsNotTheNextPoll) {
  for (const double phase_s : {0.0205, 0.0225, 0.025}) {
    const auto taken = [phase_s](double t) {
      return std::floor((t - phase_s) / 0.03 + 1e-9) * 0.03 + phase_s;
    };
    RunTable table = Synthetic(
        Ramp, Ramp, [&taken](double t) { return Ramp(taken(t)); }, 1.5);
    for (size_t s = 0; s < 3; ++s) table.age_s[s].assign(table.rows(), 0.0);
    for (size_t i = 0; i < table.rows(); ++i) {
      table.age_s[kReal][i] = std::round((table.time_s[i] - taken(table.time_s[i])) * 1e6) * 1e-6;
    }
    const MoveResult move = OnlyMove(Analyze(table, AnalysisOptions{}));
    EXPECT_NEAR(move.streams[kReal].start_delay_s, 0.5 / 90, 1e-9) << "phase " << phase_s;
    EXPECT_NEAR(move.streams[kVirt].start_delay_s, 0.5 / 90, 1e-9) << "phase " << phase_s;
  }
}
TEST(ReportNumbers, JointsThatDoNotTravelAreLeftOutAndUnknownJointsAreRefused) {
  RunTable table = Synthetic([](double) { return 0.2; }, Ramp, None, 1.5);
  EXPECT_TRUE(Analyze(table, AnalysisOptions{}).moves.empty());
  AnalysisOptions options;
  options.joints = {2};
  const std::string text =
      sirupp::testing::ErrorText<core::ConfigError>([&] { Analyze(table, options); });
  EXPECT_EQ(text, "synthetic: unknown joint 2: this file has 1 joints (1 to 1)");
}

// The paper's plans return the arm to zero, then make the measured move: --last-move keeps only
// that one per movement set.
TEST(ReportNumbers, LastMoveOnlyKeepsEachSetsFinalMove) {
  RunTable table;
  table.source = "synthetic";
  table.label = "synthetic";
  table.Reset({{"waist", false}});
  for (int i = 0; i <= 4000; ++i) {
    const double t = i * 1e-3;
    const double q = t < 2.5 ? Ramp(t) : 90.0 - std::clamp(90.0 * (t - 2.5), 0.0, 90.0);
    for (size_t s = 0; s < 2; ++s) table.position[0][s].push_back(q);
    table.position[0][kReal].push_back(NAN);
    table.time_s.push_back(t);
    table.move_id.push_back(t < 0.5 ? 1 : t < 2.5 ? 2 : 3);
    table.done[0].push_back(-1);
  }
  table.cells = {4001, 4001, 0};
  AnalysisOptions options;
  const Analysis all = Analyze(table, options);
  ASSERT_EQ(all.moves.size(), 2u);
  EXPECT_EQ(all.moves[0].move_id, 2);
  options.last_move_only = true;
  const MoveResult last = OnlyMove(Analyze(table, options));
  EXPECT_EQ(last.move_id, 3);
  EXPECT_DOUBLE_EQ(last.from, 90.0);
  EXPECT_DOUBLE_EQ(last.to, 0.0);
  EXPECT_EQ(last.end, table.rows());
}
TEST(ReportOutput, MarkdownCsvAndPlots) {
  TempDir dir;
  const std::vector<RunTable> tables = {Synthetic(
      Ramp, [](double t) { return Ramp(t - 0.1); }, None, 1.5)};
  ReportOptions options;
  options.out_dir = dir.path.string();
  const ReportOutput output = WriteReport(tables, options);
  EXPECT_EQ(output.moves, 1u);
  EXPECT_NE(output.markdown.find("| synthetic | 2 | 1 (waist) | from 0.0 to 90.0 deg | set-point "
                                 "vs virtual | 7.19 | 0.00 | 5.90 | 9.00 |"),
            std::string::npos)
      << output.markdown;
  EXPECT_NE(output.markdown.find("|  |  |  |  | set-point vs real | - | - | - | - |"),
            std::string::npos);
  std::ifstream csv(dir / "report_errors.csv");
  std::string header, row;
  std::getline(csv, header);
  std::getline(csv, row);
  EXPECT_EQ(row.substr(0, 48), "synthetic,synthetic,2,1,waist,deg,0.00000,90.000");
  const cv::Mat angle = cv::imread(dir / "synthetic-m2-j1-angle.png");
  const cv::Mat error = cv::imread(dir / "synthetic-m2-j1-error.png");
  ASSERT_FALSE(angle.empty());
  ASSERT_FALSE(error.empty());
  EXPECT_EQ(angle.cols, 1000);
  EXPECT_EQ(angle.rows, 560);
}

// ---- LCM log files
// ---------------------------------------------------------------------------------

template <class Msg>
void WriteEvent(lcm_eventlog_t* log, const std::string& channel, const Msg& message,
                int64_t timestamp) {
  std::vector<uint8_t> data(static_cast<size_t>(message.getEncodedSize()));
  message.encode(data.data(), 0, static_cast<int>(data.size()));
  lcm_eventlog_event_t event{};
  event.timestamp = timestamp;
  event.channellen = static_cast<int32_t>(channel.size());
  event.datalen = static_cast<int32_t>(data.size());
  event.channel = const_cast<char*>(channel.c_str());
  event.data = data.data();
  ASSERT_EQ(lcm_eventlog_write_event(log, &event), 0);
}

sirupp::arm_state_t State(int64_t tick, double q1_deg) {
  sirupp::arm_state_t state{};
  state.utime = tick * 512;
  state.seq = tick;
  state.tick = tick;
  state.num_joints = 2;
  state.position = {q1_deg * kDeg, 0};
  state.velocity = {0, 0};
  state.effort = {0, 0};
  state.flags = {0, 0};
  return state;
}

sirupp::servo_setpoint_t SetpointAt(int64_t tick, int64_t move, double q1_deg, bool done) {
  sirupp::servo_setpoint_t setpoint{};
  setpoint.utime = tick * 512;
  setpoint.seq = tick;
  setpoint.tick = tick;
  setpoint.move_id = move;
  setpoint.num_joints = 2;
  setpoint.position = {q1_deg * kDeg, 0};
  setpoint.velocity = {0, 0};
  setpoint.goal = {0, 0};
  setpoint.position_error = {0, 0};
  setpoint.effort = {0, 0};
  const int8_t status = done ? sirupp::servo_setpoint_t::STATUS_MOVE_DONE : 0;
  setpoint.status = {status, status};
  return setpoint;
}

// A two-joint log: a plan starts at tick 100; its move (id 1) ramps joint 1 from 0 to 45 deg over
// ticks 200..1199; the arm follows 10 ticks late.
void WriteRampLog(const std::string& path, int64_t ticks = 3000) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  auto ramp = [](int64_t tick) {
    return 45.0 * std::clamp(static_cast<double>(tick - 200) / 1000.0, 0.0, 1.0);
  };
  for (int64_t tick = 0; tick < ticks; ++tick) {
    const int64_t wall = 1'700'000'000'000'000 + tick * 600;
    if (tick == 100) {
      sirupp::controller_status_t status{};
      status.utime = tick * 512;
      status.plan_name = "plans/ramp.plan";
      status.plan_step = 0;
      status.plan_steps = 3;
      WriteEvent(log, "CONTROLLER_STATUS", status, wall);
    }
    WriteEvent(log, "SIM_ARM_STATE", State(tick, ramp(tick - 10)), wall);
    WriteEvent(log, "ARM_SETPOINT",
               SetpointAt(tick, tick >= 200 ? 1 : 0, ramp(tick), tick < 200 || tick >= 1200),
               wall + 50);
  }
  lcm_eventlog_destroy(log);
}

TEST(LcmLog, IsReadLikeADataFileOneTablePerPlanRun) {
  TempDir dir;
  WriteRampLog(dir / "ramp.lcm");
  const std::vector<RunTable> tables = ImportLcmLog(dir / "ramp.lcm", ImportOptions{});
  ASSERT_EQ(tables.size(), 2u);
  EXPECT_EQ(tables[0].label, "ramp");  // before the plan: the file's name
  EXPECT_EQ(tables[1].label, "ramp");  // the plan plans/ramp.plan
  EXPECT_EQ(tables[1].plan_name, "plans/ramp.plan");
  EXPECT_EQ(tables[0].rows(), 100u);
  EXPECT_EQ(tables[1].rows(), 2900u);
  EXPECT_EQ(tables[1].cells[kSet], 2900);
  EXPECT_EQ(tables[1].lost[kSet], 0);
  const MoveResult move = OnlyMove(Analyze(tables[1], AnalysisOptions{}));
  EXPECT_NEAR(move.to, 45.0, 1e-5);
  // 10 ticks behind a ramp of 45 deg per 1000 ticks: 0.45 deg.
  EXPECT_NEAR(move.pairs[0].max, 0.45, 1e-4);
  EXPECT_NEAR(move.streams[kVirt].start_delay_s - move.streams[kSet].start_delay_s, 10 * 512e-6,
              1e-9);
}

TEST(LcmLog, ACutLastEventIsANoteAndDamageInsideIsAnError) {
  TempDir dir;
  WriteRampLog(dir / "cut.lcm", 500);
  const auto size = std::filesystem::file_size(dir / "cut.lcm");
  std::filesystem::resize_file(dir / "cut.lcm", size - 7);
  const std::vector<RunTable> tables = ImportLcmLog(dir / "cut.lcm", ImportOptions{});
  ASSERT_FALSE(tables.empty());
  ASSERT_EQ(tables.back().notes.size(), 1u);
  EXPECT_NE(tables.back().notes[0].find("the last event is cut short"), std::string::npos);

  WriteRampLog(dir / "damaged.lcm", 500);
  {
    std::fstream file(dir / "damaged.lcm", std::ios::in | std::ios::out | std::ios::binary);
    LcmLogReader reader(dir / "damaged.lcm");
    LcmLogEvent event;
    for (int i = 0; i < 40; ++i) reader.Next(event);
    file.seekp(event.offset);
    file.write("JUNK", 4);
  }
  const std::string text = sirupp::testing::ErrorText<core::ConfigError>(
      [&] { ImportLcmLog(dir / "damaged.lcm", ImportOptions{}); });
  EXPECT_NE(text.find("damaged.lcm: byte "), std::string::npos) << text;
  EXPECT_NE(text.find("expected the event sync word 0xEDA1DA01, found 0x4A554E4B: the log is "
                      "corrupted here"),
            std::string::npos)
      << text;
}

// ---- The malformed-input corpus
// ------------------------------------------------------------------

TEST(BadLogs, EachFileFailsWithItsMessage) {
  const std::string corpus = "tests/data/bad_logs";
  std::ifstream expected_file(corpus + "/expected.txt");
  ASSERT_TRUE(expected_file.good());
  std::string line;
  int checked = 0;
  std::vector<std::string> listed;
  while (std::getline(expected_file, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.find(' ');
    ASSERT_NE(space, std::string::npos) << line;
    const std::string name = line.substr(0, space);
    std::string message = line.substr(space + 1);
    ASSERT_EQ(message.rfind("FILE", 0), 0u) << line;
    const std::string path = corpus + "/" + name;
    message = path + message.substr(4);
    listed.push_back(name);
    SCOPED_TRACE(path);
    const std::string text =
        sirupp::testing::ErrorText<core::ConfigError>([&] { ReadInputs({path}, ImportOptions{}); });
    EXPECT_EQ(text, message);
    ++checked;
  }
  EXPECT_GE(checked, 20);
  for (const auto& entry : std::filesystem::directory_iterator(corpus)) {
    const std::string name = entry.path().filename().string();
    if (name == "expected.txt" || name == "README.md") continue;
    EXPECT_NE(std::find(listed.begin(), listed.end(), name), listed.end())
        << name << " has no line in expected.txt";
  }
}

// ---- Slipped sim time --------------------------------------------------------------------------

// A move of joint 1 from 0 to 45 deg, smooth, over 1 s from its start.
double Profile(double tau) {
  if (tau <= 0) return 0.0;
  if (tau >= 1) return 45.0;
  return 22.5 * (1 - std::cos(3.14159265358979323846 * tau));
}
double Virtual(double tau) { return Profile(tau - 0.02); }
double RealArm(double tau) { return Profile(tau - 0.05) + 0.1; }

// The data a logger records when the sim runs at `factor` times the wall clock: rows every
// 0.512 ms of sim time, the move from the tick at sim time 0.500224 s (move_id 1 -> 2) for 2 s; the
// set-point and the virtual arm on the rows; a real arm polled every 10 ms of wall clock, moving on
// the wall clock from the move's start, placed on the sim axis where the sim was when it was taken
// (row time minus age).
RunTable Slipped(double factor) {
  RunTable table;
  table.source = "slipped";
  table.label = "slipped";
  table.Reset({{"waist", false}});
  const double start = 977 * 512e-6;  // a row: the tick the controller loaded the move
  size_t next_poll = 0;
  double held = NAN, held_at = NAN;
  for (int i = 0; i * 512e-6 <= start + 2.0 + 1e-9; ++i) {
    const double t = i * 512e-6;
    const double tau = t - start;  // sim time since the move's start
    table.time_s.push_back(t);
    table.move_id.push_back(t < start - 1e-9 ? 1 : 2);
    table.position[0][kSet].push_back(Profile(tau));
    table.position[0][kVirt].push_back(Virtual(tau));
    table.done[0].push_back(tau >= 1.0 - 1e-9 || t < start - 1e-9 ? 1 : 0);
    // Polls up to this row: wall time since the move's start is (sim time since it) / factor.
    while (start + 0.01 * static_cast<double>(next_poll) * factor <= t + 1e-12) {
      held_at = start + 0.01 * static_cast<double>(next_poll) * factor;
      held = RealArm(0.01 * static_cast<double>(next_poll));
      ++next_poll;
    }
    table.position[0][kReal].push_back(held);
    for (size_t s = 0; s < 3; ++s) table.age_s[s].push_back(0.0);
    table.age_s[kReal].back() = std::isnan(held) ? NAN : t - held_at;
  }
  for (size_t s = 0; s < 3; ++s) {
    table.cells[s] = std::count_if(table.position[0][s].begin(), table.position[0][s].end(),
                                   [](double v) { return !std::isnan(v); });
  }
  table.realtime_factor = factor;
  return table;
}

void ExpectSameErrors(const MoveResult& a, const MoveResult& b, double tolerance) {
  for (Pair pair : kAllPairs) {
    SCOPED_TRACE(PairTitle(pair));
    const PairMetrics& x = a.pairs[static_cast<size_t>(pair)];
    const PairMetrics& y = b.pairs[static_cast<size_t>(pair)];
    EXPECT_NEAR(x.mean_transient, y.mean_transient, tolerance);
    EXPECT_NEAR(x.mean_steady, y.mean_steady, tolerance);
    EXPECT_NEAR(x.rms, y.rms, tolerance);
    EXPECT_NEAR(x.max, y.max, tolerance);
  }
  const StreamResponse& x = a.streams[kReal];
  const StreamResponse& y = b.streams[kReal];
  EXPECT_NEAR(x.start_delay_s, y.start_delay_s, 1e-3);
  EXPECT_NEAR(x.settling_s, y.settling_s, 1e-3);
  EXPECT_NEAR(x.final_error, y.final_error, tolerance);
}

// Virtual and real are compared per move from each move's own start, each on its own clock: a sim
// running at half the wall clock's pace gives the same Table II as one keeping pace.
TEST(SlippedSimTime, ASimAtHalfSpeedGivesTheErrorsOfOneAtFullSpeed) {
  const RunTable full = Slipped(1.0);
  const RunTable half = Slipped(0.5);
  const MoveResult at_full = OnlyMove(Analyze(full, AnalysisOptions{}));
  const MoveResult at_half = OnlyMove(Analyze(half, AnalysisOptions{}));
  ExpectSameErrors(at_full, at_half, 1e-9);
  // The errors are the arm's: 0.1 deg of offset, and 30 ms of lag behind the virtual arm at its
  // top speed of 22.5 pi deg/s (the error is negative then).
  const PairMetrics& virt_real = at_half.pairs[static_cast<size_t>(Pair::kVirtReal)];
  EXPECT_NEAR(virt_real.mean_steady, 0.1, 1e-6);
  EXPECT_NEAR(virt_real.max, 22.5 * 3.14159265358979323846 * 0.03 - 0.1, 0.01);
  EXPECT_EQ(virt_real.transient_samples + virt_real.steady_samples,
            at_full.pairs[static_cast<size_t>(Pair::kVirtReal)].transient_samples +
                at_full.pairs[static_cast<size_t>(Pair::kVirtReal)].steady_samples);
  EXPECT_NEAR(at_half.streams[kReal].start_delay_s, at_full.streams[kReal].start_delay_s, 1e-9);
  // Compared on the sim-time axis instead (no factor known), the slip shows as a large error.
  RunTable unknown = half;
  unknown.realtime_factor = NAN;
  const MoveResult naive = OnlyMove(Analyze(unknown, AnalysisOptions{}));
  EXPECT_GT(naive.pairs[static_cast<size_t>(Pair::kVirtReal)].max, 10.0);
  // A real arm on the sim clock (a second sim) is never rescaled.
  unknown.realtime_factor = 0.5;
  unknown.real_on_sim_clock = true;
  EXPECT_DOUBLE_EQ(unknown.RealClockScale(), 1.0);
}

// The same through the logger's path: LCM logs of a run at 1.0x and at 0.5x (the sim's states
// stamped on sim time and received on the wall clock, the real arm stamped on the wall clock),
// aligned by the aligner, which follows the slipping sim clock, with the real-time factor taken
// from the log; the report prints it.
// `wall_s_of_sim`: the wall clock (s since sim time 0) when the sim was at a time; `virtual_arm`:
// the virtual arm's joint 1 (deg) at a sim time since the move's start; `real_arm`: the real arm's
// at a wall time since the move's start.
void WriteSlippedLog(const std::string& path, const std::function<double(double)>& wall_s_of_sim,
                     const std::function<double(double)>& virtual_arm,
                     const std::function<double(double)>& real_arm, double start) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  const int64_t wall0 = 1'700'000'000'000'000;
  const auto wall_of_sim = [&](double sim_s) {
    return wall0 + static_cast<int64_t>(std::llround(wall_s_of_sim(sim_s) * 1e6));
  };
  const double wall_start = (wall_of_sim(start) - wall0) * 1e-6;
  const int64_t ticks = static_cast<int64_t>(std::llround((start + 2.0) / 512e-6));
  int64_t poll = 0;
  for (int64_t tick = 0; tick <= ticks; ++tick) {
    const double sim = static_cast<double>(tick) * 512e-6;
    const int64_t wall = wall_of_sim(sim);
    // The real arm's polls up to now (wall clock), each received 2 ms after it was taken.
    while (wall0 + poll * 10000 <= wall) {
      const int64_t taken = wall0 + poll * 10000;
      sirupp::arm_state_t real = State(poll, real_arm((taken - wall0) * 1e-6 - wall_start));
      real.utime = taken;
      real.source = sirupp::arm_state_t::SOURCE_EMULATED;
      WriteEvent(log, "REAL_ARM_STATE", real, taken + 2000);
      ++poll;
    }
    const double tau = sim - start;
    const int64_t move = sim < start - 1e-9 ? 1 : 2;
    WriteEvent(log, "SIM_ARM_STATE", State(tick, virtual_arm(tau)), wall + 1000);
    WriteEvent(log, "ARM_SETPOINT",
               SetpointAt(tick, move, Profile(tau), move == 1 || tau >= 1.0 - 1e-9), wall + 1000);
  }
  lcm_eventlog_destroy(log);
}
void WriteSlippedLog(const std::string& path, double factor) {
  WriteSlippedLog(
      path, [factor](double sim_s) { return sim_s / factor; }, Virtual, RealArm, 2930 * 512e-6);
}

TEST(SlippedSimTime, TheLoggersPathGivesTheSameErrorsAndPrintsTheFactor) {
  TempDir dir;
  WriteSlippedLog(dir / "full.lcm", 1.0);
  WriteSlippedLog(dir / "half.lcm", 0.5);
  const std::vector<RunTable> full = ImportLcmLog(dir / "full.lcm", ImportOptions{});
  const std::vector<RunTable> half = ImportLcmLog(dir / "half.lcm", ImportOptions{});
  ASSERT_EQ(full.size(), 1u);
  ASSERT_EQ(half.size(), 1u);
  EXPECT_NEAR(full[0].realtime_factor, 1.0, 1e-3);
  EXPECT_NEAR(half[0].realtime_factor, 0.5, 1e-3);
  const MoveResult at_full = OnlyMove(Analyze(full[0], AnalysisOptions{}));
  const MoveResult at_half = OnlyMove(Analyze(half[0], AnalysisOptions{}));
  ExpectSameErrors(at_full, at_half, 2e-3);
  EXPECT_NEAR(at_half.pairs[static_cast<size_t>(Pair::kVirtReal)].mean_steady, 0.1, 1e-3);
  ReportOptions options;
  options.out_dir = dir / "report";
  options.plots = false;
  const ReportOutput output = WriteReport(half, options);
  EXPECT_NE(output.markdown.find("| closed | real-time factor |"), std::string::npos);
  EXPECT_NE(output.markdown.find("| yes | 0.500 |"), std::string::npos) << output.markdown;
}

// ---- A sim that slips unevenly within a move
// -----------------------------------------------------

// The sim's pace against the wall clock changes in the middle of the move: 0.4 until 0.5 s of wall
// clock after the move's start, 1.0 after it (a loaded machine whose load went away).
constexpr double kUnevenStart = 977 * 512e-6;  // sim time of the move's start: a tick
constexpr double kSlowPace = 0.4;
constexpr double kSlowWallAfterStart = 0.5;        // wall seconds at the slow pace after the start
constexpr int64_t kWall0 = 1'700'000'000'000'000;  // the wall clock (us) at sim time 0
// Wall seconds since sim time 0 when the sim was at sim_s.
double UnevenWall(double sim_s) {
  const double change = kUnevenStart + kSlowWallAfterStart * kSlowPace;  // sim time of the change
  return sim_s <= change ? sim_s / kSlowPace : change / kSlowPace + (sim_s - change);
}
double UnevenSim(double wall_s) {
  const double change_wall = kUnevenStart / kSlowPace + kSlowWallAfterStart;
  return wall_s <= change_wall ? wall_s * kSlowPace
                               : change_wall * kSlowPace + (wall_s - change_wall);
}

// What a logger records: rows every 0.512 ms of sim time from 0 to 2 s after the move's start;
// the set-point and the virtual arm (which follows it exactly) on the rows; a real arm polled every
// 10 ms of wall clock that follows the set-point exactly on its own clock (the same profile, in
// wall time since the move's start), each sample placed on the axis where the sim was when it was
// taken, with its wall-clock stamp (real_clock_us), and each set-point with the wall clock when it
// was received (set_recv_us); the file's one real-time factor. `misplaced_s`: the logger's
// estimate of the sim clock, by which it placed the real samples on the axis, runs this far ahead.
RunTable UnevenlySlipped(double misplaced_s = 0) {
  RunTable table;
  table.source = "uneven";
  table.label = "uneven";
  table.Reset({{"waist", false}});
  const double wall_start = UnevenWall(kUnevenStart);
  int64_t next_poll = 0;
  double held = NAN;
  int64_t held_axis_us = 0, held_stamp = kNoClock;
  for (int64_t i = 0; static_cast<double>(i) * 512e-6 <= kUnevenStart + 2.0 + 1e-9; ++i) {
    const int64_t row_us = i * 512;
    const double t = static_cast<double>(row_us) * 1e-6;
    const double tau = t - kUnevenStart;
    table.time_s.push_back(t);
    table.move_id.push_back(tau < -1e-9 ? 1 : 2);
    table.position[0][kSet].push_back(Profile(tau));
    table.position[0][kVirt].push_back(Profile(tau));
    table.done[0].push_back(tau >= 1.0 - 1e-9 || tau < -1e-9 ? 1 : 0);
    while (true) {  // the polls taken up to this row's sim time
      const double wall = 0.01 * static_cast<double>(next_poll);
      const int64_t axis_us = std::llround(UnevenSim(wall + misplaced_s) * 1e6);
      if (axis_us > row_us) break;
      held = Profile(wall - wall_start);
      held_axis_us = axis_us;
      held_stamp = kWall0 + std::llround(wall * 1e6);
      ++next_poll;
    }
    table.position[0][kReal].push_back(held);
    for (size_t s = 0; s < 3; ++s) table.age_s[s].push_back(0.0);
    table.age_s[kReal].back() =
        std::isnan(held) ? NAN : static_cast<double>(row_us - held_axis_us) * 1e-6;
    table.real_clock_us.push_back(std::isnan(held) ? kNoClock : held_stamp);
    table.set_recv_us.push_back(kWall0 + std::llround(UnevenWall(t) * 1e6));
  }
  for (size_t s = 0; s < 3; ++s) {
    table.cells[s] = std::count_if(table.position[0][s].begin(), table.position[0][s].end(),
                                   [](double v) { return !std::isnan(v); });
  }
  table.realtime_factor = (kUnevenStart + 2.0) / UnevenWall(kUnevenStart + 2.0);
  return table;
}

// The real arm and the set-point (and the virtual arm) on their own clocks agree exactly.
void ExpectExactAgreement(const MoveResult& move, double tolerance) {
  for (Pair pair : {Pair::kSetReal, Pair::kVirtReal}) {
    SCOPED_TRACE(PairTitle(pair));
    const PairMetrics& m = move.pairs[static_cast<size_t>(pair)];
    EXPECT_GT(m.transient_samples, 50);
    EXPECT_LT(m.mean_transient, tolerance);
    EXPECT_LT(m.max, tolerance);
  }
  // Started and settled when the set-point did, within a poll (10 ms of wall clock).
  EXPECT_NEAR(move.streams[kReal].start_delay_s, move.streams[kSet].start_delay_s, 0.0101);
  EXPECT_NEAR(move.streams[kReal].settling_s, move.streams[kSet].settling_s, 0.0101);
}

// The sim slips at 0.4 of the wall clock, then keeps pace, within one move: with each real sample's
// stamp the real arm, which follows the set-point exactly on its own clock, shows no error; with
// the file's one real-time factor (all a format 1 file has) it shows one of many degrees, and the
// start delay and settling time are wrong.
TEST(UnevenSlip, TheRealArmsStampsGiveNoErrorWhereTheFilesOneFactorGivesDegrees) {
  const RunTable table = UnevenlySlipped();
  ASSERT_GT(table.realtime_factor, 0.6);
  ASSERT_LT(table.realtime_factor, 0.8);
  const MoveResult stamped = OnlyMove(Analyze(table, AnalysisOptions{}));
  ExpectExactAgreement(stamped, 0.02);

  // The logger's estimate of the sim clock (by which it placed the real samples on the axis) 0.1 s
  // off at the move's start, as a sim running in bursts made it in a loaded demo: the set-point's
  // receive time there still gives the real arm's clock at the start; without it (and only
  // then) the estimate's error shows.
  RunTable misplaced = UnevenlySlipped(0.1);
  ExpectExactAgreement(OnlyMove(Analyze(misplaced, AnalysisOptions{})), 0.02);
  misplaced.set_recv_us.clear();
  EXPECT_GT(OnlyMove(Analyze(misplaced, AnalysisOptions{}))
                .pairs[static_cast<size_t>(Pair::kVirtReal)]
                .max,
            1.0);

  RunTable unstamped = table;
  unstamped.real_clock_us.clear();
  const MoveResult by_factor = OnlyMove(Analyze(unstamped, AnalysisOptions{}));
  const PairMetrics& virt_real = by_factor.pairs[static_cast<size_t>(Pair::kVirtReal)];
  EXPECT_GT(virt_real.max, 5.0);
  EXPECT_GT(virt_real.mean_transient, 2.0);
  // The real arm starts (0.5 deg) 67 ms after the move's start on its own clock, as the set-point;
  // by the factor, 0.4 * 67 ms of sim time / 0.70 = 38 ms.
  EXPECT_LT(by_factor.streams[kReal].start_delay_s, 0.7 * by_factor.streams[kSet].start_delay_s);
  // Counted from the file's first row instead of the move's start (the first set-point is received
  // with the first real sample).
  const std::vector<double> times = table.RealSampleTimes(0, 0, table.rows());
  const std::vector<double> factor_times = unstamped.RealSampleTimes(0, 0, table.rows());
  ASSERT_EQ(times.size(), table.rows());
  EXPECT_TRUE(std::isnan(times[0]) == std::isnan(table.position[0][kReal][0]));
  const size_t last = table.rows() - 1;
  // From the file's first row, 2.5 s of sim time span 3.55 s of wall clock: the stamps say so.
  EXPECT_NEAR(times[last] - table.time_s[0], UnevenWall(table.time_s[last]), 0.0101);
  EXPECT_NEAR(factor_times[last] - table.time_s[0],
              (table.time_s[last] - table.Age(Stream::kReal, last)) / table.realtime_factor, 1e-9);
}

// The same through the logger's path: an LCM log of that run (the sim stamped on sim time and
// received on the wall clock, the real arm stamped on the wall clock), aligned by the aligner into
// a table with the stamps, and that table written to a data file and read back: no error. The
// same file without its real_clock_us column (format 1) is still read, with the file's factor.
TEST(UnevenSlip, TheLoggersPathKeepsTheStampsAndAFormatOneFileFallsBackToTheFactor) {
  TempDir dir;
  WriteSlippedLog(dir / "uneven.lcm", UnevenWall, Profile, Profile, kUnevenStart);
  const std::vector<RunTable> tables = ImportLcmLog(dir / "uneven.lcm", ImportOptions{});
  ASSERT_EQ(tables.size(), 1u);
  const RunTable& imported = tables[0];
  ASSERT_EQ(imported.real_clock_us.size(), imported.rows());
  const MoveResult from_log = OnlyMove(Analyze(imported, AnalysisOptions{}));
  // The sim samples arrived 1 ms after they were stamped: the anchor is off by that, 0.07 deg at
  // the profile's top speed.
  ExpectExactAgreement(from_log, 0.1);

  // Written as the logger writes it, and read back.
  const std::string path = dir / "uneven.csv";
  {
    ColumnLayout layout;
    layout.joints = imported.joints;
    std::string joints = "joints: " + std::to_string(layout.joints.size()) + ":";
    for (size_t j = 0; j < layout.joints.size(); ++j) {
      const std::string& name = layout.joints[j].name;
      joints += (j ? "; j" : " j") + std::to_string(j + 1) + " " + (name.empty() ? "joint" : name) +
                " deg";
    }
    DataFileWriter writer(path, {joints, "plan: set1.plan"}, layout);
    for (size_t i = 0; i < imported.rows(); ++i) {
      std::array<Sample, kNumStreams> samples;
      Row row;
      row.time_us = std::llround(imported.time_s[i] * 1e6);
      for (size_t s = 0; s < kNumStreams; ++s) {
        if (std::isnan(imported.position[0][s][i])) continue;
        for (size_t j = 0; j < layout.joints.size(); ++j) {
          samples[s].position.push_back(imported.position[j][s][i] * kDeg);
        }
        samples[s].move_id = imported.move_id[i];
        samples[s].done = {imported.done[0][i]};
        row.cell[s] = &samples[s];
        row.age_us[s] = std::llround(imported.age_s[s][i] * 1e6);
      }
      samples[kReal].utime = imported.real_clock_us[i];
      samples[kSet].recv_utime = imported.set_recv_us[i] == kNoClock ? 0 : imported.set_recv_us[i];
      writer.Append(row);
    }
    writer.AppendComment("real-time factor: " + std::to_string(imported.realtime_factor) +
                         " (sim and wall), this file");
    writer.Close(std::to_string(imported.rows()) + " rows");
  }
  const RunTable read = ReadDataFile(path);
  ASSERT_EQ(read.real_clock_us, imported.real_clock_us);
  ASSERT_EQ(read.set_recv_us, imported.set_recv_us);
  ExpectExactAgreement(OnlyMove(Analyze(read, AnalysisOptions{})), 0.1);

  // The same file as format 1: without the two columns, and with the older magic line.
  std::ifstream in(path);
  std::string line, text;
  while (std::getline(in, line)) {
    if (line.rfind(kFileMagic, 0) == 0) {
      line.replace(0, std::string(kFileMagic).size(), kFileMagicFormat1);
    } else if (!line.empty() && line[0] != '#') {
      line.erase(line.rfind(','));  // set_recv_us and real_clock_us are the last columns
      line.erase(line.rfind(','));
    }
    text += line + "\n";
  }
  in.close();
  ASSERT_EQ(text.find("real_clock_us"), std::string::npos);
  ASSERT_EQ(text.find("set_recv_us"), std::string::npos);
  const std::string old_path = dir / "uneven-format1.csv";
  std::ofstream(old_path) << text;
  const RunTable old = ReadDataFile(old_path);
  EXPECT_TRUE(old.real_clock_us.empty());
  EXPECT_TRUE(old.set_recv_us.empty());
  EXPECT_NEAR(old.realtime_factor, imported.realtime_factor, 1e-5);
  const MoveResult by_factor = OnlyMove(Analyze(old, AnalysisOptions{}));
  RunTable unstamped = read;
  unstamped.real_clock_us.clear();
  ExpectSameErrors(by_factor, OnlyMove(Analyze(unstamped, AnalysisOptions{})), 1e-9);
  EXPECT_GT(by_factor.pairs[static_cast<size_t>(Pair::kVirtReal)].max, 5.0);
  // The report says how the real arm was timed.
  ReportOptions options;
  options.out_dir = dir / "report";
  options.plots = false;
  EXPECT_NE(WriteReport({read}, options).markdown.find("| own stamps |"), std::string::npos);
  EXPECT_NE(WriteReport({old}, options).markdown.find("| file's factor |"), std::string::npos);
}

// ---- The paper's set VII, closed loop
// ------------------------------------------------------------

TEST(ReportOfASimRun, SetSevenInLockstepLoggedAndReported) {
  TempDir dir;
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Bus bus("memq://");
  sim::ArmWorld world(model, core::Environment{});
  sim::SimNode sim(bus, world, core::Environment{}, sim::NodeOptions{});
  control::ControlNode control(bus, model, control::ControlOptions{});
  LoggerOptions options;
  options.out_dir = dir.path.string();
  options.name = "run";
  LoggerNode logger(bus, model, options);
  auto run_for = [&](double seconds) {
    const double until = world.time_s() + seconds;
    while (world.time_s() < until) sim.Service(0);
  };
  run_for(0.05);
  const std::string plan = "config/plans/set7.plan";
  sirupp::plan_command_t command{};
  command.command = sirupp::plan_command_t::COMMAND_RUN;
  command.name = plan;
  command.text = control::ReadPlanText(plan);
  bus.Publish("ARM_PLAN", command);
  run_for(0.05);
  ASSERT_TRUE(control.plan_running()) << control.last_error();
  for (int i = 0; i < 2000 && control.plan_running(); ++i) run_for(0.01);
  ASSERT_FALSE(control.plan_running());
  run_for(0.2);
  logger.Close();
  const LoggerStats stats = logger.stats();
  ASSERT_EQ(stats.files.size(), 2u);
  EXPECT_EQ(stats.files[1], dir / "run-02-set7.csv");
  EXPECT_EQ(stats.lost[kSet] + stats.lost[kVirt], 0);
  EXPECT_GE(stats.samples[kVirt], world.tick());

  ReportOptions report;
  report.out_dir = dir / "report";
  const ReportOutput output = WriteReport(ReadInputs({stats.files[1]}, ImportOptions{}), report);
  std::cout << output.markdown;
  ASSERT_EQ(output.moves, 3u);  // joints 1, 2 and 3 travel 90 deg in the plan's second move
  const RunTable table = ReadDataFile(stats.files[1]);
  const Analysis analysis = Analyze(table, AnalysisOptions{});
  for (const MoveResult& move : analysis.moves) {
    SCOPED_TRACE("joint " + std::to_string(move.joint));
    EXPECT_NEAR(move.from, 0.0, 0.01);
    EXPECT_NEAR(move.to, 90.0, 0.01);
    const PairMetrics& m = move.pairs[static_cast<size_t>(Pair::kSetVirt)];
    EXPECT_GT(m.mean_transient, m.mean_steady);  // the arm lags while moving, then settles
    EXPECT_LT(m.mean_steady, 1.0);
    EXPECT_GT(m.steady_samples, 500);
    EXPECT_FALSE(move.pairs[static_cast<size_t>(Pair::kVirtReal)].has());  // no real arm
    EXPECT_GT(move.streams[kVirt].start_delay_s, move.streams[kSet].start_delay_s);
    EXPECT_LT(std::abs(move.streams[kVirt].final_error), 1.0);
    EXPECT_FALSE(
        cv::imread(dir / ("report/set7-m2-j" + std::to_string(move.joint) + "-angle.png")).empty());
  }
}

}  // namespace
}  // namespace sirupp::logger
