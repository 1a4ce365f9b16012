#include "lab/identify.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "core/dynamics.hpp"
#include "core/errors.hpp"
#include "core/units.hpp"
#include "core/yaml_reader.hpp"
#include "lab/box_search.hpp"
#include "logger/analysis.hpp"
#include "servo/picservo.hpp"
#include "servo/servo_units.hpp"
#include "sim/arm_world.hpp"

namespace sirupp::lab {
namespace {

constexpr int kParams =
    6;  // static, Coulomb +/- as fractions of static, viscous, Stribeck, armature
constexpr double kFirstSimplex = 0.1;  // the search's first simplex, in units of its box
constexpr int kSpreadStarts = 20;      // starts spread over the box (Identify), at most a quarter
                                       // of the budget
constexpr int kPrimes[kParams] = {2, 3, 5, 7, 11, 13};

// The Halton sequence's element `index` in base `base`, in [0, 1).
double Halton(int index, int base) {
  double result = 0, f = 1;
  for (int i = index; i > 0; i /= base) {
    f /= base;
    result += f * (i % base);
  }
  return result;
}

// One table, prepared: the set-point per servo tick (SI) and the fresh real samples.
struct Track {
  size_t table = 0;                           // its table (Identify's tables)
  double t0 = 0;                              // the time of tick 0 on the table's axis
  size_t first_row = 0;                       // rows before it are not simulated
  std::vector<double> start;                  // SI, per joint
  std::vector<std::vector<double>> setpoint;  // [tick][joint], SI
  struct Sample {
    size_t tick;
    size_t joint;
    double real;    // SI
    double weight;  // its move's weight in the fit (MoveWeight)
  };
  std::vector<Sample> samples;
};

double Interpolate(const std::vector<double>& t, const std::vector<double>& v, size_t* cursor,
                   double at) {
  while (*cursor + 1 < t.size() && t[*cursor + 1] <= at) ++*cursor;
  const size_t i = *cursor;
  if (i + 1 >= t.size() || std::isnan(v[i + 1])) return v[i];
  const double f = (at - t[i]) / (t[i + 1] - t[i]);
  return v[i] + std::clamp(f, 0.0, 1.0) * (v[i + 1] - v[i]);
}

// The row the table's last move starts at (where a known move_id last differs from the one
// before it), 0 when the move_id never changes.
size_t LastMoveRow(const logger::RunTable& table) {
  const std::vector<size_t> starts = table.MoveStarts();
  return starts.empty() ? 0 : starts.back();
}

// The weight in the fit of the move of `table` that row `row` is in: 1 for a movement set's last
// move (a file a plan ran: the move Table II measures), `others` for every other move.
// last_move_row: LastMoveRow(table).
double MoveWeight(const logger::RunTable& table, size_t last_move_row, size_t row, double others) {
  return !table.plan_name.empty() && row >= last_move_row ? 1.0 : others;
}

// The track of `table` from row `first_row` on; its samples weighted by MoveWeight(.., others).
Track Prepare(const core::RobotModel& model, const logger::RunTable& table, size_t first_row = 0,
              double others = 1, bool need_real = true) {
  const size_t n = model.joints.size();
  if (table.joints.size() != n) {
    throw core::ConfigError({table.source, 0, 0}, "joints",
                            std::to_string(table.joints.size()) +
                                " joints in the data; the model " + model.name + " has " +
                                std::to_string(n));
  }
  // Rows with a set-point for every joint: the time axis of the track.
  std::vector<double> t;
  std::vector<std::vector<double>> set(n);
  std::vector<size_t> rows;
  for (size_t i = first_row; i < table.rows(); ++i) {
    bool complete = true;
    for (size_t j = 0; j < n; ++j) complete &= !std::isnan(table.position[j][0][i]);
    if (!complete) continue;
    t.push_back(table.time_s[i]);
    for (size_t j = 0; j < n; ++j)
      set[j].push_back(table.position[j][0][i] / table.joints[j].scale());
    rows.push_back(i);
  }
  if (t.size() < 2) {
    throw core::ConfigError(
        {table.source, 0, 0}, "set-point",
        "no set-point data to drive the model with (" + std::to_string(t.size()) + " rows)");
  }
  Track track;
  track.t0 = t.front();
  track.first_row = first_row;
  const double tick = model.servo_tick_s;
  const auto ticks = static_cast<size_t>((t.back() - t.front()) / tick) + 1;
  std::vector<size_t> cursor(n, 0);
  for (size_t k = 0; k < ticks; ++k) {
    std::vector<double> row(n);
    for (size_t j = 0; j < n; ++j) {
      row[j] = Interpolate(t, set[j], &cursor[j], t.front() + static_cast<double>(k) * tick);
    }
    track.setpoint.push_back(row);
  }
  // The arm starts where the first real sample has it (else at the set-point).
  track.start = track.setpoint.front();
  for (size_t j = 0; j < n; ++j) {
    for (size_t i = first_row; i < table.rows(); ++i) {
      if (!std::isnan(table.position[j][2][i])) {
        track.start[j] = table.position[j][2][i] / table.joints[j].scale();
        break;
      }
    }
    track.start[j] =
        std::clamp(track.start[j], model.joints[j].position_min, model.joints[j].position_max);
  }
  // The real samples of each move on the real arm's own clock from the move's start (a sim that
  // slipped does not compress them); those that fall past the next move's start are left out.
  const double period = table.period_s();
  std::vector<size_t> moves = {first_row};
  for (size_t start : table.MoveStarts()) {
    if (start > first_row) moves.push_back(start);
  }
  moves.push_back(table.rows());
  const size_t last_move_row = LastMoveRow(table);
  for (size_t m = 0; m + 1 < moves.size(); ++m) {
    const double weight = MoveWeight(table, last_move_row, moves[m], others);
    const std::vector<double> real_at = table.RealSampleTimes(moves[m], moves[m], moves[m + 1]);
    for (size_t i = moves[m]; i < moves[m + 1]; ++i) {
      if (!table.Fresh(logger::Stream::kReal, i, period)) continue;
      const double at = real_at[i - moves[m]] - t.front();
      if (!(at >= 0) ||
          (moves[m + 1] < table.rows() && at + t.front() >= table.time_s[moves[m + 1]]))
        continue;
      const auto k = static_cast<size_t>(std::lround(at / tick));
      if (k >= ticks) continue;
      for (size_t j = 0; j < n; ++j) {
        const double real = table.position[j][2][i];
        if (!std::isnan(real)) {
          track.samples.push_back({k, j, real / table.joints[j].scale(), weight});
        }
      }
    }
  }
  std::stable_sort(track.samples.begin(), track.samples.end(),
                   [](const Track::Sample& a, const Track::Sample& b) { return a.tick < b.tick; });
  if (track.samples.empty() && need_real) {
    throw core::ConfigError({table.source, 0, 0}, "real",
                            "no real-arm samples to fit the model to");
  }
  return track;
}

// Simulates the virtual arm along the track: sirupp-sim's ODE arm of the model (sim::ArmWorld)
// under one PIC-SERVO chip per joint with the model's gains, held at the logged set-point each
// tick (StopHere), whose PWM becomes an effort command as sirupp-control's ServoBank makes it
// (JointDrive::EffortFromPwm). Adds each joint's squared error (rad^2, each sample's times its
// weight), the sum of the weights and the sample count; with
// `trace`, also the positions at every tick. Throws std::runtime_error naming the joint if ODE's
// integration blows up.
void Simulate(const core::RobotModel& model, const Track& track, std::vector<double>* sse,
              std::vector<double>* weight, std::vector<int64_t>* count,
              std::vector<std::vector<double>>* trace = nullptr) {
  const size_t n = model.joints.size();
  sim::ArmWorld world(model, core::Environment{});
  world.SetJointState(track.start);
  std::vector<servo::JointDrive> drives;
  std::vector<servo::PicServo> chips(n);
  for (size_t j = 0; j < n; ++j) {
    drives.emplace_back(model.joints[j], model.servo_tick_s);
    chips[j].SetGains(servo::GainsFromModel(model.joints[j].servo));
    chips[j].ServoOn(drives[j].ToCounts(track.start[j]));
  }
  core::ArmCommand command;
  command.mode = core::CommandMode::kEffort;
  command.effort.assign(n, 0.0);
  std::vector<double> position = world.State().position;
  size_t next = 0;
  for (size_t k = 0; k < track.setpoint.size(); ++k) {
    for (size_t j = 0; j < n; ++j) {
      const int64_t actual = drives[j].ToCounts(position[j]);
      chips[j].StopHere(drives[j].ToCounts(track.setpoint[k][j]), actual);
      command.effort[j] = drives[j].EffortFromPwm(chips[j].Tick(actual));
    }
    world.Step(command);
    position = world.State().position;
    if (trace) trace->push_back(position);
    while (next < track.samples.size() && track.samples[next].tick <= k) {
      const Track::Sample& s = track.samples[next++];
      if (s.tick != k) continue;
      const double e = position[s.joint] - s.real;
      (*sse)[s.joint] += s.weight * e * e;
      (*weight)[s.joint] += s.weight;
      ++(*count)[s.joint];
    }
  }
}

// `trace` (positions after each tick, SI) as `stream` of `out`, a copy of the table it was
// simulated along: at each row from `first_row` on, the tick nearest the row's time (tick 0 at
// `t0`); earlier rows empty. Each value is fresh (age 0).
void PutStream(const std::vector<std::vector<double>>& trace, double t0, double tick,
               size_t first_row, logger::Stream stream, logger::RunTable* out) {
  const auto s = static_cast<size_t>(stream);
  const auto last = static_cast<long>(trace.size()) - 1;
  for (size_t i = 0; i < out->rows(); ++i) {
    const auto k =
        static_cast<size_t>(std::clamp<long>(std::lround((out->time_s[i] - t0) / tick), 0, last));
    for (size_t j = 0; j < out->joints.size(); ++j) {
      out->position[j][s][i] = i < first_row ? std::nan("") : trace[k][j] * out->joints[j].scale();
    }
    out->age_s[s][i] = i < first_row ? std::nan("") : 0;
  }
}

// What one simulation of all the data scores, per joint.
struct Score {
  std::vector<double> sse;  // squared angle error over the fresh real samples (rad^2), weighted
  std::vector<double> sse_weights;  // the sum of their weights
  std::vector<int64_t> count;       // those samples
  // Table II's measure (logger/analysis.hpp): over the moves the joint takes part in, each move's
  // mean |virtual - real| over the transient and over the steady state (deg or mm), weighted
  // (MoveWeight) and summed.
  std::vector<double> table;
  std::vector<double> weights;  // the sum of the weights of those means
};

// Adds Table II's measure of `virt` (a table whose virtual stream is the simulation) to `score`.
// `joints`: the fitted ones (0-based); `others`: MoveWeight's.
void AddTableMeans(const logger::RunTable& virt, const std::vector<size_t>& joints, bool last_move,
                   double others, Score* score) {
  logger::AnalysisOptions analysis;
  // Only the last move when the others count nothing: the analysis then has less to do.
  analysis.last_move_only = last_move || (others == 0 && !virt.plan_name.empty());
  for (size_t j : joints) analysis.joints.push_back(static_cast<int>(j + 1));
  const size_t last_move_row = LastMoveRow(virt);
  for (const logger::MoveResult& move : logger::Analyze(virt, analysis).moves) {
    const logger::PairMetrics& m = move.pairs[static_cast<size_t>(logger::Pair::kVirtReal)];
    const double w = MoveWeight(virt, last_move_row, move.begin, others);
    const auto j = static_cast<size_t>(move.joint - 1);
    for (double mean : {m.mean_transient, m.mean_steady}) {
      if (!std::isfinite(mean) || w <= 0) continue;
      score->table[j] += w * mean;
      score->weights[j] += w;
    }
  }
}

// The search's box for one joint: the static level (log scale), the Coulomb levels as fractions
// of it (so static >= Coulomb, as the model file requires), the viscous coefficient, the Stribeck
// speed and the armature (log scales). The bounds come from the joint itself, so they fit any
// model: no friction level above the joint's maximum effort, no viscous friction that would take
// all of it at the servo's default speed, no armature that would at its default acceleration, a
// Stribeck speed from 0.1 % to twice the joint's top speed.
std::array<BoxAxis, kParams> Box(const core::Joint& joint) {
  const double effort = joint.effort_max;
  const double viscous = effort / joint.servo.default_velocity;
  const double armature = effort / joint.servo.default_acceleration;
  return {{{1e-3 * effort, 0.5 * effort, true},
           {0.02, 1.0, false},
           {0.02, 1.0, false},
           {1e-5 * viscous, viscous, true},
           {1e-3 * joint.velocity_max, 2 * joint.velocity_max, true},
           {1e-5 * armature, armature, true}}};
}

// Joint j's values as a point of its box, and back.
std::vector<double> ToUnit(const core::RobotModel& m, size_t j) {
  const core::Friction& f = m.joints[j].friction;
  const std::array<BoxAxis, kParams> box = Box(m.joints[j]);
  const double up = f.static_effort > 0 ? f.coulomb_positive / f.static_effort : 1;
  const double down = f.static_effort > 0 ? f.coulomb_negative / f.static_effort : 1;
  return {box[0].ToUnit(f.static_effort),
          box[1].ToUnit(up),
          box[2].ToUnit(down),
          box[3].ToUnit(f.viscous),
          box[4].ToUnit(f.stribeck_velocity),
          box[5].ToUnit(m.joints[j].armature)};
}

void FromUnit(core::RobotModel& m, size_t j, const std::vector<double>& u) {
  core::Friction& f = m.joints[j].friction;
  const std::array<BoxAxis, kParams> box = Box(m.joints[j]);
  f.static_effort = box[0].FromUnit(u[0]);
  f.coulomb_positive = box[1].FromUnit(u[1]) * f.static_effort;
  f.coulomb_negative = box[2].FromUnit(u[2]) * f.static_effort;
  f.viscous = box[3].FromUnit(u[3]);
  f.stribeck_velocity = box[4].FromUnit(u[4]);
  m.joints[j].armature = box[5].FromUnit(u[5]);
}

// The model as sirupp-sim's ODE arm has it (docs/physics.md, "Rotor inertia"): each revolute
// joint's armature is rotor inertia about the joint axis in its child link's inertia tensor, not
// the diagonal term core::Dynamics gives a joint's armature (which is then 0 here). The two differ
// where a joint's parent turns about a parallel axis (PUMA joint 3 under joint 2, the wrist under
// joint 1): the rotor then turns with the parent too.
struct JointAxes {
  bool standard;
  // World axis of joint i (0-based) in the frames of a forward kinematics result.
  Eigen::Vector3d operator()(const core::ForwardResult& fk, size_t i) const {
    return fk.frames[standard ? i : i + 1].linear().col(2);
  }
};

core::RobotModel ArmatureInLinks(const core::RobotModel& model) {
  const core::KinematicChain chain(model);
  const JointAxes axes{model.dh_convention == core::DhConvention::kStandard};
  core::JointVector home(model.num_joints());
  for (size_t j = 0; j < model.joints.size(); ++j) {
    home[static_cast<Eigen::Index>(j)] = model.joints[j].home;
  }
  const core::ForwardResult fk = chain.Forward(home);
  core::RobotModel out = model;
  for (size_t j = 0; j < model.joints.size(); ++j) {
    core::Joint& joint = out.joints[j];
    if (joint.type == core::JointType::kRevolute) {
      const Eigen::Vector3d in_link = fk.frames[j + 1].linear().transpose() * axes(fk, j);
      out.links[j + 1].inertia_kg_m2 += joint.armature * in_link * in_link.transpose();
    }
    joint.armature = 0;  // a prismatic joint's: ODE leaves it out
  }
  return out;
}

// The torque regression. Along a track, the effort each joint's motor gave is known from the
// set-point and the real angles (the chip's PID recomputed, the model's PWM-to-effort, clamped at
// the joint's maximum effort as the sim clamps it); what the arm needs of it follows from the
// inverse dynamics of the model as the sim has it, the present armatures included. The rest is
// the joint's armature's change times its rotor term plus its friction, which for a fixed Stribeck
// speed is linear in the static and Coulomb levels, the viscous coefficient and the armature.
// Integrated over windows of W ticks (so accelerations enter as velocity changes, and encoder
// steps average out):
//
//   sum tau T - M_j(q) dv - sum bias_j T = (armature - present) rotor_j + sum friction_j(v) T
//
// The rotor term is the window's change of the rotor's speed about its axis, a_j . w_j (w_j the
// angular velocity of the joint's child link): sum over l <= j of (a_j . a_l) v_l, exact for a
// rotor that is inertia of its child link. Static friction is also measured where a stuck joint
// breaks away (the effort then, less the links' own need, between the last tick it held and the
// first it moved).
constexpr size_t kWindow = 20;             // ticks per regression window
constexpr size_t kSmooth = 4;              // velocities over +-kSmooth ticks
constexpr double kMinSlidingSpeed = 1e-4;  // rad/s (or m/s): slower is not sliding

struct Regression {
  // Per joint: window rows (sliding windows only) and breakaway estimates of static friction.
  struct Row {
    double target;              // N*m*s
    double rotor;               // the rotor term's change over the window (rad/s)
    double up, down;            // time sliding positive / negative (s), with each tick's speed
    std::vector<double> speed;  // signed speed of each tick (rad/s), for the Stribeck terms
    double travel;              // displacement (rad): the viscous term
  };
  std::vector<std::vector<Row>> rows;
  std::vector<std::vector<double>> breakaway;
};

void Collect(const core::RobotModel& model, const Track& track, Regression* out) {
  const size_t n = model.joints.size();
  const double tick = model.servo_tick_s;
  const size_t ticks = track.setpoint.size();
  // The real angles at every tick (after that tick's step), filled in between samples.
  std::vector<std::vector<double>> q(ticks, std::vector<double>(n, std::nan("")));
  for (const Track::Sample& s : track.samples) q[s.tick][s.joint] = s.real;
  for (size_t j = 0; j < n; ++j) {
    size_t last = ticks;
    for (size_t k = 0; k < ticks; ++k) {
      if (std::isnan(q[k][j])) continue;
      if (last == ticks) {
        for (size_t i = 0; i < k; ++i) q[i][j] = q[k][j];
      } else {
        for (size_t i = last + 1; i < k; ++i) {
          const double f = static_cast<double>(i - last) / static_cast<double>(k - last);
          q[i][j] = q[last][j] + f * (q[k][j] - q[last][j]);
        }
      }
      last = k;
    }
    if (last == ticks) {
      for (size_t k = 0; k < ticks; ++k) q[k][j] = track.start[j];
    } else {
      for (size_t i = last + 1; i < ticks; ++i) q[i][j] = q[last][j];
    }
  }
  // The motors' efforts: tau[k] drove the step from q[k-1] (track.start for k = 0) to q[k].
  std::vector<servo::JointDrive> drives;
  for (const core::Joint& joint : model.joints) drives.emplace_back(joint, tick);
  std::vector<servo::PicServo> chips(n);
  std::vector<int64_t> zero(n);
  for (size_t j = 0; j < n; ++j) {
    chips[j].SetGains(servo::GainsFromModel(model.joints[j].servo));
    chips[j].ServoOn(0);
    zero[j] = drives[j].ToCounts(track.start[j]);
  }
  std::vector<std::vector<double>> tau(ticks, std::vector<double>(n));
  for (size_t k = 0; k < ticks; ++k) {
    for (size_t j = 0; j < n; ++j) {
      const int64_t actual = drives[j].ToCounts(k == 0 ? track.start[j] : q[k - 1][j]) - zero[j];
      chips[j].StopHere(drives[j].ToCounts(track.setpoint[k][j]) - zero[j], actual);
      const double limit = model.joints[j].effort_max;
      tau[k][j] = std::clamp(drives[j].EffortFromPwm(chips[j].Tick(actual)), -limit, limit);
    }
  }
  // Velocities at each tick (smoothed) and during each step.
  auto at = [&](size_t k, size_t j) { return q[std::min(k, ticks - 1)][j]; };
  std::vector<std::vector<double>> v(ticks, std::vector<double>(n, 0.0));
  for (size_t k = kSmooth; k + kSmooth < ticks; ++k) {
    for (size_t j = 0; j < n; ++j) {
      v[k][j] = (at(k + kSmooth, j) - at(k - kSmooth, j)) / (2.0 * kSmooth * tick);
    }
  }
  const core::Dynamics dynamics(ArmatureInLinks(model));
  const core::KinematicChain chain(model);
  const JointAxes axes{model.dh_convention == core::DhConvention::kStandard};
  // Each joint's rotor term at tick k: sum over l <= j of (a_j . a_l) v_l (a joint's own speed
  // for a prismatic joint).
  auto rotor = [&](size_t k) {
    const core::ForwardResult fk =
        chain.Forward(Eigen::Map<const Eigen::VectorXd>(q[k].data(), static_cast<Eigen::Index>(n)));
    std::vector<double> r(n, 0.0);
    for (size_t j = 0; j < n; ++j) {
      if (model.joints[j].type != core::JointType::kRevolute) {
        r[j] = v[k][j];
        continue;
      }
      const Eigen::Vector3d aj = axes(fk, j);
      for (size_t l = 0; l <= j; ++l) {
        if (model.joints[l].type == core::JointType::kRevolute)
          r[j] += aj.dot(axes(fk, l)) * v[k][l];
      }
    }
    return r;
  };
  out->rows.resize(n);
  out->breakaway.resize(n);
  // Breakaways: the joint held (no change over two steps), then moved.
  for (size_t k = 2; k < ticks; ++k) {
    std::vector<double> still(n, 0.0);
    const core::JointVector bias = dynamics.BiasEffort(
        Eigen::Map<const Eigen::VectorXd>(q[k - 1].data(), static_cast<Eigen::Index>(n)),
        Eigen::Map<const Eigen::VectorXd>(still.data(), static_cast<Eigen::Index>(n)));
    for (size_t j = 0; j < n; ++j) {
      if (q[k - 1][j] != q[k - 2][j] || q[k][j] == q[k - 1][j]) continue;
      const double push = 0.5 * (tau[k][j] + tau[k - 1][j]) - bias[static_cast<Eigen::Index>(j)];
      out->breakaway[j].push_back(std::abs(push));
    }
  }
  // Windows in which a joint slides one way throughout.
  for (size_t a = kSmooth + 1; a + kWindow + kSmooth < ticks; a += kWindow) {
    const size_t b = a + kWindow;
    std::vector<double> mid(n), dv(n);
    const std::vector<double> rotor_a = rotor(a), rotor_b = rotor(b);
    for (size_t j = 0; j < n; ++j) {
      mid[j] = q[(a + b) / 2][j];
      dv[j] = v[b][j] - v[a][j];
    }
    const Eigen::MatrixXd mass = dynamics.MassMatrix(
        Eigen::Map<const Eigen::VectorXd>(mid.data(), static_cast<Eigen::Index>(n)));
    std::vector<double> bias_sum(n, 0.0);
    for (size_t k = a + 1; k <= b; ++k) {
      const core::JointVector bias = dynamics.BiasEffort(
          Eigen::Map<const Eigen::VectorXd>(q[k].data(), static_cast<Eigen::Index>(n)),
          Eigen::Map<const Eigen::VectorXd>(v[k].data(), static_cast<Eigen::Index>(n)));
      for (size_t j = 0; j < n; ++j) bias_sum[j] += bias[static_cast<Eigen::Index>(j)] * tick;
    }
    for (size_t j = 0; j < n; ++j) {
      // Sliding one way from a - kSmooth to b + kSmooth: every step moves, all the same way, at
      // kMinSlidingSpeed or more (a sticking joint in the sim creeps by far less, pulled back to
      // where it stuck; a real encoder does not move at all).
      int sign = 0;
      bool sliding = true;
      for (size_t k = a - kSmooth; k <= b + kSmooth && sliding; ++k) {
        const double step = q[k][j] - q[k - 1][j];
        const int s = (step > 0) - (step < 0);
        if (std::abs(step) < kMinSlidingSpeed * tick || (sign != 0 && s != sign)) sliding = false;
        sign = s;
      }
      if (!sliding) continue;
      Regression::Row row;
      row.rotor = rotor_b[j] - rotor_a[j];
      row.travel = q[b][j] - q[a][j];
      row.up = row.down = 0;
      double effort = 0;
      for (size_t k = a + 1; k <= b; ++k) {
        effort += tau[k][j] * tick;
        row.speed.push_back((q[k][j] - q[k - 1][j]) / tick);
      }
      (sign > 0 ? row.up : row.down) = static_cast<double>(kWindow) * tick;
      double coupled = 0;
      for (size_t i = 0; i < n; ++i) {
        coupled += mass(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) * dv[i];
      }
      row.target = effort - coupled - bias_sum[j];
      out->rows[j].push_back(std::move(row));
    }
  }
}

// Least squares for one joint at Stribeck speed vs: friction levels, viscous, armature (the rows
// were made with `present` armature). Returns the residual sum of squares; `fixed_static` >= 0
// fixes the static level.
double SolveJoint(const std::vector<Regression::Row>& rows, double vs, double fixed_static,
                  double tick, double present, core::Friction* friction, double* armature) {
  // Unknowns: coulomb+, coulomb-, static (unless fixed), viscous, armature.
  const bool fit_static = fixed_static < 0;
  const Eigen::Index cols = fit_static ? 5 : 4;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(rows.size()), cols);
  Eigen::VectorXd y(static_cast<Eigen::Index>(rows.size()));
  for (size_t r = 0; r < rows.size(); ++r) {
    const Regression::Row& row = rows[r];
    double up = 0, down = 0, peak = 0;  // the Coulomb and Stribeck parts, integrated
    for (double w : row.speed) {
      const double ratio = w / vs;
      const double g = std::exp(-ratio * ratio);
      if (w > 0) {
        up += (1 - g) * tick;
        peak += g * tick;
      } else {
        down -= (1 - g) * tick;
        peak -= g * tick;
      }
    }
    const auto i = static_cast<Eigen::Index>(r);
    a(i, 0) = up;
    a(i, 1) = down;
    a(i, 2) = row.travel;
    a(i, 3) = row.rotor;
    y[i] = row.target;
    if (fit_static) {
      a(i, 4) = peak;
    } else {
      y[i] -= fixed_static * peak;
    }
  }
  // Columns scaled to unit norm for the solve.
  Eigen::VectorXd scale(cols);
  for (Eigen::Index c = 0; c < cols; ++c) {
    scale[c] = a.col(c).norm() > 0 ? a.col(c).norm() : 1.0;
    a.col(c) /= scale[c];
  }
  Eigen::VectorXd x = a.colPivHouseholderQr().solve(y);
  const double rss = (a * x - y).squaredNorm();
  x = x.cwiseQuotient(scale);
  friction->coulomb_positive = std::max(x[0], 0.0);
  friction->coulomb_negative = std::max(x[1], 0.0);
  friction->viscous = std::max(x[2], 0.0);
  *armature = std::max(present + x[3], 1e-5);
  friction->static_effort = fit_static ? x[4] : fixed_static;
  friction->static_effort = std::max(
      {friction->static_effort, friction->coulomb_positive, friction->coulomb_negative, 1e-4});
  friction->stribeck_velocity = vs;
  return rss;
}

// Whether the windows sample the friction curve at low speeds (below 0.2 rad/s, both ways),
// where the regression sees the static level itself; else breakaways measure it.
bool HasSlowSliding(const std::vector<Regression::Row>& rows) {
  int up = 0, down = 0;
  for (const Regression::Row& row : rows) {
    double sum = 0;
    for (double w : row.speed) sum += w;
    const double speed = sum / static_cast<double>(std::max<size_t>(1, row.speed.size()));
    if (speed > 0 && speed < 0.2) ++up;
    if (speed < 0 && speed > -0.2) ++down;
  }
  return up >= 10 && down >= 10;
}

// One joint's regression: its friction and armature in `out`, unless it has too little data.
void RegressJoint(const core::RobotModel& present, const Regression& data, size_t j,
                  core::RobotModel* out) {
  const std::vector<Regression::Row>& rows = data.rows[j];
  if (rows.size() < 20) return;
  std::vector<double> breaks = data.breakaway[j];
  double fixed_static = -1;
  if (breaks.size() >= 3 && !HasSlowSliding(rows)) {
    std::sort(breaks.begin(), breaks.end());
    // The middle half's mean: robust to a breakaway pushed by another joint's start.
    const size_t lo = breaks.size() / 4, hi = breaks.size() - breaks.size() / 4;
    double sum = 0;
    for (size_t i = lo; i < hi; ++i) sum += breaks[i];
    fixed_static = sum / static_cast<double>(hi - lo);
  }
  // The Stribeck speed: the best of a log grid, then refined by golden section in log speed.
  auto rss_at = [&](double log_vs, core::Friction* f, double* armature) {
    return SolveJoint(rows, std::exp(log_vs), fixed_static, present.servo_tick_s,
                      present.joints[j].armature, f, armature);
  };
  core::Friction f;
  double armature = 0;
  double best_log = std::log(1e-3), best_rss = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= 40; ++i) {
    const double lv = std::log(1e-3) + i * (std::log(3.0) - std::log(1e-3)) / 40;
    const double rss = rss_at(lv, &f, &armature);
    if (rss < best_rss) {
      best_rss = rss;
      best_log = lv;
    }
  }
  const double width = (std::log(3.0) - std::log(1e-3)) / 40;
  double lo = best_log - width, hi = best_log + width;
  const double golden = 0.5 * (std::sqrt(5.0) - 1);
  for (int i = 0; i < 30; ++i) {
    const double x1 = hi - golden * (hi - lo), x2 = lo + golden * (hi - lo);
    if (rss_at(x1, &f, &armature) < rss_at(x2, &f, &armature)) {
      hi = x2;
    } else {
      lo = x1;
    }
  }
  rss_at(0.5 * (lo + hi), &f, &armature);
  out->joints[j].friction = f;
  out->joints[j].armature = armature;
}

