// The logger library: alignment of the three streams on the sample clock (logger/aligner.hpp), the
// data file written and read back (logger/data_file.hpp), sirupp-logger's logic on an in-process
// memq:// bus (one file per movement set, real-arm samples placed by the sim clock's offset, gaps
// counted), and a kill -9 during logging that leaves a parseable file missing at most 100 ms.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sstream>
#include <thread>

#include "core/bus.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "logger/aligner.hpp"
#include "logger/data_file.hpp"
#include "logger/logger_node.hpp"
#include "logger/raw_settings.hpp"
#include "logger/report.hpp"
#include "tests/helpers.hpp"

namespace sirupp::logger {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr int kJoints = 6;

// A fresh directory under the system temp dir, removed at the end of the test.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char pattern[] = "/tmp/sirupp_logger_test_XXXXXX";
    path = mkdtemp(pattern);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

Sample SimSample(Stream stream, int64_t tick, double q1_deg, int64_t lost = 0) {
  Sample sample;
  sample.stream = stream;
  sample.clock = SampleClock::kSim;
  sample.utime = tick * 512;
  sample.recv_utime = 1'000'000'000 + tick * 512;  // received at once, on a wall clock
  sample.lost_before = lost;
  sample.position.assign(kJoints, 0.0);
  sample.position[0] = q1_deg * kDeg;
  if (stream == Stream::kSetpoint) {
    sample.move_id = 1;
    sample.done.assign(kJoints, 1);
  }
  return sample;
}

std::vector<Row> Collect(Aligner& aligner, int64_t now, bool final_flush,
                         std::vector<std::vector<double>>* q1 = nullptr) {
  std::vector<Row> rows;
  aligner.TakeRows(now, final_flush, [&](const Row& row) {
    rows.push_back(row);
    if (q1 != nullptr) {
      std::vector<double> cells;
      for (const Sample* cell : row.cell) cells.push_back(cell ? cell->position[0] / kDeg : NAN);
      q1->push_back(cells);
    }
  });
  return rows;
}

TEST(Aligner, PutsTheStreamsOnTheServoTickAndWaitsForTheSlowestLiveStream) {
  AlignerOptions options;
  options.join_window_us = 0;  // no wait for a plan status at the start (tested below)
  options.status_hold_us = 0;  // rows as soon as every live stream has them (tested below)
  Aligner aligner(options);
  for (int64_t tick = 0; tick < 10; ++tick) {
    aligner.Add(SimSample(Stream::kVirtual, tick, static_cast<double>(tick)));
    if (tick < 6)
      aligner.Add(SimSample(Stream::kSetpoint, tick, 100.0 + static_cast<double>(tick)));
  }
  // Both streams are live (just heard): rows only up to the set-point's newest tick.
  const int64_t now = 1'000'000'000 + 10 * 512;
  std::vector<std::vector<double>> q1;
  std::vector<Row> rows = Collect(aligner, now, false, &q1);
  ASSERT_EQ(rows.size(), 6u);
  for (size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].time_us, static_cast<int64_t>(i) * 512);
    EXPECT_DOUBLE_EQ(q1[i][1], static_cast<double>(i));          // virtual
    EXPECT_DOUBLE_EQ(q1[i][0], 100.0 + static_cast<double>(i));  // set-point
    EXPECT_TRUE(std::isnan(q1[i][2]));                           // no real arm: empty
  }
  // 60 ms later the set-point counts as silent: the virtual rows go out, set-point cells empty
  // once its last sample is older than max_age (25 ms) -- here it is not yet.
  q1.clear();
  rows = Collect(aligner, now + 60'000, false, &q1);
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_DOUBLE_EQ(q1[3][1], 9.0);
  EXPECT_DOUBLE_EQ(q1[3][0], 105.0);  // 2 ms old: still the newest set-point
}

