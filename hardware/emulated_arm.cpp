#include "hardware/emulated_arm.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/errors.hpp"

namespace sirupp::hardware {
namespace {

constexpr double kFullPwm = 255.0;

double Sign(double v) { return (v > 0) - (v < 0); }

int64_t FloorDiv(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// The model the rigid-body dynamics use: with real-arm effects, a rigid joint's armature is the
// file's, and a compliant joint's rotor is integrated on its own (no armature on the link).
core::RobotModel DynamicsModel(const core::RobotModel& model, const ArmOptions& options) {
  core::RobotModel m = model;
  if (!options.effects) return m;
  CheckRealArmParams(*options.effects, model);
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const JointEffects& e = options.effects->joints[j];
    m.joints[j].armature = e.stiffness_nm_per_rad > 0 ? 0.0 : e.armature_kg_m2;
  }
  return m;
}

// The accelerations of one step with static friction as an active set: `held` joints (sticking,
// or braked) have qdd = 0 while the friction they need stays within their break-away level
// (`static_level[0]` pushed up, `[1]` down; a brake holds whatever it takes); the worst offender is
// released (sliding, static friction against the push, taken off `rhs`) and the rest re-solved,
// until the set is consistent. On return `held` is the joints that stay held.
Eigen::VectorXd SolveActiveSet(const Eigen::MatrixXd& mass, Eigen::VectorXd rhs,
                               const std::array<std::vector<double>, 2>& static_level,
                               const std::vector<bool>& braked, std::vector<bool>& held) {
  const auto n = static_cast<int>(rhs.size());
  Eigen::VectorXd qdd = Eigen::VectorXd::Zero(n);
  for (int round = 0; round <= n; ++round) {
    std::vector<int> free;
    for (int j = 0; j < n; ++j) {
      if (!held[static_cast<size_t>(j)]) free.push_back(j);
    }
    qdd.setZero();
    if (!free.empty()) {
      const auto m = static_cast<Eigen::Index>(free.size());
      Eigen::MatrixXd mff(m, m);
      Eigen::VectorXd rf(m);
      for (Eigen::Index a = 0; a < m; ++a) {
        rf[a] = rhs[free[static_cast<size_t>(a)]];
        for (Eigen::Index b = 0; b < m; ++b) {
          mff(a, b) = mass(free[static_cast<size_t>(a)], free[static_cast<size_t>(b)]);
        }
      }
      const Eigen::VectorXd af = mff.ldlt().solve(rf);
      for (Eigen::Index a = 0; a < m; ++a) qdd[free[static_cast<size_t>(a)]] = af[a];
    }
    // The friction each held joint needs: M_j qdd - rhs_j.
    int worst = -1;
    double worst_excess = 1.0;
    double worst_push = 0;
    double worst_limit = 0;
    for (int j = 0; j < n; ++j) {
      const auto u = static_cast<size_t>(j);
      if (!held[u] || braked[u]) continue;  // a brake holds whatever it takes
      const double needed = mass.row(j).dot(qdd) - rhs[j];
      // The break-away level of the way the joint would go without friction (-needed).
      const double limit = -needed > 0 ? static_level[0][u] : static_level[1][u];
      const double excess = limit > 0 ? std::abs(needed) / limit : (needed != 0 ? 2.0 : 0.0);
      if (excess > worst_excess) {
        worst = j;
        worst_excess = excess;
        worst_push = -needed;
        worst_limit = limit;
      }
    }
    if (worst < 0) break;
    held[static_cast<size_t>(worst)] = false;
    rhs[worst] -= Sign(worst_push) * worst_limit;
  }
  return qdd;
}

}  // namespace

EmulatedArm::EmulatedArm(const core::RobotModel& model, const ArmOptions& options)
    : model_(model),
      effects_(options.effects),
      dynamics_(DynamicsModel(model, options)),
      options_(options),
      tick_s_(model.servo_tick_s) {
  const size_t n = model.joints.size();
  if (!(options.friction_scale >= 0) || !std::isfinite(options.friction_scale)) {
    throw std::invalid_argument("friction scale " + core::FormatNumber(options.friction_scale) +
                                ": allowed a finite number >= 0");
  }
  if (options.substeps < 1 || options.substeps > 100) {
    throw std::invalid_argument("substeps " + std::to_string(options.substeps) +
                                ": allowed 1..100");
  }
  if (!options.start_positions.empty() && options.start_positions.size() != n) {
    throw std::invalid_argument(
        "start positions: " + std::to_string(options.start_positions.size()) + " values for " +
        std::to_string(n) + " joints");
  }
  position_.assign(n, 0.0);
  if (!options.start_positions.empty()) position_ = options.start_positions;
  for (size_t j = 0; j < n; ++j) {
    const core::Joint& joint = model.joints[j];
    if (!std::isfinite(position_[j]) || position_[j] < joint.position_min ||
        position_[j] > joint.position_max) {
      throw std::invalid_argument("start position of joint " + std::to_string(j + 1) + " (" +
                                  joint.name + ") " + core::FormatNumber(position_[j]) +
                                  " is outside its limits [" +
                                  core::FormatNumber(joint.position_min) + ", " +
                                  core::FormatNumber(joint.position_max) + "]");
    }
    drives_.emplace_back(joint, tick_s_);
  }
  velocity_.assign(n, 0.0);
  motor_effort_.assign(n, 0.0);
  external_.assign(n, 0.0);
  current_.assign(n, 0.0);
  rotor_position_ = position_;
  rotor_velocity_.assign(n, 0.0);
  supply_v_ = effects_ ? effects_->supply_voltage_v : 0.0;
  stuck_.assign(n, true);
  braked_.assign(n, false);
  pwm_.assign(n, 0);
  index_edge_.assign(n, 0);
  index_crossed_.assign(n, false);
  for (size_t j = 0; j < n; ++j) power_up_counts_.push_back(AbsoluteCounts(static_cast<int>(j)));
  previous_counts_ = power_up_counts_;
}

double EmulatedArm::EncoderPosition(int joint) const {
  const auto u = static_cast<size_t>(joint);
  return compliant(u) ? rotor_position_[u] : position_[u];
}

int64_t EmulatedArm::AbsoluteCounts(int joint) const {
  const int64_t counts = drives_[static_cast<size_t>(joint)].ToCounts(EncoderPosition(joint));
  if (!effects_ || effects_->encoder_quantum_counts <= 1) return counts;
  // A coarser encoder: the counter steps at whole multiples of the quantum.
  const int64_t q = effects_->encoder_quantum_counts;
  return FloorDiv(counts, q) * q;
}

double EmulatedArm::TransmissionTorque(size_t j) const {
  const JointEffects& e = effects_->joints[j];
  const double twist = rotor_position_[j] - position_[j];
  const double half_gap = e.backlash_rad / 2;
  if (std::abs(twist) <= half_gap) return 0;  // inside the backlash: the gears are apart
  return e.stiffness_nm_per_rad * (twist - Sign(twist) * half_gap) +
         e.damping_nm_s_per_rad * (rotor_velocity_[j] - velocity_[j]);
}

void EmulatedArm::UpdateElectrics(double h) {
  // Each amplifier applies duty x the supply's voltage; the current follows L di/dt = V - R i -
  // Kt w (solved exactly over the substep for the voltage and speed held), within the amplifier's
  // limit. The supply sags by its source resistance times the current all amplifiers draw (an
  // H-bridge draws duty x motor current; regenerated current is not fed back).
  double drawn = 0;
  for (size_t j = 0; j < current_.size(); ++j) {
    const JointEffects& e = effects_->joints[j];
    const double gear = model_.joints[j].servo.gear_ratio;
    const double duty = pwm_[j] / kFullPwm;
    const double motor_speed = gear * (compliant(j) ? rotor_velocity_[j] : velocity_[j]);
    const double steady = (duty * supply_v_ - e.motor.torque_constant_nm_per_a * motor_speed) /
                          e.motor.resistance_ohm;
    const double decay = std::exp(-h * e.motor.resistance_ohm / e.motor.inductance_h);
    current_[j] = std::clamp(steady + (current_[j] - steady) * decay, -e.motor.current_limit_a,
                             e.motor.current_limit_a);
    motor_effort_[j] = gear * e.motor.torque_constant_nm_per_a * current_[j];
    drawn += std::max(0.0, duty * current_[j]);
  }
  supply_v_ = std::max(0.0, effects_->supply_voltage_v - effects_->supply_resistance_ohm * drawn);
}

void EmulatedArm::SetExternalEffort(const std::vector<double>& effort) {
  for (size_t j = 0; j < external_.size(); ++j) external_[j] = j < effort.size() ? effort[j] : 0.0;
}

void EmulatedArm::SetBrakes(const std::vector<bool>& engaged) {
  for (size_t j = 0; j < braked_.size(); ++j) {
    braked_[j] = options_.brakes && j < engaged.size() && engaged[j];
  }
}

void EmulatedArm::Step(const std::vector<int>& pwm) {
  for (size_t j = 0; j < pwm_.size(); ++j) {
    pwm_[j] = j < pwm.size() ? std::clamp(pwm[j], -255, 255) : 0;
    if (!effects_) motor_effort_[j] = drives_[j].EffortFromPwm(pwm_[j]);
  }
  const double h = tick_s_ / options_.substeps;
  for (int s = 0; s < options_.substeps; ++s) Substep(h);
  time_s_ += tick_s_;
  // Encoder index: once per motor revolution, at absolute counts that are multiples of a turn.
  for (size_t j = 0; j < pwm_.size(); ++j) {
    const int64_t now = AbsoluteCounts(static_cast<int>(j));
    const auto per_rev =
        std::max<int64_t>(1, std::llround(model_.joints[j].servo.encoder_counts_per_rev));
    const int64_t before_turn = FloorDiv(previous_counts_[j], per_rev);
    const int64_t now_turn = FloorDiv(now, per_rev);
    index_crossed_[j] = before_turn != now_turn;
    if (index_crossed_[j]) {
      const int64_t edge = std::max(before_turn, now_turn) * per_rev;
      index_edge_[j] = edge - power_up_counts_[j];
    }
    previous_counts_[j] = now;
  }
}

void EmulatedArm::Substep(double h) {
  const int n = num_joints();
  const Eigen::Map<const Eigen::VectorXd> q(position_.data(), n);
  const Eigen::Map<const Eigen::VectorXd> qd(velocity_.data(), n);
  if (effects_) UpdateElectrics(h);
  const Eigen::MatrixXd mass = dynamics_.MassMatrix(q);
  const Eigen::VectorXd bias = dynamics_.BiasEffort(q, qd);
  const double scale = options_.friction_scale;

  // Everything but the friction of sticking joints. The friction levels: the file's per direction
  // with effects, else the model's x friction_scale.
  Eigen::VectorXd rhs(n);
  std::vector<double> static_up(static_cast<size_t>(n)), static_down(static_cast<size_t>(n));
  std::vector<double> drive(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    const auto u = static_cast<size_t>(j);
    const core::Friction& f = model_.joints[u].friction;
    double coulomb_up = scale * f.coulomb_positive, coulomb_down = scale * f.coulomb_negative;
    double viscous = f.viscous, stribeck = f.stribeck_velocity;
    static_up[u] = static_down[u] = scale * f.static_effort;
    if (effects_) {
      const JointEffects& e = effects_->joints[u];
      static_up[u] = e.static_nm[0];
      static_down[u] = e.static_nm[1];
      coulomb_up = e.coulomb_nm[0];
      coulomb_down = e.coulomb_nm[1];
      viscous = e.viscous_nm_s_per_rad;
      stribeck = e.stribeck_rad_s;
    }
    drive[u] = compliant(u) ? TransmissionTorque(u) : motor_effort_[u];
    const double v = velocity_[u];
    rhs[j] = drive[u] + external_[u] - bias[j] - viscous * v;
    if (!stuck_[u] && v != 0) {
      const double coulomb = v > 0 ? coulomb_up : coulomb_down;
      const double breakaway = v > 0 ? static_up[u] : static_down[u];
      const double ratio = v / stribeck;
      rhs[j] -= Sign(v) * (coulomb + (breakaway - coulomb) * std::exp(-ratio * ratio));
    }
  }
  // The rotors of compliant joints: motor torque against the gear train's (semi-implicit Euler);
  // a braked rotor stands still.
  for (size_t u = 0; u < static_cast<size_t>(n); ++u) {
    if (!compliant(u)) continue;
    if (braked_[u]) {
      rotor_velocity_[u] = 0;
      continue;
    }
    rotor_velocity_[u] += h * (motor_effort_[u] - drive[u]) / effects_->joints[u].armature_kg_m2;
    rotor_position_[u] += h * rotor_velocity_[u];
  }

  // Active set: sticking and braked joints have qdd = 0 (see SolveActiveSet).
  std::vector<bool> held(stuck_);
  for (int j = 0; j < n; ++j) {
    if (braked_[static_cast<size_t>(j)]) held[static_cast<size_t>(j)] = true;
  }
  const Eigen::VectorXd qdd = SolveActiveSet(mass, rhs, {static_up, static_down}, braked_, held);

  for (int j = 0; j < n; ++j) {
    const auto u = static_cast<size_t>(j);
    const core::Joint& joint = model_.joints[u];
    if (held[u]) {
      velocity_[u] = 0;
      stuck_[u] = true;
      continue;
    }
    const double before = velocity_[u];
    double after = before + qdd[j] * h;
    if (!stuck_[u] && before != 0 && Sign(after) != Sign(before)) {
      after = 0;  // friction (or a reversal) brought the joint to rest within the step: it sticks
      stuck_[u] = true;
    } else {
      stuck_[u] = false;
    }
    velocity_[u] = after;
    position_[u] += after * h;
    if (position_[u] < joint.position_min) {
      position_[u] = joint.position_min;
      velocity_[u] = 0;
      stuck_[u] = true;
    } else if (position_[u] > joint.position_max) {
      position_[u] = joint.position_max;
      velocity_[u] = 0;
      stuck_[u] = true;
    }
  }
}

MotorInputs EmulatedArm::Inputs(int joint) const {
  const auto u = static_cast<size_t>(joint);
  const core::Joint& j = model_.joints[u];
  MotorInputs in;
  const int64_t absolute = AbsoluteCounts(joint);
  in.encoder_counts = absolute - power_up_counts_[u];
  const double margin = j.type == core::JointType::kRevolute
                            ? options_.limit_switch_margin_rad
                            : options_.limit_switch_margin_rad / 100;
  const bool at_max = position_[u] >= j.position_max - margin;
  const bool at_min = position_[u] <= j.position_min + margin;
  // LIMIT1 is the end the counts run up to: the upper limit, or the lower one for a negative gear.
  const bool counts_up_is_max = drives_[u].counts_per_unit() > 0;
  in.limit1 = counts_up_is_max ? at_max : at_min;
  in.limit2 = counts_up_is_max ? at_min : at_max;
  const auto per_rev = std::max<int64_t>(1, std::llround(j.servo.encoder_counts_per_rev));
  const int64_t phase = absolute - FloorDiv(absolute, per_rev) * per_rev;
  in.index = phase < options_.index_width_counts;
  in.index_crossed = index_crossed_[u];
  in.index_edge_counts = index_edge_[u];
  // The current sense reads the motor current with effects (full scale at the amplifier's limit),
  // else the PWM.
  const double level = effects_ ? std::abs(current_[u]) / effects_->joints[u].motor.current_limit_a
                                : std::abs(pwm_[u]) / kFullPwm;
  in.current_ad = static_cast<uint8_t>(
      std::clamp<long>(std::lround(level * options_.current_ad_full_scale), 0, 255));
  in.power_ok = true;
  return in;
}

}  // namespace sirupp::hardware