// The regression's model: joints with too little data keep the model's values. A joint's armature
// also acts on the joints it shares an axis direction with (ArmatureInLinks), so the regression is
// run again with the armatures it found, kRegressionPasses times in all.
constexpr int kRegressionPasses = 3;

core::RobotModel Regress(const core::RobotModel& model, const std::vector<Track>& tracks,
                         const std::vector<size_t>& joints) {
  core::RobotModel out = model;
  for (int pass = 0; pass < kRegressionPasses; ++pass) {
    const core::RobotModel present = out;
    Regression data;
    for (const Track& t : tracks) Collect(present, t, &data);
    for (size_t j : joints) RegressJoint(present, data, j, &out);
  }
  return out;
}

}  // namespace

IdentifyResult Identify(const core::RobotModel& model, const std::vector<logger::RunTable>& tables,
                        const IdentifyOptions& options) {
  const size_t n = model.joints.size();
  // The weight of the moves other than the movement sets' last ones: by default none when the
  // data has movement sets (Table II measures their last moves), else all count.
  const bool sets = std::any_of(tables.begin(), tables.end(),
                                [](const logger::RunTable& t) { return !t.plan_name.empty(); });
  const double others =
      options.other_moves_weight >= 0 ? options.other_moves_weight : (sets ? 0.0 : 1.0);
  std::vector<Track> tracks;
  for (size_t i = 0; i < tables.size(); ++i) {
    tracks.push_back(
        Prepare(model, tables[i], options.last_move_only ? LastMoveRow(tables[i]) : 0, others));
    tracks.back().table = i;
  }
  std::vector<size_t> joints;
  if (options.joints.empty()) {
    for (size_t j = 0; j < n; ++j) {
      double lo = 1e9, hi = -1e9;
      for (const Track& t : tracks) {
        for (const auto& row : t.setpoint) {
          lo = std::min(lo, row[j]);
          hi = std::max(hi, row[j]);
        }
      }
      if (hi - lo > kDeg && model.joints[j].type == core::JointType::kRevolute) joints.push_back(j);
    }
  } else {
    for (int j : options.joints) {
      if (j < 1 || j > static_cast<int>(n)) {
        throw std::invalid_argument("joint " + std::to_string(j) + ": allowed 1.." +
                                    std::to_string(n));
      }
      joints.push_back(static_cast<size_t>(j - 1));
    }
  }
  std::vector<int> fitted;  // 1-based, for CheckMoves
  for (size_t j : joints) fitted.push_back(static_cast<int>(j + 1));
  IdentifyResult result;
  // The copies of the tables whose virtual stream each simulation replaces, for Table II's
  // measure.
  std::vector<logger::RunTable> work(tables);
  // What a simulation of model `m` along `on` scores. A trial whose simulation blows up in ODE
  // (viscous friction far too stiff for a light joint, say) costs infinity for every joint; the
  // given model's own (`thrown` true) is thrown.
  const double inf = std::numeric_limits<double>::infinity();
  auto evaluate = [&](const core::RobotModel& m, bool thrown, const std::vector<Track>& on) {
    Score score{std::vector<double>(n, 0.0), std::vector<double>(n, 0.0),
                std::vector<int64_t>(n, 0), std::vector<double>(n, 0.0),
                std::vector<double>(n, 0.0)};
    ++result.evaluations;
    try {
      for (const Track& t : on) {
        std::vector<std::vector<double>> trace;
        Simulate(m, t, &score.sse, &score.sse_weights, &score.count, &trace);
        PutStream(trace, t.t0, m.servo_tick_s, t.first_row, logger::Stream::kVirtual,
                  &work[t.table]);
        AddTableMeans(work[t.table], joints, t.first_row > 0 || options.last_move_only, others,
                      &score);
      }
    } catch (const std::runtime_error&) {
      if (thrown) throw;
      score.sse.assign(n, inf);
      score.table.assign(n, inf);
    }
    if (options.require_moves && !thrown) {
      try {
        for (const LagCheck& check : CheckMoves(m, fitted)) {
          if (!check.over()) continue;
          score.sse[static_cast<size_t>(check.joint - 1)] = inf;
          score.table[static_cast<size_t>(check.joint - 1)] = inf;
        }
      } catch (const std::runtime_error&) {  // the moves blow up in ODE: as the data's would
        score.sse.assign(n, inf);
        score.table.assign(n, inf);
      }
    }
    return score;
  };
  // What each joint's search lowers in the end: Table II's measure where the data has moves the
  // joint takes part in (the same moves whatever the model: they come from the set-point and the
  // real samples), else (data without moves, e.g. one long streamed set-point) the squared angle
  // error.
  const Score before = evaluate(model, true, tracks);
  auto table_cost = [&](const Score& score, size_t j) {
    return before.weights[j] > 0 ? score.table[j] : score.sse[j];
  };
  auto total = [&](const Score& score) {
    double sum = 0;
    for (size_t j : joints) sum += table_cost(score, j);
    return sum;
  };
  const bool two_phases =
      std::any_of(joints.begin(), joints.end(), [&](size_t j) { return before.weights[j] > 0; });
  // With Table II's measure the search has two phases. First the squared error (smooth: it finds
  // the valley), for half the budget; when only the movement sets' last moves count, on those
  // moves alone, each simulated from where its real arm starts (cheaper, and the returns to zero
  // do not pull it). Then Table II's measure over all the data (sums of |error|, with corners),
  // from each joint's point of the first phase.
  std::vector<Track> last_moves;
  if (two_phases && others == 0 && !options.last_move_only) {
    for (size_t i = 0; i < tables.size(); ++i) {
      if (tables[i].plan_name.empty()) continue;
      last_moves.push_back(Prepare(model, tables[i], LastMoveRow(tables[i]), others));
      last_moves.back().table = i;
    }
  }
  const std::vector<Track>& first = last_moves.empty() ? tracks : last_moves;
  auto first_cost = [&](const Score& score, size_t j) {
    return two_phases ? score.sse[j] : table_cost(score, j);
  };
  // Two starts, each put into the search's box: the torque regression's values and the model's.
  // Per joint the one that follows the data better is where the search begins (a joint the
  // regression fits worse than the model had it: data the model cannot explain, e.g. a real
  // arm's latency).
  const Score model_first = &first == &tracks ? before : evaluate(model, true, first);
  core::RobotModel from_regression = Regress(model, first, joints);
  core::RobotModel from_model = model;
  for (size_t j : joints) {
    FromUnit(from_regression, j, ToUnit(from_regression, j));
    FromUnit(from_model, j, ToUnit(from_model, j));
  }
  const Score regression_score = evaluate(from_regression, false, first);
  auto near = [](double a, double b) { return std::abs(a - b) <= 1e-9 * std::abs(b); };
  const bool model_in_box = std::all_of(joints.begin(), joints.end(), [&](size_t j) {
    const core::Friction& a = from_model.joints[j].friction;
    const core::Friction& b = model.joints[j].friction;
    return near(a.static_effort, b.static_effort) && near(a.coulomb_positive, b.coulomb_positive) &&
           near(a.coulomb_negative, b.coulomb_negative) && near(a.viscous, b.viscous) &&
           near(a.stribeck_velocity, b.stribeck_velocity) &&
           near(from_model.joints[j].armature, model.joints[j].armature);
  });
  const Score model_score = model_in_box ? model_first : evaluate(from_model, false, first);
  core::RobotModel start = from_regression;
  std::vector<double> start_cost(n, inf);
  for (size_t j : joints) {
    const bool regression = first_cost(regression_score, j) <= first_cost(model_score, j);
    start.joints[j] = (regression ? from_regression : from_model).joints[j];
    start_cost[j] = first_cost(regression ? regression_score : model_score, j);
  }
  // With Table II's data, kSpreadStarts more starts spread over the box (a Halton sequence, the
  // same point for every joint; every second one with its viscous friction in the box's top
  // tenth): a latency fits as viscous friction near the box's cap, far from both starts, and a
  // search from them can settle on pure Coulomb friction instead.
  const int spread = std::min(kSpreadStarts, options.max_evaluations / 4);
  for (int p = 1; two_phases && p <= spread; ++p) {
    std::vector<double> unit(kParams);
    for (size_t a = 0; a < unit.size(); ++a) unit[a] = Halton(p, kPrimes[a]);
    if (p % 2 == 0) unit[3] = 0.9 + 0.1 * unit[3];  // viscous friction in the box's top decade
    core::RobotModel trial = start;
    for (size_t j : joints) FromUnit(trial, j, unit);
    const Score score = evaluate(trial, false, first);
    for (size_t j : joints) {
      if (first_cost(score, j) < start_cost[j]) {
        start.joints[j] = trial.joints[j];
        start_cost[j] = first_cost(score, j);
      }
    }
  }
  // Output error: one Nelder-Mead search per joint on its log box (box_search.hpp), all of them
  // sharing each simulation of the data (the joints' errors are nearly independent), until
  // `until` simulations less one are spent. Returns the joints' best points together.
  auto search = [&](const core::RobotModel& from, const std::vector<double>& from_cost, int until,
                    const std::vector<Track>& on, bool by_table) {
    std::vector<BoxSearch> searches;
    for (size_t j : joints) searches.emplace_back(ToUnit(from, j), from_cost[j], kFirstSimplex);
    while (!searches.empty() && result.evaluations + 1 < until) {
      core::RobotModel trial = from;
      for (size_t k = 0; k < joints.size(); ++k) FromUnit(trial, joints[k], searches[k].Ask());
      const Score score = evaluate(trial, false, on);
      for (size_t k = 0; k < joints.size(); ++k) {
        searches[k].Tell(by_table ? table_cost(score, joints[k]) : first_cost(score, joints[k]));
      }
    }
    core::RobotModel found = from;
    for (size_t k = 0; k < joints.size(); ++k) FromUnit(found, joints[k], searches[k].best());
    return found;
  };
  // The candidates, each with its score over all the data; the one with the lowest measure wins.
  std::vector<std::pair<core::RobotModel, Score>> candidates;
  if (!two_phases) {
    // One phase on the squared error (table_cost is it): the start's score is known already.
    Score start_score = regression_score;
    for (size_t j : joints) {
      start_score.sse[j] = start_cost[j];
      start_score.sse_weights[j] = before.sse_weights[j];
    }
    candidates.emplace_back(start, start_score);
    if (result.evaluations + 1 < options.max_evaluations) {
      const core::RobotModel found =
          search(start, start_cost, options.max_evaluations, tracks, true);
      candidates.emplace_back(found, evaluate(found, false, tracks));
    }
  } else {
    candidates.emplace_back(start, evaluate(start, false, tracks));
    const int half =
        result.evaluations + std::max(0, options.max_evaluations - result.evaluations) / 2;
    const core::RobotModel phase1 = search(start, start_cost, half, first, false);
    const Score phase1_score = evaluate(phase1, false, tracks);
    candidates.emplace_back(phase1, phase1_score);
    if (result.evaluations + 1 < options.max_evaluations) {
      std::vector<double> cost(n, inf);
      for (size_t j : joints) cost[j] = table_cost(phase1_score, j);
      const core::RobotModel found = search(phase1, cost, options.max_evaluations, tracks, true);
      candidates.emplace_back(found, evaluate(found, false, tracks));
    }
  }
  core::RobotModel best = candidates.front().first;
  Score best_score = candidates.front().second;
  for (const auto& [m, score] : candidates) {
    if (total(score) < total(best_score)) {
      best = m;
      best_score = score;
    }
  }
  result.model = best;
  for (size_t j : joints) {
    JointIdentification id;
    id.joint = static_cast<int>(j + 1);
    id.friction_before = model.joints[j].friction;
    id.friction_after = best.joints[j].friction;
    id.armature_before = model.joints[j].armature;
    id.armature_after = best.joints[j].armature;
    id.samples = before.count[j];
    const double w = std::max(1e-300, before.sse_weights[j]);
    id.rms_before_deg = std::sqrt(before.sse[j] / w) / kDeg;
    id.rms_after_deg = std::sqrt(best_score.sse[j] / w) / kDeg;
    if (before.weights[j] > 0) {
      id.table_before = before.table[j] / before.weights[j];
      id.table_after = best_score.table[j] / before.weights[j];
    }
    result.joints.push_back(id);
  }
  return result;
}