// A plan's status handled after the plan's first set-points (they come by the tick feed's socket,
// the status by LCM's) still starts the plan's run at its own time: while the streams are live,
// rows stay status_hold_us of the axis behind. With no hold, the rows past the plan's start had
// already gone out in the run before.
TEST(Aligner, APlanStatusHandledAfterItsFirstSetPointsStillStartsItsRunThere) {
  auto plan_run_at_start = [](int64_t hold_us) {
    AlignerOptions options;
    options.join_window_us = 0;
    options.status_hold_us = hold_us;
    Aligner aligner(options);
    std::vector<Row> rows;
    auto take = [&](int64_t tick, bool final_flush) {
      const std::vector<Row> some = Collect(aligner, 1'000'000'000 + tick * 512, final_flush);
      rows.insert(rows.end(), some.begin(), some.end());
    };
    for (int64_t tick = 0; tick < 400; ++tick) {
      aligner.Add(SimSample(Stream::kVirtual, tick, 1.0));
      aligner.Add(SimSample(Stream::kSetpoint, tick, 1.0));
      if (tick == 210) {  // the plan started at tick 200; its status comes 10 ticks late
        PlanStatus status;
        status.utime = 200 * 512;
        status.recv_utime = 1'000'000'000 + tick * 512;
        status.plan_name = "config/plans/set1.plan";
        status.plan_step = 0;
        status.plan_steps = 4;
        aligner.AddStatus(status);
      }
      take(tick, false);
    }
    take(400, true);
    for (const Row& row : rows) {
      if (row.time_us == 200 * 512) return row.plan_run;
    }
    return -1;
  };
  EXPECT_EQ(plan_run_at_start(50000), 1);  // the default hold: the plan's first row
  EXPECT_EQ(plan_run_at_start(0), 0);      // without it the row had gone to the manual run
}

// The first plan status, heard soon after the first sample, decides what the rows so far belong
// to: a plan past its first step was under way before the input began (a logger restarted in the
// middle of a movement set) and is joined; a plan at its first step starts there.
TEST(Aligner, APlanRunUnderWayWhenTheInputBeginsIsJoined) {
  auto run = [](int32_t step, const std::string& continue_plan) {
    AlignerOptions options;
    options.continue_plan = continue_plan;
    Aligner aligner(options);
    std::vector<Row> rows;
    for (int64_t tick = 0; tick < 2000; ++tick) {
      if (tick == 100) {
        PlanStatus status;
        status.utime = tick * 512;
        status.plan_name = "config/plans/set2.plan";
        status.plan_step = step;
        status.plan_steps = 6;
        aligner.AddStatus(status);
      }
      aligner.Add(SimSample(Stream::kVirtual, tick, 1.0));
      aligner.Add(SimSample(Stream::kSetpoint, tick, 1.0));
      // Rows are taken as they come (the writer wakes often): before the status none are final.
      const std::vector<Row> some = Collect(aligner, 1'000'000'000 + tick * 512, false);
      if (tick < 100) {
        EXPECT_TRUE(some.empty()) << tick;
      }
      rows.insert(rows.end(), some.begin(), some.end());
    }
    Collect(aligner, 1'000'000'000 + 2000 * 512, true);
    return std::make_pair(rows.front().plan_run, aligner.plan_runs());
  };
  const auto [joined_run, joined] = run(3, "");
  EXPECT_EQ(joined_run, 0);
  ASSERT_EQ(joined.size(), 1u);
  EXPECT_EQ(joined[0].plan_name, "config/plans/set2.plan");
  EXPECT_TRUE(joined[0].joined);
  const auto [fresh_run, fresh] = run(0, "");
  ASSERT_EQ(fresh.size(), 2u);  // the time before the plan, and the plan from its start
  EXPECT_EQ(fresh[0].plan_name, "");
  EXPECT_FALSE(fresh[1].joined);
  const auto [continued_run, continued] = run(0, "config/plans/set2.plan");
  ASSERT_EQ(continued.size(), 1u);  // the plan the earlier logger was recording
  EXPECT_TRUE(continued[0].joined);
}

TEST(Aligner, LeavesCellsOfAStaleStreamEmptyAndSkipsRowsWithNothing) {
  AlignerOptions options;
  options.max_age_us = 2000;
  Aligner aligner(options);
  aligner.Add(SimSample(Stream::kVirtual, 0, 1.0));
  aligner.Add(SimSample(Stream::kSetpoint, 0, 2.0));
  for (int64_t tick = 1; tick <= 20; ++tick) aligner.Add(SimSample(Stream::kVirtual, tick, 1.0));
  aligner.Add(SimSample(Stream::kVirtual, 1000, 5.0));  // half a second without anything
  std::vector<std::vector<double>> q1;
  const std::vector<Row> rows = Collect(aligner, 0, true, &q1);
  // Ticks 0..23 (tick 20's state held while younger than 2 ms) and 1000; nothing in between.
  ASSERT_EQ(rows.size(), 25u);
  EXPECT_EQ(rows.back().time_us, 1000 * 512);
  EXPECT_DOUBLE_EQ(q1[3][0], 2.0);    // 1.5 ms old
  EXPECT_TRUE(std::isnan(q1[4][0]));  // 2.048 ms old: too old, left empty
  EXPECT_TRUE(std::isnan(q1.back()[0]));
  EXPECT_DOUBLE_EQ(q1.back()[1], 5.0);
}

TEST(Aligner, CountsMissingMessagesIntoTheRows) {
  Aligner aligner(AlignerOptions{});
  aligner.Add(SimSample(Stream::kVirtual, 0, 0));
  aligner.Add(SimSample(Stream::kVirtual, 1, 0));
  aligner.Add(SimSample(Stream::kVirtual, 4, 0, 2));  // ticks 2 and 3 lost
  const std::vector<Row> rows = Collect(aligner, 0, true);
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_EQ(rows[1].lost[1], 0);
  EXPECT_EQ(rows[3].lost[1], 0);  // held from tick 1: the gap shows with the sample after it
  EXPECT_EQ(rows[4].lost[1], 2);
  EXPECT_EQ(aligner.lost_total()[1], 2);
}

TEST(Aligner, MovesWallClockRealArmSamplesOntoSimTime) {
  Aligner aligner(AlignerOptions{});
  // The sim's tick 100 (51.2 ms of sim time) is received at wall clock 5 s.
  Sample virt = SimSample(Stream::kVirtual, 100, 1.0);
  virt.recv_utime = 5'000'000;
  aligner.Add(virt);
  Sample real;
  real.stream = Stream::kReal;
  real.clock = SampleClock::kWall;
  real.source = sirupp::arm_state_t::SOURCE_EMULATED;
  real.utime = 5'000'000 - 1024;  // measured two ticks before
  real.recv_utime = 5'000'100;
  real.position.assign(kJoints, 7 * kDeg);
  aligner.Add(real);
  std::vector<std::vector<double>> q1;
  const std::vector<Row> rows = Collect(aligner, 0, true, &q1);
  ASSERT_EQ(rows.size(), 1u);  // the clock starts with the first sim sample
  EXPECT_EQ(rows[0].time_us, 100 * 512);
  EXPECT_NEAR(q1[0][1], 1.0, 1e-12);
  EXPECT_NEAR(q1[0][2], 7.0, 1e-12);   // at sim tick 98: 1 ms old
  EXPECT_EQ(rows[0].age_us[2], 1024);  // and the row says how old
  EXPECT_EQ(rows[0].age_us[1], 0);
  EXPECT_EQ(aligner.real_sources(), 1 << sirupp::arm_state_t::SOURCE_EMULATED);
}

TEST(Aligner, ASimSampleDeliveredLateDoesNotMoveTheRealArmsSamples) {
  Aligner aligner(AlignerOptions{});
  for (int64_t tick = 0; tick < 10; ++tick) aligner.Add(SimSample(Stream::kVirtual, tick, 1.0));
  Sample late = SimSample(Stream::kVirtual, 10, 1.0);
  late.recv_utime += 5000;  // the logger got tick 10 five milliseconds late
  aligner.Add(late);
  Sample real;
  real.stream = Stream::kReal;
  real.clock = SampleClock::kWall;
  real.source = sirupp::arm_state_t::SOURCE_REAL;
  real.utime = 1'000'000'000 + 10 * 512;  // measured as tick 10 was due
  real.recv_utime = real.utime + 5000;
  real.position.assign(kJoints, 7 * kDeg);
  aligner.Add(real);
  std::vector<std::vector<double>> q1;
  const std::vector<Row> rows = Collect(aligner, 0, true, &q1);
  ASSERT_EQ(rows.size(), 11u);
  // On tick 10, not 5 ms (about ten ticks) before it, as the late sample's offset would put it.
  EXPECT_TRUE(std::isnan(q1[9][2]));
  EXPECT_DOUBLE_EQ(q1[10][2], 7.0);
  EXPECT_EQ(rows[10].age_us[2], 0);
}

// A run played back onto the bus later (`sirupp replay` with a live logger): the sim samples get
// new receive times, the real arm's samples keep the old run's wall clock, a minute behind. They
// are put on the receive clock by their smallest delay (1 ms here) and land where they were live,
// one tick apart from the sim samples received with them; within a second of the receive clock
// (clocks in sync) they are placed as before, by their own stamp.
TEST(Aligner, ARealArmClockFarOffTheReceiveClockIsPutOnItByItsSmallestDelay) {
  for (const int64_t behind : {int64_t{60'000'000}, int64_t{0}}) {
    SCOPED_TRACE(behind);
    Aligner aligner(AlignerOptions{});
    for (int64_t tick = 0; tick <= 2000; ++tick) {
      aligner.Add(SimSample(Stream::kVirtual, tick, 1.0));
      if (tick % 20 == 0) {
        Sample real;
        real.stream = Stream::kReal;
        real.clock = SampleClock::kWall;
        real.source = sirupp::arm_state_t::SOURCE_EMULATED;
        // Read a tick before it reached the logger with this sim tick; some arrive 3 ms late.
        real.recv_utime = 1'000'000'000 + tick * 512 + (tick % 100 == 0 ? 3000 : 0);
        real.utime = 1'000'000'000 + (tick - 2) * 512 - behind;
        real.position.assign(kJoints, static_cast<double>(tick) * kDeg);
        aligner.Add(real);
      }
    }
    std::vector<std::vector<double>> q1;
    const std::vector<Row> rows = Collect(aligner, 0, true, &q1);
    ASSERT_EQ(rows.size(), 2001u);
    const int64_t shift = behind > 0 ? 2 : 0;  // live: by its stamp; a minute off: by 1 ms delay
    for (int64_t tick = 40; tick <= 1980; tick += 20) {
      SCOPED_TRACE(tick);
      const auto at = static_cast<size_t>(tick - 2 + shift);
      EXPECT_DOUBLE_EQ(q1[at][2], static_cast<double>(tick));
      EXPECT_DOUBLE_EQ(q1[at - 1][2], static_cast<double>(tick - 20));
    }
  }
}

TEST(Aligner, APlanStartBeginsANewMovementSet) {
  Aligner aligner(AlignerOptions{});
  for (int64_t tick = 0; tick < 10; ++tick) aligner.Add(SimSample(Stream::kVirtual, tick, 0));
  PlanStatus status;
  status.utime = 5 * 512;
  status.plan_name = "config/plans/set7.plan";
  status.plan_step = 0;
  status.plan_steps = 6;
  aligner.AddStatus(status);
  status.plan_step = 3;  // the same run, later
  aligner.AddStatus(status);
  const std::vector<Row> rows = Collect(aligner, 0, true);
  ASSERT_EQ(rows.size(), 10u);
  EXPECT_EQ(rows[4].plan_run, 0);
  EXPECT_EQ(rows[5].plan_run, 1);
  EXPECT_EQ(rows[9].plan_run, 1);
  ASSERT_EQ(aligner.plan_runs().size(), 2u);
  EXPECT_EQ(aligner.plan_runs()[1].plan_name, "config/plans/set7.plan");
}

ColumnLayout TwoJoints() {
  ColumnLayout layout;
  layout.joints = {{"waist", false}, {"slide", true}};
  return layout;
}

TEST(DataFile, RowsWrittenAreReadBackInTheFileUnits) {
  TempDir dir;
  const std::string path = dir / "run.csv";
  {
    DataFileWriter writer(path, {"joints: 2: j1 waist deg; j2 slide mm", "plan: set3.plan"},
                          TwoJoints());
    Sample set, virt;
    set.stream = Stream::kSetpoint;
    set.position = {90 * kDeg, 0.25};
    set.move_id = 4;
    set.done = {1, 0};
    virt.stream = Stream::kVirtual;
    virt.position = {89.5 * kDeg, 0.2495};
    Row row;
    row.time_us = 1'000'512;
    row.cell = {&set, &virt, nullptr};
    row.lost = {0, 3, 0};
    writer.Append(row);
    row.time_us += 512;
    row.cell = {nullptr, &virt, nullptr};
    row.age_us = {0, 512, 0};  // the virtual sample held over from the row before
    row.lost = {0, 5, 0};      // the logger's counts run on: 2 more lost during this file
    writer.Append(row);
    writer.Close("2 rows");
  }
  const RunTable table = ReadDataFile(path);
  ASSERT_EQ(table.rows(), 2u);
  EXPECT_TRUE(table.closed);
  EXPECT_TRUE(table.notes.empty());
  EXPECT_EQ(table.label, "set3");
  EXPECT_NEAR(table.time_s[0], 1.000512, 1e-9);
  EXPECT_NEAR(table.position[0][0][0], 90.0, 1e-5);
  EXPECT_NEAR(table.position[0][1][0], 89.5, 1e-5);
  EXPECT_NEAR(table.position[1][0][0], 250.0, 1e-5);  // mm
  EXPECT_TRUE(std::isnan(table.position[0][2][0]));
  EXPECT_TRUE(std::isnan(table.position[0][0][1]));
  EXPECT_EQ(table.move_id[0], 4);
  EXPECT_EQ(table.move_id[1], -1);
  EXPECT_EQ(table.done[0][0], 1);
  EXPECT_EQ(table.done[1][0], 0);
  EXPECT_EQ(table.lost[1], 5);
  EXPECT_EQ(table.lost_at_start[1], 3);
  EXPECT_EQ(table.LostInSet(1), 2);  // what the report's Inputs table shows
  EXPECT_DOUBLE_EQ(table.age_s[1][0], 0.0);
  EXPECT_NEAR(table.age_s[1][1], 512e-6, 1e-12);
  EXPECT_TRUE(std::isnan(table.age_s[0][1]));  // an empty cell has no age
  EXPECT_NEAR(table.period_s(), 512e-6, 1e-9);
  EXPECT_TRUE(table.Fresh(Stream::kVirtual, 0, table.period_s()));
  EXPECT_FALSE(table.Fresh(Stream::kVirtual, 1, table.period_s()));
  // The first line says where the column line is, so Octave's dlmread can skip the header.
  std::ifstream in(path);
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, std::string(kFileMagic) + "; the column line is line 4");
}

TEST(DataFile, APartialLastLineIsDroppedWithANoteAndAMissingEndIsNoted) {
  TempDir dir;
  const std::string path = dir / "killed.csv";
  {
    std::ofstream out(path);
    out << kFileMagic << "; the column line is line 3\n# joints: 1: j1 waist deg\n"
        << "time_s,j1_set_deg,j1_virt_deg,j1_real_deg,move_id,j1_done,set_lost,virt_lost,"
           "real_lost\n0.000512,1,2,,1,0,0,0,0\n0.001024,1,2,,1,0,0,0,0\n0.00153";
  }
  const RunTable table = ReadDataFile(path);
  EXPECT_EQ(table.rows(), 2u);
  EXPECT_FALSE(table.closed);
  ASSERT_EQ(table.notes.size(), 2u);
  EXPECT_EQ(table.notes[0], path +
                                ":6: the last line has no line end (the logger stopped while "
                                "writing it); ignored");
  EXPECT_NE(table.notes[1].find("no '# end:' line"), std::string::npos);
}

TEST(DataFile, AnExistingFileIsNeverReplaced) {
  TempDir dir;
  const std::string path = dir / "taken.csv";
  std::ofstream(path) << "precious\n";
  const std::string text = sirupp::testing::ErrorText<std::runtime_error>(
      [&] { DataFileWriter(path, {}, TwoJoints()); });
  EXPECT_NE(text.find("taken.csv: cannot create the data file: File exists"), std::string::npos)
      << text;
}

// ---- sirupp-logger's logic on memq:// ----------------------------------------------------------

sirupp::arm_state_t ArmState(int64_t tick, int64_t seq, double q1_deg) {
  sirupp::arm_state_t state{};
  state.utime = tick * 512;
  state.seq = seq;
  state.tick = tick;
  state.source = sirupp::arm_state_t::SOURCE_SIM;
  state.num_joints = kJoints;
  state.position.assign(kJoints, 0.0);
  state.position[0] = q1_deg * kDeg;
  state.velocity.assign(kJoints, 0.0);
  state.effort.assign(kJoints, 0.0);
  state.flags.assign(kJoints, 0);
  return state;
}

sirupp::servo_setpoint_t Setpoint(int64_t tick, int64_t seq, int64_t move_id, double q1_deg) {
  sirupp::servo_setpoint_t setpoint{};
  setpoint.utime = tick * 512;
  setpoint.seq = seq;
  setpoint.tick = tick;
  setpoint.move_id = move_id;
  setpoint.num_joints = kJoints;
  setpoint.position.assign(kJoints, 0.0);
  setpoint.position[0] = q1_deg * kDeg;
  setpoint.velocity.assign(kJoints, 0.0);
  setpoint.goal.assign(kJoints, 0.0);
  setpoint.position_error.assign(kJoints, 0.0);
  setpoint.effort.assign(kJoints, 0.0);
  setpoint.status.assign(kJoints, sirupp::servo_setpoint_t::STATUS_SERVO_ON);
  return setpoint;
}

sirupp::controller_status_t PlanStatusMessage(int64_t tick, const std::string& plan, int step) {
  sirupp::controller_status_t status{};
  status.utime = tick * 512;
  status.mode = sirupp::controller_status_t::MODE_AUTOMATIC;
  status.state = sirupp::controller_status_t::STATE_MOVING;
  status.plan_name = plan;
  status.plan_step = step;
  status.plan_steps = 6;
  return status;
}

struct LoggerRig {
  core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Bus bus{"memq://"};
  TempDir dir;
  LoggerOptions Options() {
    LoggerOptions options;
    options.out_dir = dir.path.string();
    options.name = "run";
    return options;
  }
};

TEST(LoggerNode, WritesOneFilePerMovementSetWithTheGapsCounted) {
  LoggerRig rig;
  LoggerNode node(rig.bus, rig.model, rig.Options());
  int64_t virt_seq = 0;
  for (int64_t tick = 0; tick < 2000; ++tick) {
    if (tick == 1000)
      rig.bus.Publish("CONTROLLER_STATUS", PlanStatusMessage(tick, "config/plans/set1.plan", 0));
    if (tick == 1500) virt_seq += 3;  // three states lost on the way
    rig.bus.Publish("SIM_ARM_STATE", ArmState(tick, virt_seq++, 0.01 * static_cast<double>(tick)));
    rig.bus.Publish("ARM_SETPOINT",
                    Setpoint(tick, tick, tick < 1000 ? 0 : 1, 0.02 * static_cast<double>(tick)));
    rig.bus.HandleAvailable();
  }
  node.Close();
  const LoggerStats stats = node.stats();
  ASSERT_EQ(stats.files.size(), 2u);
  EXPECT_EQ(stats.files[0], rig.dir / "run-01-manual.csv");
  EXPECT_EQ(stats.files[1], rig.dir / "run-02-set1.csv");
  EXPECT_EQ(stats.rows, 2000);
  EXPECT_EQ(stats.lost[1], 3);
  EXPECT_TRUE(stats.error.empty()) << stats.error;

  const RunTable manual = ReadDataFile(stats.files[0]);
  const RunTable set1 = ReadDataFile(stats.files[1]);
  EXPECT_EQ(manual.rows(), 1000u);
  EXPECT_EQ(set1.rows(), 1000u);
  EXPECT_TRUE(set1.closed);
  EXPECT_EQ(set1.plan_name, "config/plans/set1.plan");
  EXPECT_EQ(set1.label, "set1");
  EXPECT_NEAR(set1.time_s.front(), 1000 * 512e-6, 1e-9);
  EXPECT_NEAR(set1.position[0][1][0], 10.0, 1e-5);
  EXPECT_NEAR(set1.position[0][0][0], 20.0, 1e-5);
  EXPECT_EQ(set1.move_id.back(), 1);
  EXPECT_EQ(set1.lost[1], 3);
  EXPECT_EQ(set1.cells[2], 0);  // no real arm: its column stays empty
  // Each row's set-point sample with the wall-clock time the logger received it (set_recv_us: when
  // the sim was at that row, for the report's timing of a real arm), in the order received.
  ASSERT_EQ(set1.set_recv_us.size(), set1.rows());
  EXPECT_TRUE(std::is_sorted(set1.set_recv_us.begin(), set1.set_recv_us.end()));
  EXPECT_GT(set1.set_recv_us.front(), 1'500'000'000'000'000);  // after 2017: the wall clock
  EXPECT_TRUE(std::all_of(set1.real_clock_us.begin(), set1.real_clock_us.end(),
                          [](int64_t stamp) { return stamp == kNoClock; }));
  std::ifstream in(stats.files[1]);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("# plan: config/plans/set1.plan\n"), std::string::npos);
  EXPECT_NE(text.str().find("# mode: controller automatic; real arm: none heard yet\n"),
            std::string::npos);
  EXPECT_NE(text.str().find("# gains (chip units, the model's; no ARM_GAINS heard): kp 100"),
            std::string::npos);
  EXPECT_NE(text.str().find("# config hash: fnv1a "), std::string::npos);
  EXPECT_NE(text.str().find("# end: 1000 rows"), std::string::npos);
}

// On a real udpm bus (a private port, ttl=0) the logger reads the per-tick channels from a socket
// of its own (core/tick_reader.hpp) and LCM's socket drops them: every message of bursts published
// while the logger sleeps between its drains is logged, once, in order.
TEST(LoggerNode, OnUdpmEveryPerTickMessageOfBurstsIsLoggedOnceInOrder) {
  const std::string url =
      "udpm://239.255.76.67:" + std::to_string(36000 + ::getpid() % 5000) + "?ttl=0";
  core::Bus publisher(url);
  core::Bus bus(url);
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  TempDir dir;
  LoggerOptions options;
  options.out_dir = dir.path.string();
  options.name = "burst";
  options.split_per_plan = false;
  LoggerNode node(bus, model, options);
  const std::vector<std::string> muted = bus.MutedOnLcm();
  EXPECT_NE(std::find(muted.begin(), muted.end(), "SIM_ARM_STATE"), muted.end());
  EXPECT_NE(std::find(muted.begin(), muted.end(), "ARM_SETPOINT"), muted.end());
  constexpr int64_t kBursts = 20;
  constexpr int64_t kTicksPerBurst = 50;
  constexpr int64_t kTicks = kBursts * kTicksPerBurst;
  std::atomic<bool> sent{false};
  std::thread sender([&] {
    for (int64_t tick = 0; tick < kTicks; ++tick) {
      publisher.Publish("ARM_SETPOINT", Setpoint(tick, tick, 0, 0.01 * static_cast<double>(tick)));
      publisher.Publish("SIM_ARM_STATE", ArmState(tick, tick, 0.01 * static_cast<double>(tick)));
      if (tick % kTicksPerBurst == kTicksPerBurst - 1) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
    sent = true;
  });
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < end) {
    node.Service(20);
    const LoggerStats now = node.stats();
    if (sent && now.samples[0] + now.lost[0] >= kTicks && now.samples[1] + now.lost[1] >= kTicks) {
      break;
    }
  }
  sender.join();
  node.Close();
  const LoggerStats stats = node.stats();
  EXPECT_EQ(stats.samples[0], kTicks);
  EXPECT_EQ(stats.samples[1], kTicks);
  EXPECT_EQ(stats.lost[0], 0);
  EXPECT_EQ(stats.lost[1], 0);
  EXPECT_EQ(stats.kernel_dropped, 0);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").messages, kTicks);  // once each, not also through LCM
  ASSERT_EQ(stats.files.size(), 1u);
  const RunTable table = ReadDataFile(stats.files[0]);
  ASSERT_EQ(table.rows(), static_cast<size_t>(kTicks));
  for (size_t row = 0; row < table.rows(); ++row) {
    ASSERT_NEAR(table.time_s[row], static_cast<double>(row) * 512e-6, 1e-9) << row;
    ASSERT_NEAR(table.position[0][1][row], 0.01 * static_cast<double>(row), 1e-6) << row;
    ASSERT_NEAR(table.position[0][0][row], 0.01 * static_cast<double>(row), 1e-6) << row;
  }
}

// The real arm's cells carry its own stamps (real_clock_us, format 2), so the report can time its
// motion on its own clock (docs/logging.md, "Definitions").
TEST(LoggerNode, TakesTheRealArmWhenItIsThereWithItsStampsAndRefusesWrongJointCounts) {
  LoggerRig rig;
  LoggerOptions options = rig.Options();
  options.split_per_plan = false;
  LoggerNode node(rig.bus, rig.model, options);
  std::vector<int64_t> stamps;
  for (int64_t tick = 0; tick < 400; ++tick) {
    rig.bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 1.0));
    if (tick % 4 == 0) {  // a real arm at a quarter of the rate, stamped with the wall clock
      sirupp::arm_state_t real = ArmState(tick, tick / 4, 3.0);
      real.source = sirupp::arm_state_t::SOURCE_EMULATED;
      // As the bridge stamps it: the wall clock when it was read (a fixed stamp would fall behind
      // the sim clock as fast as this loop is slow, and a slow sanitizer build lost the samples).
      real.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
      stamps.push_back(real.utime);
      rig.bus.Publish("REAL_ARM_STATE", real);
    }
    rig.bus.HandleAvailable();
  }
  sirupp::arm_state_t three = ArmState(400, 400, 1.0);
  three.num_joints = 3;
  three.position.resize(3);
  three.velocity.resize(3);
  three.effort.resize(3);
  three.flags.resize(3);
  rig.bus.Publish("SIM_ARM_STATE", three);
  rig.bus.HandleAvailable();
  node.Close();
  const core::ChannelStats refused = rig.bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(refused.rejected, 1);
  EXPECT_NE(refused.last_error.find("num_joints: 3 joints; the model has 6"), std::string::npos)
      << refused.last_error;
  const LoggerStats stats = node.stats();
  ASSERT_EQ(stats.files.size(), 1u);
  EXPECT_EQ(stats.files[0], rig.dir / "run.csv");
  const RunTable table = ReadDataFile(stats.files[0]);
  EXPECT_EQ(table.rows(), 400u);
  EXPECT_GT(table.cells[2], 300);  // real samples held for up to 10 ms between their arrivals
  EXPECT_EQ(stats.samples[2], 100);
  EXPECT_NEAR(table.position[0][2].back(), 3.0, 1e-5);
  // Every row with a real cell has that sample's stamp, one the bridge sent; rows without one have
  // none.
  ASSERT_EQ(table.real_clock_us.size(), table.rows());
  std::vector<int64_t> written;
  for (size_t i = 0; i < table.rows(); ++i) {
    SCOPED_TRACE(i);
    const int64_t stamp = table.real_clock_us[i];
    EXPECT_EQ(std::isnan(table.position[0][2][i]), stamp == kNoClock);
    if (stamp == kNoClock) continue;
    EXPECT_NE(std::find(stamps.begin(), stamps.end(), stamp), stamps.end());
    if (written.empty() || stamp != written.back()) written.push_back(stamp);
  }
  EXPECT_GT(written.size(), 50u);
  // No set-point stream here: no set-point receive times either.
  ASSERT_EQ(table.set_recv_us.size(), table.rows());
  EXPECT_TRUE(std::all_of(table.set_recv_us.begin(), table.set_recv_us.end(),
                          [](int64_t recv) { return recv == kNoClock; }));
  std::ifstream in(stats.files[0]);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("real arm: emulated"), std::string::npos);
  EXPECT_NE(text.str().find(",real_age_us,real_clock_us,set_recv_us\n"), std::string::npos);
  EXPECT_EQ(text.str().rfind(kFileMagic, 0), 0u);
}

