// Checks that the MuJoCo version of each SIRUPP arm (bench/mujoco_arm.hpp) is the same arm, and
// times it for the physics benchmark:
//   1. for random positions within the limits, every link's centre-of-mass frame in MuJoCo against
//      SIRUPP forward kinematics (base * DH frames * com), and MuJoCo's gravity load (mj_inverse
//      at rest) and joint-space mass matrix against SIRUPP's rigid-body dynamics
//      (core/dynamics.hpp: Newton-Euler gravity effort, composite-rigid-body mass matrix with the
//      armature on the diagonal);
//   2. one second of free swing from q = 0 (no friction, damping or limits): total energy drift
//      with MuJoCo's Euler integrator (and RK4 for scale);
//   3. mj_step calls per second on the PUMA 260 at its servo tick, following the reference motion
//      (bench/reference_motion.hpp), without and with joint friction.
// Exits 1 when a pose, gravity-load or mass-matrix error exceeds 1e-9 (SI units).
//
//   build/bin/bench_mujoco_check [--poses N] [--seconds S]     (from the source root)
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <random>
#include <string>
#include <vector>

#include "bench/mujoco_arm.hpp"
#include "core/dynamics.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"

namespace {

using sirupp::bench::MujocoArm;
using sirupp::core::RobotModel;

constexpr double kTolerance = 1e-9;

struct CheckResult {
  double position_m = 0;
  double rotation_rad = 0;
  double gravity = 0;      // N*m or N
  double mass_matrix = 0;  // kg*m^2, kg*m or kg
};

CheckResult CheckPoses(const RobotModel& model, int poses) {
  MujocoArm arm(model, model.servo_tick_s, false);
  const sirupp::core::KinematicChain chain(model);
  const sirupp::core::Dynamics dynamics(model);
  std::mt19937 random(42);
  CheckResult worst;
  const int n = model.num_joints();
  for (int k = 0; k < poses; ++k) {
    std::vector<double> q(static_cast<size_t>(n));
    for (int j = 0; j < n; ++j) {
      const auto& joint = model.joints[static_cast<size_t>(j)];
      q[static_cast<size_t>(j)] =
          std::uniform_real_distribution<double>(joint.position_min, joint.position_max)(random);
    }
    arm.SetPositions(q);
    const sirupp::core::JointVector joints = sirupp::core::ToJointVector(q);
    const std::vector<Eigen::Isometry3d> frames = chain.Forward(joints).frames;
    for (int l = 0; l <= n; ++l) {
      const sirupp::core::Link& link = model.links[static_cast<size_t>(l)];
      if (link.mass_kg <= 0) continue;  // a massless base has no inertial in MuJoCo
      const Eigen::Isometry3d expected =
          frames[static_cast<size_t>(l)] * Eigen::Translation3d(link.com_m);
      const sirupp::core::PoseError error =
          sirupp::core::ComparePoses(expected, arm.BodyComPose(l));
      worst.position_m = std::max(worst.position_m, error.position_m);
      worst.rotation_rad = std::max(worst.rotation_rad, error.rotation_rad);
    }
    // At rest (SetPositions zeroes qvel) and with qacc = 0 (mj_forward left the free-fall
    // acceleration there), mj_inverse's qfrc_inverse is the effort that holds the arm still.
    for (int j = 0; j < n; ++j) arm.data()->qacc[arm.DofIndex(j)] = 0;
    mj_inverse(arm.model(), arm.data());
    const sirupp::core::JointVector tau = dynamics.GravityEffort(joints);
    for (int j = 0; j < n; ++j) {
      worst.gravity =
          std::max(worst.gravity, std::abs(arm.data()->qfrc_inverse[arm.DofIndex(j)] - tau[j]));
    }
    // MuJoCo's joint-space mass matrix (qM, expanded to n x n in dof order).
    Eigen::Matrix<mjtNum, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> full(n, n);
    mj_fullM(arm.model(), full.data(), arm.data()->qM);
    const Eigen::MatrixXd expected_mass = dynamics.MassMatrix(joints);
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) {
        worst.mass_matrix =
            std::max(worst.mass_matrix,
                     std::abs(full(arm.DofIndex(r), arm.DofIndex(c)) - expected_mass(r, c)));
      }
    }
  }
  return worst;
}

struct SwingResult {
  double start_energy_j = 0;
  double max_drift_j = 0;    // largest |E(t) - E(0)| over the run
  double final_drift_j = 0;  // E(end) - E(0)
  double peak_kinetic_j = 0;
};