logger::RunTable SimulateRealStream(const core::RobotModel& model, const logger::RunTable& table) {
  const Track track = Prepare(model, table, 0, 1, false);
  std::vector<double> sse(model.joints.size(), 0.0), weight(model.joints.size(), 0.0);
  std::vector<int64_t> count(model.joints.size(), 0);
  std::vector<std::vector<double>> trace;
  Simulate(model, track, &sse, &weight, &count, &trace);
  logger::RunTable out = table;
  PutStream(trace, table.time_s.front(), model.servo_tick_s, 0, logger::Stream::kReal, &out);
  out.real_clock_us.clear();  // the simulated stream is on the sim clock: no stamps, no factor
  out.real_on_sim_clock = true;
  return out;
}

namespace {

// One phase of CheckMoves: every joint to `goal` (rad or m), as the chip's trapezoid at the
// servo's defaults, then 0.3 s of holding; the set-point appended to `table` as move `id`.
void AppendMove(const core::RobotModel& model, const std::vector<servo::JointDrive>& drives,
                const std::vector<double>& from, const std::vector<double>& goal, int id,
                logger::RunTable* table) {
  const size_t n = model.joints.size();
  std::vector<servo::TrapezoidalProfile> profiles;
  for (size_t j = 0; j < n; ++j) {
    profiles.emplace_back(servo::ToFixed(drives[j].ToCounts(from[j])));
    const core::ServoParams& servo = model.joints[j].servo;
    if (goal[j] != from[j]) {
      profiles[j].SetGoal(servo::ToFixed(drives[j].ToCounts(goal[j])),
                          drives[j].VelocityWord(servo.default_velocity),
                          drives[j].AccelerationWord(servo.default_acceleration));
    }
  }
  const auto hold = static_cast<int>(std::lround(0.3 / model.servo_tick_s));
  for (int held = 0; held < hold;) {
    bool done = true;
    const double t = table->time_s.empty() ? 0 : table->time_s.back() + model.servo_tick_s;
    table->time_s.push_back(t);
    table->move_id.push_back(id);
    for (size_t j = 0; j < n; ++j) {
      const int64_t counts = servo::WholeCounts(profiles[j].Tick());
      done = done && profiles[j].done();
      table->position[j][0].push_back(drives[j].FromCounts(counts) * table->joints[j].scale());
      for (size_t s = 1; s < logger::kNumStreams; ++s)
        table->position[j][s].push_back(std::nan(""));
      table->done[j].push_back(profiles[j].done() ? 1 : 0);
    }
    for (size_t s = 0; s < logger::kNumStreams; ++s) table->age_s[s].push_back(0);
    if (done) ++held;
  }
}

}  // namespace