// Malformed traffic (a flood, a broken publisher): a NaN or infinite value, or a controller
// status with a mode or state no controller sends, is refused and counted; the file keeps only
// finite rows and no plan split comes from it.
TEST(LoggerNode, RefusesNonFiniteValuesAndImpossibleStatuses) {
  LoggerRig rig;
  LoggerNode node(rig.bus, rig.model, rig.Options());
  for (int64_t tick = 0; tick < 200; ++tick) {
    rig.bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 1.0));
    rig.bus.Publish("ARM_SETPOINT", Setpoint(tick, tick, 0, 2.0));
    if (tick == 50) {
      sirupp::arm_state_t nan = ArmState(tick, tick, 1.0);
      nan.position[1] = std::numeric_limits<double>::quiet_NaN();
      rig.bus.Publish("SIM_ARM_STATE", nan);
      sirupp::servo_setpoint_t inf = Setpoint(tick, tick, 0, 2.0);
      inf.velocity[2] = std::numeric_limits<double>::infinity();
      rig.bus.Publish("ARM_SETPOINT", inf);
      sirupp::arm_state_t real = ArmState(tick, 0, 3.0);
      real.source = sirupp::arm_state_t::SOURCE_EMULATED;
      real.effort[0] = -std::numeric_limits<double>::infinity();
      rig.bus.Publish("REAL_ARM_STATE", real);
      sirupp::controller_status_t status = PlanStatusMessage(tick, "config/plans/set1.plan", 0);
      status.state = 99;
      rig.bus.Publish("CONTROLLER_STATUS", status);
    }
    rig.bus.HandleAvailable();
  }
  node.Close();
  for (const char* channel : {"SIM_ARM_STATE", "ARM_SETPOINT", "REAL_ARM_STATE"}) {
    const core::ChannelStats stats = rig.bus.StatsFor(channel);
    EXPECT_EQ(stats.rejected, 1) << channel;
    EXPECT_NE(stats.last_error.find("is not allowed; expected a finite number"), std::string::npos)
        << stats.last_error;
  }
  EXPECT_EQ(rig.bus.StatsFor("CONTROLLER_STATUS").rejected, 1);
  EXPECT_NE(rig.bus.StatsFor("CONTROLLER_STATUS")
                .last_error.find("state: 99 is not allowed; expected 0..5"),
            std::string::npos)
      << rig.bus.StatsFor("CONTROLLER_STATUS").last_error;
  const LoggerStats stats = node.stats();
  ASSERT_EQ(stats.files.size(), 1u);  // no plan started by the refused status
  const RunTable table = ReadDataFile(stats.files[0]);
  EXPECT_EQ(table.rows(), 200u);
  EXPECT_EQ(table.cells[2], 0);  // the refused real state left no trace
}

