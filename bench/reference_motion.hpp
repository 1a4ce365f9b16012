#pragma once
// The reference motion of the physics benchmark: every joint follows a slow sinusoid under a
// clamped PD law, so that every engine (MuJoCo, ODE, ...) is driven by exactly the same efforts for
// the same state. Header-only and engine-free: it needs only the robot model.
//
//   target_i(t) = centre_i + amplitude_i * sin(2 pi f_i t)
//   effort_i    = clamp(kp_i * (target_i(t) - q_i) - kd_i * qd_i, -effort_max_i, effort_max_i)
//
// Amplitude: 0.5 rad (revolute) or 0.1 m (prismatic), at most 40 % of half the joint's range.
// Centre: the joint's home position, moved inside the limits by the amplitude. Frequency: 0.20 Hz
// for joint 0, 0.05 Hz more for each next joint, so the joints do not move in lockstep.
// Gains scale with the joint's effort limit: the drive saturates at an error of 0.1 rad (0.02 m),
// kp = effort_max / 0.1 rad, and kd = 0.04 s * kp. For the PUMA 260 shoulder (20 N*m, about
// 0.25 kg*m^2 with armature) that is kp = 200 N*m/rad and kd = 8 N*m*s/rad, a damping ratio near
// 0.5; in MuJoCo the PUMA then tracks within 0.07 rad on every joint (mostly the lag of the
// -kd * qd term) and never saturates. The wrist loops (2 to 2.5 N*m, about 0.002 to
// 0.003 kg*m^2) are overdamped, and kd * h / inertia stays near 0.5 or below for steps up to
// 1 ms, so the explicit damping term is stable in every engine at the servo tick.

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/robot_model.hpp"

namespace sirupp::bench {

struct ReferenceJoint {
  double centre = 0;     // rad or m
  double amplitude = 0;  // rad or m
  double frequency_hz = 0;
  double kp = 0;  // N*m/rad or N/m
  double kd = 0;  // N*m*s/rad or N*s/m
};

inline constexpr double kReferenceSaturationRad = 0.1;
inline constexpr double kReferenceSaturationM = 0.02;
inline constexpr double kReferenceDampingTimeS = 0.04;

inline ReferenceJoint ReferenceFor(const core::Joint& joint, int index) {
  const bool revolute = joint.type == core::JointType::kRevolute;
  ReferenceJoint ref;
  const double half_range = 0.5 * (joint.position_max - joint.position_min);
  ref.amplitude = std::min(revolute ? 0.5 : 0.1, 0.4 * half_range);
  ref.centre = std::clamp(joint.home, joint.position_min + ref.amplitude,
                          joint.position_max - ref.amplitude);
  ref.frequency_hz = 0.20 + 0.05 * index;
  ref.kp = joint.effort_max / (revolute ? kReferenceSaturationRad : kReferenceSaturationM);
  ref.kd = kReferenceDampingTimeS * ref.kp;
  return ref;
}

// The target positions at time t (s); at t = 0 they are the centres, a good start state.
inline std::vector<double> ReferencePosition(const core::RobotModel& model, double t) {
  std::vector<double> target(model.joints.size());
  for (size_t i = 0; i < model.joints.size(); ++i) {
    const ReferenceJoint ref = ReferenceFor(model.joints[i], static_cast<int>(i));
    target[i] = ref.centre + ref.amplitude * std::sin(2 * M_PI * ref.frequency_hz * t);
  }
  return target;
}

// The efforts (N*m or N, one per joint) the reference controller applies at time t in state
// (q, qd).
inline std::vector<double> ReferenceEffort(const core::RobotModel& model, double t,
                                           const std::vector<double>& q,
                                           const std::vector<double>& qd) {
  std::vector<double> effort(model.joints.size());
  for (size_t i = 0; i < model.joints.size(); ++i) {
    const core::Joint& joint = model.joints[i];
    const ReferenceJoint ref = ReferenceFor(joint, static_cast<int>(i));
    const double target = ref.centre + ref.amplitude * std::sin(2 * M_PI * ref.frequency_hz * t);
    effort[i] =
        std::clamp(ref.kp * (target - q[i]) - ref.kd * qd[i], -joint.effort_max, joint.effort_max);
  }
  return effort;
}

}  // namespace sirupp::bench