std::vector<LagCheck> CheckMoves(const core::RobotModel& model, const std::vector<int>& joints) {
  const size_t n = model.joints.size();
  std::vector<servo::JointDrive> drives;
  std::vector<logger::JointInfo> info;
  for (const core::Joint& joint : model.joints) {
    drives.emplace_back(joint, model.servo_tick_s);
    info.push_back({joint.name, joint.type == core::JointType::kPrismatic});
  }
  logger::RunTable table;
  table.Reset(info);
  table.label = "moves check";
  std::vector<std::string> labels;
  const std::vector<double> zero(n, 0.0);
  std::vector<double> all = zero;
  int id = 0;
  const auto move = [&](const std::vector<double>& from, const std::vector<double>& to,
                        const std::string& label) {
    AppendMove(model, drives, from, to, id++, &table);
    labels.push_back(label);
  };
  if (const core::NamedPose* ready = model.FindNamedPose("ready")) {
    move(ready->position, zero, "ready -> zero, all joints");
  }
  for (int joint : joints) {
    const auto j = static_cast<size_t>(joint - 1);
    const core::Joint& spec = model.joints[j];
    const bool prismatic = spec.type == core::JointType::kPrismatic;
    const double goal = prismatic ? (spec.position_min + spec.position_max) / 2
                                  : std::clamp(kPi / 2, spec.position_min, spec.position_max);
    all[j] = goal;
    std::vector<double> there = zero;
    there[j] = goal;
    const std::string span =
        "0 -> " + core::FormatNumber(goal * table.joints[j].scale()) + (prismatic ? " mm" : " deg");
    move(zero, there, span + ", alone");
    move(there, zero, "back, alone");
  }
  move(zero, all, "there, all together");
  move(all, zero, "back, all together");
  const logger::RunTable simulated = SimulateRealStream(model, table);
  std::vector<LagCheck> checks;
  for (int joint : joints) {
    const auto j = static_cast<size_t>(joint - 1);
    LagCheck check;
    check.joint = joint;
    check.limit_counts = std::llround(model.joints[j].servo.error_limit);
    const double scale = table.joints[j].scale();
    for (size_t i = 0; i < table.rows(); ++i) {
      const int64_t set = drives[j].ToCounts(table.position[j][0][i] / scale);
      const int64_t at = drives[j].ToCounts(
          simulated.position[j][static_cast<size_t>(logger::Stream::kReal)][i] / scale);
      const int64_t lag = std::abs(set - at);
      if (lag > check.worst_counts) {
        check.worst_counts = lag;
        check.move = labels[static_cast<size_t>(table.move_id[i])];
      }
    }
    checks.push_back(check);
  }
  return checks;
}

