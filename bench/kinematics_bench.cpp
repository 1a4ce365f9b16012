// Time per call of forward kinematics, the Jacobian, closed-form IK (all 8 solutions) and numeric
// IK for the PUMA 260, and, when built with KDL (liborocos-kdl-dev; scripts/install-deps.sh
// --peers), KDL's ChainFkSolverPos_recursive and ChainIkSolverPos_LMA on the same arm in the same
// run, printed as ratios. Goals: FK at least as fast as KDL; closed-form IK at least 10x faster
// than KDL's numeric IK.
//
//   build/bin/bench_kinematics [--calls N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/inverse_kinematics.hpp"
#include "core/model_loader.hpp"

#ifdef SIRUPP_HAVE_KDL
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_lma.hpp>
#endif

namespace {

using sirupp::core::JointVector;
using Clock = std::chrono::steady_clock;

// Median over 5 rounds of the mean time per call, nanoseconds.
template <class Body>
double NanosecondsPerCall(int calls, Body body) {
  std::vector<double> rounds;
  for (int round = 0; round < 5; ++round) {
    const auto start = Clock::now();
    for (int i = 0; i < calls; ++i) body(i);
    rounds.push_back(std::chrono::duration<double, std::nano>(Clock::now() - start).count() /
                     calls);
  }
  std::sort(rounds.begin(), rounds.end());
  return rounds[2];
}

volatile double sink = 0;  // keeps results alive so the optimiser cannot drop the work

#ifdef SIRUPP_HAVE_KDL
KDL::Frame ToKdl(const Eigen::Isometry3d& pose) {
  const Eigen::Matrix3d& r = pose.linear();
  return KDL::Frame(
      KDL::Rotation(r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1),
                    r(2, 2)),
      KDL::Vector(pose.translation().x(), pose.translation().y(), pose.translation().z()));
}

KDL::Chain ToKdlChain(const sirupp::core::RobotModel& model) {
  KDL::Chain chain;
  chain.addSegment(KDL::Segment(KDL::Joint(KDL::Joint::None), ToKdl(model.base.ToIsometry())));
  for (const sirupp::core::Joint& joint : model.joints) {
    chain.addSegment(KDL::Segment(
        KDL::Joint(KDL::Joint::RotZ),
        KDL::Frame::DH(joint.dh.a_m, joint.dh.alpha_rad, joint.dh.d_m, joint.dh.theta_rad)));
  }
  chain.addSegment(KDL::Segment(KDL::Joint(KDL::Joint::None), ToKdl(model.tool.ToIsometry())));
  return chain;
}
#endif

// The random poses every figure is measured on: joint vectors inside the limits and their tool
// poses.
struct Poses {
  std::vector<JointVector> qs;
  std::vector<Eigen::Isometry3d> targets;
  const JointVector& q(int i) const { return qs[static_cast<size_t>(i) % qs.size()]; }
  const Eigen::Isometry3d& target(int i) const {
    return targets[static_cast<size_t>(i) % targets.size()];
  }
};

Poses RandomPoses(const sirupp::core::RobotModel& model, int count) {
  std::mt19937 random(42);
  Poses poses;
  for (int k = 0; k < count; ++k) {
    JointVector q(6);
    for (int i = 0; i < 6; ++i) {
      const auto& joint = model.joints[static_cast<size_t>(i)];
      q[i] = std::uniform_real_distribution<double>(joint.position_min, joint.position_max)(random);
    }
    poses.qs.push_back(q);
    poses.targets.push_back(sirupp::core::ToolPose(model, q));
  }
  return poses;
}

// Our own figures, nanoseconds per call.
struct OurFigures {
  double fk_ns, jacobian_ns, ik_ns, numeric_ns;
};

OurFigures MeasureOurs(const sirupp::core::RobotModel& puma, const Poses& poses, int calls) {
  const sirupp::core::KinematicChain chain(puma);
  OurFigures ours{};
  ours.fk_ns = NanosecondsPerCall(
      calls, [&](int i) { sink = chain.ToolPose(poses.q(i)).translation().x(); });
  ours.jacobian_ns =
      NanosecondsPerCall(calls, [&](int i) { sink = chain.GeometricJacobian(poses.q(i))(0, 0); });
  ours.ik_ns = NanosecondsPerCall(calls / 4, [&](int i) {
    sink = static_cast<double>(
        sirupp::core::SolvePumaIk(puma, poses.target(i), poses.q(i)).solutions.size());
  });
  sirupp::core::NumericIkOptions numeric_options;
  numeric_options.stop_at_first = true;
  ours.numeric_ns = NanosecondsPerCall(std::max(50, calls / 100), [&](int i) {
    const JointVector seed = poses.q(i) + JointVector::Constant(6, 0.1);
    sink = static_cast<double>(
        sirupp::core::SolveNumericIk(puma, poses.target(i), seed, numeric_options)
            .solutions.size());
  });
  return ours;
}