// ---- restarts
// -------------------------------------------------------------------------------------

// One logger's life on memq://: `ticks` ticks from `first_tick`, a plan status at `plan_tick`
// (step 0 of 6) when given, closed at the end. Returns the files it wrote.
std::vector<std::string> LogSome(LoggerRig& rig, const LoggerOptions& options, int64_t first_tick,
                                 int64_t ticks, const std::string& plan = "",
                                 int64_t plan_tick = -1, int plan_step = 0) {
  LoggerNode node(rig.bus, rig.model, options);
  for (int64_t tick = first_tick; tick < first_tick + ticks; ++tick) {
    if (tick == plan_tick) {
      rig.bus.Publish("CONTROLLER_STATUS", PlanStatusMessage(tick, plan, plan_step));
    }
    rig.bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 1.0));
    rig.bus.Publish("ARM_SETPOINT", Setpoint(tick, tick, tick / 500, 1.0));
    rig.bus.HandleAvailable();
  }
  node.Close();
  return node.stats().files;
}

std::string FileText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(LoggerNode, ARestartedLoggerContinuesTheRunInNewFilesAndNeverReplacesOne) {
  LoggerRig rig;
  const LoggerOptions options = rig.Options();
  const std::vector<std::string> first =
      LogSome(rig, options, 0, 2000, "config/plans/set1.plan", 1000);
  ASSERT_EQ(first.size(), 2u);
  EXPECT_EQ(first[1], rig.dir / "run-02-set1.csv");
  const std::string set1_text = FileText(first[1]);
  // Restarted with the same options while set I still runs (the status shows step 2), then set II.
  const std::vector<std::string> second = [&] {
    LoggerNode node(rig.bus, rig.model, options);
    EXPECT_EQ(node.continues(), rig.dir / "run-02-set1.csv");
    for (int64_t tick = 3000; tick < 5000; ++tick) {
      if (tick == 3000) {
        rig.bus.Publish("CONTROLLER_STATUS", PlanStatusMessage(tick, "config/plans/set1.plan", 2));
      }
      if (tick == 4000) {
        rig.bus.Publish("CONTROLLER_STATUS", PlanStatusMessage(tick, "config/plans/set2.plan", 0));
      }
      rig.bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 1.0));
      rig.bus.Publish("ARM_SETPOINT", Setpoint(tick, tick, tick / 500, 1.0));
      rig.bus.HandleAvailable();
    }
    node.Close();
    return node.stats().files;
  }();
  ASSERT_EQ(second.size(), 2u);
  EXPECT_EQ(second[0], rig.dir / "run-02-set1.1.csv");
  EXPECT_EQ(second[1], rig.dir / "run-03-set2.csv");
  EXPECT_EQ(FileText(first[1]), set1_text);  // the earlier file is untouched
  const std::string continued = FileText(second[0]);
  EXPECT_NE(continued.find("\n# continues: run-02-set1.csv (the rows between its last one and "
                           "this file's first were not logged)\n"),
            std::string::npos)
      << continued.substr(0, 2000);
  EXPECT_NE(continued.find("\n# restart: this logger started with data files of run already in "),
            std::string::npos);
  EXPECT_EQ(FileText(second[1]).find("# continues:"), std::string::npos);  // a set of its own

  // A third start during set II continues set II's file.
  EXPECT_EQ(LogSome(rig, options, 6000, 500, "config/plans/set2.plan", 6000, 3),
            std::vector<std::string>{rig.dir / "run-03-set2.1.csv"});
  // Started while another plan begins: numbering goes on after the earlier files.
  EXPECT_EQ(LogSome(rig, options, 7000, 500, "config/plans/set3.plan", 7000),
            std::vector<std::string>{rig.dir / "run-04-set3.csv"});

  // The report reads the folder in the order the files were written, continuations included.
  const std::vector<RunTable> tables = ReadInputs({rig.dir.path.string()}, ImportOptions{});
  std::vector<std::string> sources;
  for (const RunTable& table : tables) sources.push_back(table.source);
  EXPECT_EQ(sources,
            (std::vector<std::string>{rig.dir / "run-01-manual.csv", rig.dir / "run-02-set1.csv",
                                      rig.dir / "run-02-set1.1.csv", rig.dir / "run-03-set2.csv",
                                      rig.dir / "run-03-set2.1.csv", rig.dir / "run-04-set3.csv"}));
  EXPECT_EQ(tables[2].continues, "run-02-set1.csv");
  EXPECT_EQ(tables[2].label, "set1");
  ReportOptions report;
  report.out_dir = rig.dir / "report";
  report.plots = false;
  report.analysis.min_travel = 0;  // the test's set-points do not move
  EXPECT_NO_THROW(WriteReport(tables, report));
}