// Free swing from q = 0 at rest for `seconds`: no applied effort, no friction, no damping, no
// limits, so the total energy (potential + kinetic, armature included) should stay constant.
SwingResult FreeSwing(const RobotModel& model, double step_s, double seconds, int integrator) {
  MujocoArm arm(model, step_s, false);
  mjModel* m = arm.mutable_model();
  for (int k = 0; k < m->nv; ++k) m->dof_damping[k] = 0;
  m->opt.disableflags |= mjDSBL_LIMIT;
  m->opt.enableflags |= mjENBL_ENERGY;
  m->opt.integrator = integrator;
  arm.SetPositions(std::vector<double>(model.joints.size(), 0.0));
  const mjData* d = arm.data();
  SwingResult result;
  result.start_energy_j = d->energy[0] + d->energy[1];
  const std::vector<double> no_effort(model.joints.size(), 0.0);
  const long steps = std::lround(seconds / step_s);
  auto record = [&] {
    const double drift = d->energy[0] + d->energy[1] - result.start_energy_j;
    result.max_drift_j = std::max(result.max_drift_j, std::abs(drift));
    result.final_drift_j = drift;
    result.peak_kinetic_j = std::max(result.peak_kinetic_j, d->energy[1]);
  };
  // mj_step computes the energy of the state it starts from, so after step k the energy is that
  // of state k; one last mj_forward gives the final state's.
  for (long k = 0; k < steps; ++k) {
    arm.Step(no_effort);
    record();
  }
  mj_forward(arm.model(), arm.data());
  record();
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  int poses = 1000;
  double seconds = 2.0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--poses") == 0 && i + 1 < argc) {
      poses = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--seconds") == 0 && i + 1 < argc) {
      seconds = std::max(0.0, std::atof(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: bench_mujoco_check [--poses N] [--seconds S]\n");
      return 2;
    }
  }
  const std::vector<std::string> files = {
      "config/robots/puma260.yaml", "config/robots/planar3.yaml", "config/robots/stanford.yaml"};
  bool ok = true;
  try {
    std::printf("MuJoCo %s model of each SIRUPP arm against SIRUPP kinematics, %d random poses\n",
                sirupp::bench::MujocoVersion().c_str(), poses);
    std::printf("  %-10s %-9s %15s %17s %22s %12s\n", "model", "DH", "COM position m",
                "COM rotation rad", "gravity load N*m or N", "mass matrix");
    std::vector<RobotModel> models;
    for (const std::string& file : files) {
      models.push_back(sirupp::core::LoadRobotModel(file));
      const RobotModel& model = models.back();
      const CheckResult check = CheckPoses(model, poses);
      const bool model_ok = check.position_m <= kTolerance && check.rotation_rad <= kTolerance &&
                            check.gravity <= kTolerance && check.mass_matrix <= kTolerance;
      ok = ok && model_ok;
      std::printf("  %-10s %-9s %15.2e %17.2e %22.2e %12.2e  %s\n", model.name.c_str(),
                  sirupp::core::DhConventionName(model.dh_convention), check.position_m,
                  check.rotation_rad, check.gravity, check.mass_matrix,
                  model_ok ? "ok" : "FAIL (> 1e-9)");
    }

    std::printf(
        "Free swing from q = 0 for 1 s at the servo tick, no friction, damping or limits\n");
    std::printf("  %-10s %-6s %10s %12s %16s %16s %12s\n", "model", "", "step s", "E(0) J",
                "max |dE| J", "dE(1 s) J", "max dE / KE");
    for (const RobotModel& model : models) {
      for (const int integrator : {static_cast<int>(mjINT_EULER), static_cast<int>(mjINT_RK4)}) {
        const SwingResult swing = FreeSwing(model, model.servo_tick_s, 1.0, integrator);
        std::printf("  %-10s %-6s %10.6f %12.4f %16.3e %16.3e %12.2e\n", model.name.c_str(),
                    integrator == mjINT_EULER ? "Euler" : "RK4", model.servo_tick_s,
                    swing.start_energy_j, swing.max_drift_j, swing.final_drift_j,
                    swing.max_drift_j / std::max(swing.peak_kinetic_j, 1e-300));
      }
    }

    if (seconds > 0) {
      const RobotModel& puma = models.front();
      std::printf("mj_step calls per second, %s following the reference motion, %.1f s each\n",
                  puma.name.c_str(), seconds);
      for (const bool friction : {false, true}) {
        const double rate =
            sirupp::bench::MujocoStepsPerSecond(puma, puma.servo_tick_s, friction, seconds);
        std::printf("  step %.6f s, %-22s %10.0f steps/s  %6.2f us/step  %6.1fx real time\n",
                    puma.servo_tick_s, friction ? "with frictionloss" : "without friction", rate,
                    1e6 / rate, rate * puma.servo_tick_s);
      }
    }
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_mujoco_check: %s\n", error.what());
    return 2;
  }
  if (!ok) std::printf("FAIL: an error exceeds %.0e\n", kTolerance);
  return ok ? 0 : 1;
}