namespace {

// The lines of joint `joint`'s (1-based) one-line `armature:` and `friction: {...}` keys in the
// model file: within its entry of the `joints:` list (located by the YAML parser, so a link of
// the same name further down is never taken), up to the next line indented no deeper than the
// entry's keys.
std::vector<std::string> SplitLines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

struct EntryLines {
  size_t armature = 0, friction = 0;
};

EntryLines FindEntryLines(const YAML::Node& entries, const std::vector<std::string>& lines,
                          const core::RobotModel& model, int joint, const std::string& file) {
  const std::string& name = model.joints[static_cast<size_t>(joint - 1)].name;
  const auto refuse = [&](int line) {
    return core::ConfigError({file, line, 0}, "joints",
                             "joint '" + name +
                                 "': cannot rewrite it (its entry in joints: needs one-line "
                                 "'armature:' and 'friction: {...}' keys)");
  };
  if (!entries || !entries.IsSequence() || entries.size() < static_cast<size_t>(joint)) {
    throw refuse(0);
  }
  const YAML::Mark mark = entries[static_cast<size_t>(joint - 1)].Mark();
  const auto first = static_cast<size_t>(mark.line);
  const auto key_column = static_cast<size_t>(mark.column);
  std::optional<size_t> armature, friction;
  for (size_t i = first; i < lines.size(); ++i) {
    const size_t indent = lines[i].find_first_not_of(' ');
    if (indent == std::string::npos || lines[i][indent] == '#') continue;
    if (i > first && indent < key_column) break;      // the next entry, or the end of joints:
    if (indent != key_column && i > first) continue;  // a nested map (servo: ...)
    const size_t key = i == first ? key_column : indent;
    if (lines[i].compare(key, 9, "armature:") == 0) armature = i;
    if (lines[i].compare(key, 9, "friction:") == 0 && lines[i].find('}') != std::string::npos) {
      friction = i;
    }
  }
  if (!armature || !friction) throw refuse(mark.line + 1);
  return {*armature, *friction};
}

}  // namespace