TEST(LoggerNode, UnsplitFilesContinueAsNameDotK) {
  LoggerRig rig;
  LoggerOptions options = rig.Options();
  options.split_per_plan = false;
  EXPECT_EQ(LogSome(rig, options, 0, 300), std::vector<std::string>{rig.dir / "run.csv"});
  EXPECT_EQ(LogSome(rig, options, 1000, 300), std::vector<std::string>{rig.dir / "run.1.csv"});
  EXPECT_EQ(LogSome(rig, options, 2000, 300), std::vector<std::string>{rig.dir / "run.2.csv"});
  EXPECT_NE(FileText(rig.dir / "run.2.csv").find("\n# continues: run.1.csv "), std::string::npos);
}

sirupp::servo_gains_t Gains(int64_t seq, double kp2) {
  sirupp::servo_gains_t gains{};
  gains.seq = seq;
  gains.num_joints = kJoints;
  auto fill = [](std::vector<double>& values, double value) { values.assign(kJoints, value); };
  fill(gains.kp, 100);
  gains.kp[1] = kp2;
  fill(gains.kd, 1000);
  fill(gains.ki, 0);
  fill(gains.integration_limit, 0);
  fill(gains.output_limit, 255);
  fill(gains.current_limit, 0);
  fill(gains.error_limit, 4000);
  fill(gains.servo_rate_divisor, 1);
  fill(gains.deadband, 0);
  return gains;
}

