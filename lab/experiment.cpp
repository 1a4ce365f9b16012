#include "lab/experiment.hpp"

#include <strings.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "control/servo_bank.hpp"
#include "core/units.hpp"
#include "hardware/arm_link.hpp"
#include "hardware/emulated_arm.hpp"
#include "hardware/picservo_module.hpp"
#include "logger/analysis.hpp"
#include "servo/chip_gains.hpp"
#include "sim/arm_world.hpp"

namespace sirupp::lab {
namespace {

constexpr double kMaxRunS = 20;
namespace nmc = hardware::nmc;  // a set that has not finished by then is cut off

nmc::Gains BoardGains(const core::ServoParams& servo) {
  return hardware::BoardGains(servo::ChipGainsFromModel(servo));
}

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

std::vector<int> SetJoints(int set) {
  switch (set) {
    case 1:
      return {1};
    case 2:
      return {2};
    case 3:
      return {3};
    case 4:
      return {1, 2};
    case 5:
      return {1, 3};
    case 6:
      return {2, 3};
    case 7:
      return {1, 2, 3};
    default:
      throw std::invalid_argument("movement set " + std::to_string(set) +
                                  ": allowed 1..7 (I..VII)");
  }
}

const char* RomanSet(int set) {
  static const char* const kRoman[] = {"?", "I", "II", "III", "IV", "V", "VI", "VII"};
  return set >= 1 && set <= 7 ? kRoman[set] : "?";
}

int SetFromName(const std::string& name) {
  for (int k = 1; k <= 7; ++k) {
    if (strcasecmp(name.c_str(), RomanSet(k)) == 0 || name == std::to_string(k)) return k;
  }
  return 0;
}

const std::vector<PaperRow>& PaperTable() {
  // SIRUPP paper (Nugraha 2009), Table II: error mean virtual vs real, transient and steady state.
  static const std::vector<PaperRow> kRows = {
      {1, 1, 3.53, 1.72}, {2, 2, 4.32, 0.17}, {3, 3, 4.94, 0.40}, {4, 1, 3.81, 1.63},
      {4, 2, 5.16, 0.23}, {5, 1, 3.90, 5.21}, {5, 3, 1.80, 0.47}, {6, 2, 4.33, 5.33},
      {6, 3, 0.32, 0.75}, {7, 1, 3.66, 1.89}, {7, 2, 4.81, 0.28}, {7, 3, 5.54, 0.65}};
  return kRows;
}

bool WithinTolerance(double ours, double paper) {
  return std::isfinite(ours) && std::abs(ours - paper) <= std::max(0.3 * paper, 0.5);
}

VirtualRun RunVirtual(const core::RobotModel& model, int set, const ExperimentOptions& options) {
  const std::vector<int> joints = SetJoints(set);
  const auto n = static_cast<size_t>(model.num_joints());
  sim::ArmWorld world(model, core::Environment{});
  world.SetJointState(std::vector<double>(n, 0.0));
  control::ServoBank bank(model);
  bank.ServoOn(world.State().position);
  std::vector<control::JointMove> moves(n);
  for (int j : joints) {
    const core::ServoParams& servo = model.joints[static_cast<size_t>(j - 1)].servo;
    moves[static_cast<size_t>(j - 1)] = {true, 90 * kDeg, servo.default_velocity,
                                         servo.default_acceleration};
  }
  const double tick = model.servo_tick_s;
  VirtualRun run;
  run.set = set;
  run.move_tick = static_cast<size_t>(std::lround(options.hold_before_s / tick));
  const auto settle_ticks = static_cast<size_t>(std::lround(options.settle_after_s / tick));
  const auto max_ticks = static_cast<size_t>(kMaxRunS / tick);
  size_t done_tick = 0;
  core::ArmCommand command;
  command.mode = core::CommandMode::kEffort;
  for (size_t k = 0; k < max_ticks; ++k) {
    if (k == run.move_tick) bank.Load(moves);
    command.effort = bank.Tick(world.State().position);
    world.Step(command);
    const core::ArmState state = world.State();
    std::vector<double> setpoint(n);
    std::vector<int8_t> done(n);
    for (size_t j = 0; j < n; ++j) {
      setpoint[j] = bank.SetpointPosition(static_cast<int>(j));
      done[j] = bank.servo(static_cast<int>(j)).profile().done() ? 1 : 0;
    }
    run.setpoint.push_back(setpoint);
    run.position.push_back(state.position);
    run.done.push_back(done);
    if (k > run.move_tick && done_tick == 0 && bank.AllDone()) done_tick = k;
    if (done_tick > 0 && k >= done_tick + settle_ticks) break;
  }
  return run;
}

std::vector<std::vector<double>> RunReal(const core::RobotModel& model,
                                         const std::optional<hardware::RealArmParams>& effects,
                                         const VirtualRun& virtual_run) {
  const int n = model.num_joints();
  const auto un = static_cast<size_t>(n);
  hardware::ArmOptions arm_options;
  arm_options.start_positions.assign(un, 0.0);
  arm_options.effects = effects;
  hardware::EmulatedArm arm(model, arm_options);
  std::vector<hardware::PicServoModule> modules(un);
  const int latency =
      effects ? static_cast<int>(std::lround(effects->command_latency_s / model.servo_tick_s)) : 0;
  // What the bridge does at start-up, per module: address, gains, amplifier on and servo holding.
  for (int j = 0; j < n; ++j) {
    hardware::PicServoModule& m = modules[static_cast<size_t>(j)];
    const auto a = static_cast<uint8_t>(j + 1);
    m.SetCommandLatencyTicks(latency);
    m.Handle(nmc::SetAddress(0, a, 0xFF, false), true, true);
    m.Handle(nmc::SetGain(a, BoardGains(model.joints[static_cast<size_t>(j)].servo)), true, true);
    m.Handle(nmc::StopMotor(a, nmc::kAmpEnable | nmc::kStopAbrupt), true, true);
  }
  std::vector<servo::JointDrive> drives;
  for (const core::Joint& joint : model.joints) drives.emplace_back(joint, model.servo_tick_s);
  std::vector<std::vector<double>> real;
  std::vector<int> pwm(un);
  std::vector<bool> brakes(un);
  for (size_t k = 0; k < virtual_run.position.size(); ++k) {
    if (k == virtual_run.move_tick) {
      // The bridge's LOAD_TRAJ per moved joint (TrajectoryFor), started at once.
      for (int j : SetJoints(virtual_run.set)) {
        const auto u = static_cast<size_t>(j - 1);
        const servo::JointDrive& d = drives[u];
        const core::ServoParams& servo = model.joints[u].servo;
        nmc::Trajectory t;
        t.control = nmc::kLoadPosition | nmc::kLoadVelocity | nmc::kLoadAcceleration |
                    nmc::kEnableServo | nmc::kStartNow;
        t.position = static_cast<int32_t>(d.ToCounts(90 * kDeg));
        t.velocity = static_cast<uint32_t>(
            std::min<int64_t>(d.VelocityWord(servo.default_velocity), nmc::kMaxVelocityWord));
        t.acceleration = static_cast<uint32_t>(std::min<int64_t>(
            d.AccelerationWord(servo.default_acceleration), nmc::kMaxAccelerationWord));
        modules[u].Handle(nmc::LoadTrajectory(static_cast<uint8_t>(j), t), true, true);
      }
    }
    for (int j = 0; j < n; ++j) {
      const auto u = static_cast<size_t>(j);
      pwm[u] = modules[u].Tick(arm.Inputs(j));
      brakes[u] = !modules[u].amp_enabled();
    }
    arm.SetBrakes(brakes);
    arm.Step(pwm);
    std::vector<double> row(un);
    for (int j = 0; j < n; ++j) {
      row[static_cast<size_t>(j)] =
          drives[static_cast<size_t>(j)].FromCounts(arm.Inputs(j).encoder_counts);
    }
    real.push_back(row);
  }
  return real;
}

logger::RunTable MakeTable(const core::RobotModel& model, const VirtualRun& virtual_run,
                           const std::vector<std::vector<double>>& real) {
  logger::RunTable table;
  std::vector<logger::JointInfo> joints;
  for (const core::Joint& joint : model.joints) {
    joints.push_back({joint.name, joint.type == core::JointType::kPrismatic});
  }
  table.Reset(joints);
  table.label = "set" + std::to_string(virtual_run.set);
  table.source = std::string("movement set ") + RomanSet(virtual_run.set) + " (in memory)";
  table.real_on_sim_clock = true;
  table.closed = true;
  for (size_t k = 0; k < virtual_run.position.size(); ++k) {
    table.time_s.push_back(static_cast<double>(k + 1) * model.servo_tick_s);
    table.move_id.push_back(k >= virtual_run.move_tick ? 1 : 0);
    for (size_t j = 0; j < joints.size(); ++j) {
      const double scale = joints[j].scale();
      table.position[j][0].push_back(virtual_run.setpoint[k][j] * scale);
      table.position[j][1].push_back(virtual_run.position[k][j] * scale);
      table.position[j][2].push_back(k < real.size() ? real[k][j] * scale : std::nan(""));
      table.done[j].push_back(virtual_run.done[k][j]);
    }
    for (size_t s = 0; s < logger::kNumStreams; ++s) {
      table.age_s[s].push_back(0.0);
      ++table.cells[s];
    }
  }
  return table;
}

std::vector<TableRow> TableII(const std::vector<logger::RunTable>& tables) {
  std::vector<TableRow> rows;
  logger::AnalysisOptions options;
  options.last_move_only = true;
  for (const logger::RunTable& table : tables) {
    int set = 0;
    if (table.label.rfind("set", 0) == 0) set = std::atoi(table.label.c_str() + 3);
    if (set < 1 || set > 7) continue;
    const logger::Analysis analysis = logger::Analyze(table, options);
    for (int joint : SetJoints(set)) {
      for (const logger::MoveResult& move : analysis.moves) {
        if (move.joint != joint) continue;
        const logger::PairMetrics& m = move.pairs[static_cast<size_t>(logger::Pair::kVirtReal)];
        TableRow row;
        row.set = set;
        row.joint = joint;
        row.transient_deg = m.mean_transient;
        row.steady_deg = m.mean_steady;
        row.start_delay_real_s =
            move.streams[static_cast<size_t>(logger::Stream::kReal)].start_delay_s;
        row.start_delay_virtual_s =
            move.streams[static_cast<size_t>(logger::Stream::kVirtual)].start_delay_s;
        rows.push_back(row);
      }
    }
  }
  return rows;
}

void WriteDataFile(const std::string& path, const core::RobotModel& model,
                   const VirtualRun& virtual_run, const std::vector<std::vector<double>>& real) {
  logger::ColumnLayout layout;
  std::string joints = std::to_string(model.joints.size()) + ":";
  for (size_t j = 0; j < model.joints.size(); ++j) {
    const core::Joint& joint = model.joints[j];
    layout.joints.push_back({joint.name, joint.type == core::JointType::kPrismatic});
    joints += std::string(j ? ";" : "") + " j" + std::to_string(j + 1) + " " + joint.name + " " +
              layout.joints.back().unit();
  }
  const std::vector<std::string> header = {
      "model: " + model.name + " (" + model.source_file + ")", "joints: " + joints,
      "plan: config/plans/set" + std::to_string(virtual_run.set) + ".plan",
      "mode: sirupp fit-emulator, in one process: virtual arm in lockstep, emulated real arm in "
      "emulated time, both on the sim clock"};
  logger::DataFileWriter writer(path, header, layout);
  const auto tick_us = static_cast<int64_t>(std::llround(model.servo_tick_s * 1e6));
  for (size_t k = 0; k < virtual_run.position.size(); ++k) {
    logger::Sample set, virt, arm;
    set.stream = logger::Stream::kSetpoint;
    set.move_id = k >= virtual_run.move_tick ? 1 : 0;
    set.position = virtual_run.setpoint[k];
    set.done = virtual_run.done[k];
    virt.stream = logger::Stream::kVirtual;
    virt.position = virtual_run.position[k];
    arm.stream = logger::Stream::kReal;
    arm.position = real[k];
    logger::Row row;
    row.time_us = static_cast<int64_t>(k + 1) * tick_us;
    arm.utime = row.time_us;  // emulated time: the sim clock
    row.cell = {&set, &virt, &arm};
    writer.Append(row);
  }
  writer.Close(std::to_string(virtual_run.position.size()) + " rows");
}

double HoldStrayDeg(const VirtualRun& virtual_run, const std::vector<std::vector<double>>& real) {
  const std::vector<int> moved = SetJoints(virtual_run.set);
  double stray = 0;
  for (size_t k = 0; k < real.size() && k < virtual_run.position.size(); ++k) {
    for (size_t j = 0; j < real[k].size(); ++j) {
      if (std::find(moved.begin(), moved.end(), static_cast<int>(j) + 1) != moved.end()) continue;
      stray = std::max(stray, std::abs(real[k][j] - virtual_run.position[k][j]) / kDeg);
    }
  }
  return stray;
}

std::vector<TableRow> RunExperiment(const core::RobotModel& virtual_model,
                                    const core::RobotModel& real_model,
                                    const std::optional<hardware::RealArmParams>& effects,
                                    const ExperimentOptions& options, const std::string& data_dir,
                                    double* hold_stray_deg) {
  std::vector<logger::RunTable> tables;
  if (hold_stray_deg) *hold_stray_deg = 0;
  for (int set : options.sets) {
    const VirtualRun v = RunVirtual(virtual_model, set, options);
    const std::vector<std::vector<double>> real = RunReal(real_model, effects, v);
    if (hold_stray_deg) *hold_stray_deg = std::max(*hold_stray_deg, HoldStrayDeg(v, real));
    if (!data_dir.empty()) {
      WriteDataFile(data_dir + "/lab-set" + std::to_string(set) + ".csv", real_model, v, real);
    }
    tables.push_back(MakeTable(real_model, v, real));
  }
  return TableII(tables);
}

Comparison Compare(const std::vector<TableRow>& ours) {
  Comparison c;
  c.start_delay_min_s = std::nan("");
  c.start_delay_max_s = std::nan("");
  double sum = 0;
  for (const TableRow& row : ours) {
    sum += (row.transient_deg + row.steady_deg) / 2;
    if (row.joint == 1) {
      const double d = row.start_delay_real_s;
      if (!(d >= c.start_delay_min_s)) c.start_delay_min_s = d;
      if (!(d <= c.start_delay_max_s)) c.start_delay_max_s = d;
    }
    for (const PaperRow& p : PaperTable()) {
      if (p.set != row.set || p.joint != row.joint) continue;
      ++c.rows;
      if (WithinTolerance(row.transient_deg, p.transient_deg) &&
          WithinTolerance(row.steady_deg, p.steady_deg)) {
        ++c.rows_within;
      }
    }
  }
  c.mean_error_deg = ours.empty() ? 0 : sum / static_cast<double>(ours.size());
  // Coupling over the sets whose joints the paper names unambiguously (IV and VII): each joint's
  // transient error there minus the same joint's alone (I, II, III).
  auto find = [&](int set, int joint) -> const TableRow* {
    for (const TableRow& r : ours) {
      if (r.set == set && r.joint == joint) return &r;
    }
    return nullptr;
  };
  auto paper = [](int set, int joint) {
    for (const PaperRow& p : PaperTable()) {
      if (p.set == set && p.joint == joint) return p.transient_deg;
    }
    return std::nan("");
  };
  int count = 0;
  double ours_sum = 0, paper_sum = 0;
  for (int set : {4, 7}) {
    for (int joint : SetJoints(set)) {
      const TableRow* multi = find(set, joint);
      const TableRow* alone = find(joint, joint);
      if (multi == nullptr || alone == nullptr) continue;
      ours_sum += multi->transient_deg - alone->transient_deg;
      paper_sum += paper(set, joint) - paper(joint, joint);
      ++count;
    }
  }
  if (count > 0) {
    c.coupling_ours_deg = ours_sum / count;
    c.coupling_paper_deg = paper_sum / count;
  }
  return c;
}

std::string FormatComparison(const std::vector<TableRow>& ours, bool with_paper) {
  std::ostringstream out;
  out << "| set | joint | transient (deg) |" << (with_paper ? " paper |" : "") << " steady (deg) |"
      << (with_paper ? " paper | within |" : "") << " real start (s) | virtual start (s) |\n"
      << "|---|---|---:|" << (with_paper ? "---:|" : "") << "---:|"
      << (with_paper ? "---:|:---:|" : "") << "---:|---:|\n";
  for (const TableRow& row : ours) {
    const PaperRow* p = nullptr;
    for (const PaperRow& candidate : PaperTable()) {
      if (candidate.set == row.set && candidate.joint == row.joint) p = &candidate;
    }
    out << "| " << RomanSet(row.set) << " | " << row.joint << " | " << Fixed(row.transient_deg, 2)
        << " |";
    if (with_paper) out << " " << (p ? Fixed(p->transient_deg, 2) : "-") << " |";
    out << " " << Fixed(row.steady_deg, 2) << " |";
    if (with_paper) {
      const bool within = p && WithinTolerance(row.transient_deg, p->transient_deg) &&
                          WithinTolerance(row.steady_deg, p->steady_deg);
      out << " " << (p ? Fixed(p->steady_deg, 2) : "-") << " | " << (within ? "yes" : "no") << " |";
    }
    out << " " << Fixed(row.start_delay_real_s, 3) << " | " << Fixed(row.start_delay_virtual_s, 3)
        << " |\n";
  }
  const Comparison c = Compare(ours);
  out << "\n";
  if (with_paper) {
    out << "rows within 30 % or 0.5 deg of the paper (both means): " << c.rows_within << " of "
        << c.rows << "\n";
  }
  out << "joint 1 of the real arm starts " << Fixed(c.start_delay_min_s, 3) << " .. "
      << Fixed(c.start_delay_max_s, 3) << " s after the move"
      << (with_paper ? " (paper: 0.35 .. 0.40 s)" : "") << "\n"
      << "coupling (sets IV, VII minus the same joint alone, transient): "
      << Fixed(c.coupling_ours_deg, 2) << " deg"
      << (with_paper ? " (paper: " + Fixed(c.coupling_paper_deg, 2) + " deg)" : "") << "\n"
      << "mean error over the table (transient and steady): " << Fixed(c.mean_error_deg, 3)
      << " deg\n";
  return out.str();
}

}  // namespace sirupp::lab