#ifdef SIRUPP_HAVE_KDL
// KDL's FK and LMA IK on the same arm and poses, and the ratios to ours.
void CompareWithKdl(const sirupp::core::RobotModel& puma, const Poses& poses, int calls,
                    const OurFigures& ours) {
  const int count = static_cast<int>(poses.qs.size());
  const KDL::Chain kdl_chain = ToKdlChain(puma);
  KDL::ChainFkSolverPos_recursive kdl_fk(kdl_chain);
  KDL::ChainIkSolverPos_LMA kdl_ik(kdl_chain);
  std::vector<KDL::JntArray> kdl_qs;
  for (const JointVector& q : poses.qs) {
    KDL::JntArray array(6);
    array.data = q;
    kdl_qs.push_back(array);
  }
  // Same arm: KDL's tool pose must equal ours.
  double worst = 0;
  for (int k = 0; k < count; ++k) {
    KDL::Frame frame;
    kdl_fk.JntToCart(kdl_qs[static_cast<size_t>(k)], frame);
    const Eigen::Vector3d p(frame.p.x(), frame.p.y(), frame.p.z());
    worst = std::max(worst, (p - poses.targets[static_cast<size_t>(k)].translation()).norm());
  }
  const double kdl_fk_ns = NanosecondsPerCall(calls, [&](int i) {
    KDL::Frame frame;
    kdl_fk.JntToCart(kdl_qs[static_cast<size_t>(i % count)], frame);
    sink = frame.p.x();
  });
  int kdl_ok = 0, kdl_calls = 0;
  const double kdl_ik_ns = NanosecondsPerCall(std::max(50, calls / 100), [&](int i) {
    KDL::JntArray seed = kdl_qs[static_cast<size_t>(i % count)], out(6);
    seed.data.array() += 0.1;
    const int status = kdl_ik.CartToJnt(seed, ToKdl(poses.target(i)), out);
    kdl_ok += status >= 0 ? 1 : 0;
    ++kdl_calls;
    sink = out(0);
  });
  std::printf("KDL 1.5 (liborocos-kdl), same arm (tool positions agree to %.1e m)\n", worst);
  std::printf("  %-34s %12.0f ns/call\n", "ChainFkSolverPos_recursive", kdl_fk_ns);
  std::printf("  %-34s %12.0f ns/call  (%d of %d converged)\n", "ChainIkSolverPos_LMA (1 solution)",
              kdl_ik_ns, kdl_ok, kdl_calls);
  std::printf("ratios\n");
  std::printf("  FK time, ours / KDL                 %8.2f   (goal <= 1)\n",
              ours.fk_ns / kdl_fk_ns);
  std::printf("  KDL LMA IK / our closed-form IK      %8.1f   (goal >= 10; ours returns all 8)\n",
              kdl_ik_ns / ours.ik_ns);
  std::printf("  KDL LMA IK / our numeric IK          %8.2f\n", kdl_ik_ns / ours.numeric_ns);
}
#endif

}  // namespace

int main(int argc, char** argv) {
  int calls = 20000;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--calls") == 0 && i + 1 < argc) {
      calls = std::max(100, std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: bench_kinematics [--calls N]\n");
      return 2;
    }
  }
  const sirupp::core::RobotModel puma = sirupp::core::LoadRobotModel("config/robots/puma260.yaml");
  const int count = 256;
  const Poses poses = RandomPoses(puma, count);
  const OurFigures ours = MeasureOurs(puma, poses, calls);
  std::printf("SIRUPP-LCM kinematics, PUMA 260, %d random poses, median of 5 rounds\n", count);
  std::printf("  %-34s %12.0f ns/call\n", "forward kinematics (tool pose)", ours.fk_ns);
  std::printf("  %-34s %12.0f ns/call\n", "geometric Jacobian", ours.jacobian_ns);
  std::printf("  %-34s %12.0f ns/call\n", "closed-form IK, all 8 solutions", ours.ik_ns);
  std::printf("  %-34s %12.0f ns/call\n", "numeric IK (DLS, seed 0.1 rad off)", ours.numeric_ns);
#ifdef SIRUPP_HAVE_KDL
  CompareWithKdl(puma, poses, calls, ours);
#else
  std::printf(
      "KDL not found at build time: install liborocos-kdl-dev (scripts/install-deps.sh --peers)\n"
      "and rebuild to measure the ratios against KDL.\n");
#endif
  return 0;
}