// Every gain change heard on ARM_GAINS, CONTROLLER_GAINS and REAL_ARM_GAINS is written into the
// data file with its time, among the rows; repeats (the controller's 1 Hz) are not.
TEST(LoggerNode, GainChangesAreWrittenWithTheirTimeRepeatsAreNot) {
  LoggerRig rig;
  LoggerOptions options = rig.Options();
  options.split_per_plan = false;
  LoggerNode node(rig.bus, rig.model, options);
  for (int64_t tick = 0; tick < 3000; ++tick) {
    if (tick % 100 == 50) {  // the controller's live gains, again and again; kp2 changes at 1500
      rig.bus.Publish("CONTROLLER_GAINS", Gains(tick / 100, tick < 1500 ? 100 : 120));
    }
    if (tick == 1400) rig.bus.Publish("ARM_GAINS", Gains(0, 120));
    if (tick == 2000) rig.bus.Publish("REAL_ARM_GAINS", Gains(0, 100));
    rig.bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 1.0));
    rig.bus.Publish("ARM_SETPOINT", Setpoint(tick, tick, 0, 1.0));
    rig.bus.HandleAvailable();
    if (tick % 200 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  node.Close();
  const std::vector<std::string> files = node.stats().files;
  ASSERT_EQ(files.size(), 1u);
  const RunTable table = ReadDataFile(files[0]);
  ASSERT_EQ(table.gains.size(), 4u) << FileText(files[0]).substr(0, 3000);
  EXPECT_NE(table.gains[0].find(": CONTROLLER_GAINS (virtual servos) first heard: kp 100 100 100 "
                                "100 100 100; kd 1000"),
            std::string::npos)
      << table.gains[0];
  EXPECT_NE(table.gains[1].find(": ARM_GAINS (requested) first heard: kp 100 120 100"),
            std::string::npos)
      << table.gains[1];
  EXPECT_NE(table.gains[2].find(": CONTROLLER_GAINS (virtual servos) j2 kp 100 -> 120"),
            std::string::npos)
      << table.gains[2];
  EXPECT_NE(table.gains[3].find(": REAL_ARM_GAINS (real boards) first heard: kp 100 100"),
            std::string::npos)
      << table.gains[3];
  // Each line has the sim time and the wall clock, and sits among the rows at that time.
  const std::string text = FileText(files[0]);
  for (const std::string& line : table.gains) {
    EXPECT_EQ(line.rfind("gains: time_s ", 0), 0u) << line;
    EXPECT_NE(line.find(", wall 20"), std::string::npos) << line;
    const double at = std::stod(line.substr(14));
    const size_t where = text.find("# " + line);
    ASSERT_NE(where, std::string::npos);
    const size_t row_start = text.rfind('\n', where - 2) + 1;  // the row before the line
    const double row_before = std::stod(text.substr(row_start));
    EXPECT_LE(row_before, at + 1e-6) << line;
  }
  const double change_at = std::stod(table.gains[2].substr(14));
  EXPECT_NEAR(change_at, 1550 * 512e-6, 0.05);  // received with the tick it was sent at
  // The report shows them.
  ReportOptions report;
  report.out_dir = rig.dir / "report";
  report.plots = false;
  report.analysis.min_travel = 0;
  std::vector<RunTable> tables{table};
  tables[0].move_id.back() = 1;  // one move, so that there is something to report
  const ReportOutput output = WriteReport(tables, report);
  EXPECT_NE(output.markdown.find("## Gain changes"), std::string::npos);
  EXPECT_NE(output.markdown.find("CONTROLLER_GAINS (virtual servos) j2 kp 100 -> 120"),
            std::string::npos);
}