void CheckModelRewritable(const std::string& text, const std::string& file,
                          const core::RobotModel& model, const std::vector<int>& joints) {
  const core::YamlDocument doc = core::YamlDocument::Parse(text, file);
  const std::vector<std::string> lines = SplitLines(text);
  const YAML::Node entries = doc.Root().node()["joints"];
  for (int joint : joints) FindEntryLines(entries, lines, model, joint, file);
}

std::string RewriteModelText(const std::string& text, const std::string& file,
                             const core::RobotModel& original, const IdentifyResult& result) {
  const core::YamlDocument doc = core::YamlDocument::Parse(text, file);
  const YAML::Node angle = doc.Root().node()["units"]["angle"];
  const bool degrees = angle && angle.IsScalar() && angle.Scalar() == "deg";
  const double speed_scale = degrees ? kDeg : 1.0;
  std::vector<std::string> lines = SplitLines(text);
  auto number = [](double v) {
    std::ostringstream s;
    s << std::setprecision(5) << v;
    return s.str();
  };
  const YAML::Node entries = doc.Root().node()["joints"];
  for (const JointIdentification& id : result.joints) {
    const EntryLines at = FindEntryLines(entries, lines, original, id.joint, file);
    const std::string pad(lines[at.armature].find_first_not_of(' '), ' ');
    lines[at.armature] = pad + "armature: " + number(id.armature_after) + "   # identified";
    const core::Friction& f = id.friction_after;
    const std::string fpad(lines[at.friction].find_first_not_of(' '), ' ');
    lines[at.friction] = fpad + "friction: {static: " + number(f.static_effort) + ", coulomb: [" +
                         number(f.coulomb_positive) + ", " + number(f.coulomb_negative) +
                         "], viscous: " + number(f.viscous) +
                         ", stribeck_velocity: " + number(f.stribeck_velocity / speed_scale) +
                         "}   # identified";
  }
  std::string out;
  for (const std::string& line : lines) out += line + "\n";
  return out;
}

}  // namespace sirupp::lab