// Each file records the sim's real-time factor: sim time over wall time, in its header (the run
// so far), every 2 s and in a closing line (this file). Here the states come at half the pace of
// their sim time (or slower, on a busy machine).
TEST(LoggerNode, EachFileRecordsTheSimsRealTimeFactor) {
  LoggerRig rig;
  LoggerOptions options = rig.Options();
  options.split_per_plan = false;
  LoggerNode node(rig.bus, rig.model, options);
  const auto start = std::chrono::steady_clock::now();
  for (int64_t tick = 0; tick < 600; ++tick) {
    // Tick k is sent no earlier than 2 * k * 0.512 ms of wall clock after the start.
    std::this_thread::sleep_until(start + std::chrono::microseconds(2 * 512 * tick));
    rig.bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 1.0));
    rig.bus.Publish("ARM_SETPOINT", Setpoint(tick, tick, 0, 1.0));
    rig.bus.HandleAvailable();
  }
  node.Close();
  const std::string path = node.stats().files.at(0);
  const RunTable table = ReadDataFile(path);
  EXPECT_GT(table.realtime_factor, 0.05);
  EXPECT_LT(table.realtime_factor, 0.51);
  const std::string text = FileText(path);
  EXPECT_NE(text.find("\n# real-time factor so far: not known yet, sim time over wall time since "
                      "the logger first heard the sim\n"),
            std::string::npos);
  EXPECT_NE(text.find(", this file\n# end: 600 rows"), std::string::npos)
      << text.substr(text.size() - 400);
  EXPECT_NE(text.find("\n# real-time factor: 0."), std::string::npos);
}

// The data lines of a file (comments left out).
std::string DataLines(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::string rows;
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) != 0) rows += line + "\n";
  }
  return rows;
}

// A live logger with --raw over a stream paced by the wall clock, whose real arm is read every
// 10 ms but delivered in bursts every 80 ms (a late bridge): between bursts the real stream goes
// idle, so which rows are written before a burst arrives depends on where the writer's passes fall.
// sirupp-logger --from-log (ReplayRawLog) on the raw log must write the same files, byte for byte
// (the headers' start time and bus as recorded), with the name and the live settings taken from the
// log: the live logger runs with settings other than the defaults, the replay is given none of
// them. A pass of another logger arriving on the bus (a log played back) is not recorded as this
// logger's.
TEST(LoggerNode, ARawLogReplaysIntoTheLiveFilesByteForByteWithLateRealSamples) {
  LoggerRig rig;
  LoggerOptions options = rig.Options();
  options.raw_log = rig.dir / "raw/run.lcmlog";
  options.aligner.max_age_us = 30000;
  options.aligner.idle_us = 60000;
  options.velocities = true;
  options.efforts = true;
  options.note = "not a default";
  const core::Channels channels;
  std::vector<std::string> live;
  {
    LoggerNode node(rig.bus, rig.model, options);
    core::LoggerPass foreign;
    foreign.taken = 1000000000;
    foreign.name = "other";
    rig.bus.Publish(channels.logger_pass, core::ToMessage(foreign));
    auto wall = [] {
      return std::chrono::duration_cast<std::chrono::microseconds>(
                 std::chrono::system_clock::now().time_since_epoch())
          .count();
    };
    const int64_t t0 = wall();
    int64_t tick = 0;
    int64_t real_sent = 0;
    std::vector<sirupp::arm_state_t> unsent;
    while (tick < 2400) {
      const int64_t elapsed = wall() - t0;
      for (; tick * 512 <= elapsed && tick < 2400; ++tick) {  // sim time = wall time since t0
        if (tick == 1200) {
          rig.bus.Publish(channels.controller_status,
                          PlanStatusMessage(tick, "config/plans/set1.plan", 0));
        }
        const double q = 0.01 * static_cast<double>(tick);
        rig.bus.Publish(channels.sim_arm_state, ArmState(tick, tick, q));
        rig.bus.Publish(channels.arm_setpoint, Setpoint(tick, tick, tick < 1200 ? 0 : 1, q));
        if (tick % 20 == 0) {  // the real arm read every ~10 ms, stamped as the bridge does
          sirupp::arm_state_t real = ArmState(tick, tick / 20, 0.02 * static_cast<double>(tick));
          real.source = sirupp::arm_state_t::SOURCE_EMULATED;
          real.utime = wall();
          unsent.push_back(real);
        }
        if (tick % 160 == 159) {  // and delivered every ~80 ms
          for (const auto& real : unsent) rig.bus.Publish(channels.real_arm_state, real);
          real_sent += static_cast<int64_t>(unsent.size());
          unsent.clear();
        }
      }
      rig.bus.HandleAvailable();
      std::this_thread::sleep_for(std::chrono::microseconds(700));
    }
    node.Close();
    const LoggerStats stats = node.stats();
    EXPECT_TRUE(stats.error.empty()) << stats.error;
    EXPECT_EQ(stats.samples[2], real_sent);
    EXPECT_EQ(real_sent, 120);
    live = stats.files;
  }
  ASSERT_EQ(live.size(), 2u);

  // As sirupp-logger --from-log LOG --out DIR does it (logger/main.cpp): nothing but the folder
  // given, every setting from the log.
  const std::optional<core::LoggerPass> recorded = RecordedSettings(options.raw_log, std::nullopt);
  ASSERT_TRUE(recorded.has_value());
  EXPECT_EQ(recorded->model_file, rig.model.source_file);
  EXPECT_EQ(recorded->prefix, "");
  LoggerOptions again;
  again.out_dir = rig.dir / "again";
  TakeRecordedSettings(
      *recorded, [](const std::string&) { return false; }, again);
  EXPECT_EQ(again.aligner.max_age_us, 30000);
  EXPECT_EQ(again.note, "not a default");
  // An option given on the command line wins over the recorded one.
  LoggerOptions given;
  given.note = "mine";
  TakeRecordedSettings(
      *recorded, [](const std::string& flag) { return flag == "note"; }, given);
  EXPECT_EQ(given.note, "mine");
  EXPECT_TRUE(given.velocities);
  // Without the recorded settings the files differ (so the check below can fail).
  LoggerOptions plain;
  plain.out_dir = rig.dir / "plain";
  const LoggerStats plain_replay = ReplayRawLog(options.raw_log, rig.model, plain, "");
  ASSERT_EQ(plain_replay.files.size(), live.size());
  EXPECT_NE(FileText(plain_replay.files[0]), FileText(live[0]));

  const LoggerStats replay = ReplayRawLog(options.raw_log, rig.model, again, "");
  EXPECT_TRUE(replay.error.empty()) << replay.error;
  ASSERT_EQ(replay.files.size(), live.size());
  int real_cells = 0;
  for (size_t i = 0; i < live.size(); ++i) {
    SCOPED_TRACE(live[i]);
    EXPECT_EQ(std::filesystem::path(replay.files[i]).filename(),
              std::filesystem::path(live[i]).filename());
    const std::string live_text = FileText(live[i]);
    const std::string replay_text = FileText(replay.files[i]);
    EXPECT_TRUE(DataLines(live_text) == DataLines(replay_text)) << "the rows differ";
    EXPECT_TRUE(live_text == replay_text) << "the files differ";
    real_cells += ReadDataFile(live[i]).cells[2];
  }
  EXPECT_GT(real_cells, 100);
}

// A child process logs a stream it publishes itself, in step with the wall clock (one state and
// one set-point per 0.512 ms tick, sim time = wall time since its start), and notes in shared
// memory the newest sim time it has published. The parent kills it with SIGKILL mid-run. The file
// must parse, and hold every row up to 100 ms before the newest published time.
TEST(LoggerNode, AKillDuringLoggingLeavesAParseableFileMissingAtMost100ms) {
  TempDir dir;
  auto* published_us = static_cast<std::atomic<int64_t>*>(
      mmap(nullptr, sizeof(std::atomic<int64_t>), PROT_READ | PROT_WRITE,
           MAP_SHARED | MAP_ANONYMOUS, -1, 0));
  ASSERT_NE(published_us, MAP_FAILED);
  new (published_us) std::atomic<int64_t>(-1);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
    core::Bus bus("memq://");
    LoggerOptions options;
    options.out_dir = dir.path.string();
    options.name = "killed";
    options.split_per_plan = false;
    LoggerNode node(bus, model, options);
    const auto start = std::chrono::steady_clock::now();
    int64_t tick = 0;
    while (true) {
      const auto elapsed_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                  std::chrono::steady_clock::now() - start)
                                  .count();
      for (; tick * 512 <= elapsed_us; ++tick) {
        bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 0.001 * static_cast<double>(tick)));
        bus.Publish("ARM_SETPOINT", Setpoint(tick, tick, 1, 0.001 * static_cast<double>(tick)));
        bus.HandleAvailable();
        published_us->store(tick * 512);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const int64_t at_kill_us = published_us->load();
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  EXPECT_TRUE(WIFSIGNALED(status));
  ASSERT_GT(at_kill_us, 1'000'000);  // the child ran for more than a second
  const RunTable table = ReadDataFile(dir / "killed.csv");
  EXPECT_FALSE(table.closed);
  const double missing_s = static_cast<double>(at_kill_us) * 1e-6 - table.time_s.back();
  std::cout << "killed at sim time " << static_cast<double>(at_kill_us) * 1e-6 << " s; the file "
            << "ends at " << table.time_s.back() << " s (" << table.rows()
            << " rows): " << missing_s * 1e3 << " ms missing\n";
  EXPECT_LE(missing_s, 0.1);
  EXPECT_EQ(table.lost[0] + table.lost[1], 0);
  // Every row up to the end is there: one per tick from the first.
  EXPECT_NEAR(table.time_s.back() - table.time_s.front(),
              static_cast<double>(table.rows() - 1) * 512e-6, 1e-6);
  munmap(published_us, sizeof(std::atomic<int64_t>));
}

// A child process runs `options`' logger on a stream it publishes in step with the wall clock
// (sim time = wall time since its start, plus `sim_start_s`) and is killed with SIGKILL once it
// has published `run_ms` of it. Returns the newest sim time published (us).
int64_t LogInAChildAndKillIt(const LoggerOptions& options, double sim_start_s, int run_ms) {
  auto* published_us = static_cast<std::atomic<int64_t>*>(
      mmap(nullptr, sizeof(std::atomic<int64_t>), PROT_READ | PROT_WRITE,
           MAP_SHARED | MAP_ANONYMOUS, -1, 0));
  EXPECT_NE(published_us, MAP_FAILED);
  new (published_us) std::atomic<int64_t>(-1);
  const pid_t child = fork();
  EXPECT_GE(child, 0);
  if (child == 0) {
    core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
    core::Bus bus("memq://");
    LoggerNode node(bus, model, options);
    const auto start = std::chrono::steady_clock::now();
    const auto first = static_cast<int64_t>(sim_start_s / 512e-6);
    int64_t tick = first;
    while (true) {
      const auto elapsed_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                  std::chrono::steady_clock::now() - start)
                                  .count();
      for (; (tick - first) * 512 <= elapsed_us; ++tick) {
        bus.Publish("SIM_ARM_STATE", ArmState(tick, tick, 0.001 * static_cast<double>(tick)));
        bus.Publish("ARM_SETPOINT", Setpoint(tick, tick, 1, 0.001 * static_cast<double>(tick)));
        bus.HandleAvailable();
        published_us->store(tick * 512);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  // Killed once the child has published (and so logged) `run_ms` of its stream, however long a
  // loaded machine takes to start it; a minute's deadline only for a child that never gets there.
  const int64_t first_us = static_cast<int64_t>(sim_start_s / 512e-6) * 512;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (published_us->load() - first_us < int64_t{run_ms} * 1000 &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const int64_t at_kill_us = published_us->load();
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  EXPECT_TRUE(WIFSIGNALED(status));
  munmap(published_us, sizeof(std::atomic<int64_t>));
  return at_kill_us;
}

// What `restart: on-failure` does: the same command line again after a kill -9. The restarted
// logger writes the next file, which says what it continues; both files read back.
TEST(LoggerNode, KilledWithSigkillAndRestartedWithTheSameOptionsItWritesTheNextFile) {
  TempDir dir;
  LoggerOptions options;
  options.out_dir = dir.path.string();
  options.name = "lab";
  options.split_per_plan = false;
  LogInAChildAndKillIt(options, 0.0, 600);
  LogInAChildAndKillIt(options, 10.0, 600);
  LogInAChildAndKillIt(options, 20.0, 600);
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"lab.1.csv", "lab.2.csv", "lab.csv"}));
  const std::vector<RunTable> tables = ReadInputs({dir.path.string()}, ImportOptions{});
  ASSERT_EQ(tables.size(), 3u);
  EXPECT_EQ(tables[0].source, dir / "lab.csv");
  EXPECT_EQ(tables[1].continues, "lab.csv");
  EXPECT_EQ(tables[2].continues, "lab.1.csv");
  EXPECT_GE(tables[1].time_s.front(), 10.0 - 0.001);
  EXPECT_GE(tables[2].time_s.front(), 20.0 - 0.001);
  for (const RunTable& table : tables) {
    EXPECT_FALSE(table.closed);
    EXPECT_GT(table.rows(), 100u) << table.source;
  }
}

}  // namespace
}  // namespace sirupp::logger
