// The C++ side of tests/python/test_model.py: the libraries' own answers for one model and one
// state, printed with 17 significant digits (exact round trip), one "name value..." line each:
//
//   python_model_oracle MODEL.yaml Q1..QN QD1..QDN QDD1..QDDN
//
// fkine (4x4 row-major), jacob0 (6xn row-major), gravload, inertia (nxn row-major), bias, rne,
// and per closed-form IK solution of fkine(q) "ik CONFIG q1..qn".
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "core/dynamics.hpp"
#include "core/inverse_kinematics.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"

namespace {

void Print(const char* name, const Eigen::MatrixXd& m) {
  std::printf("%s", name);
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) std::printf(" %.17g", m(r, c));
  }
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc < 2) throw std::runtime_error("usage: python_model_oracle MODEL Q.. QD.. QDD..");
    const sirupp::core::RobotModel model = sirupp::core::LoadRobotModel(argv[1]);
    const int n = model.num_joints();
    if (argc != 2 + 3 * n)
      throw std::runtime_error("expected 3 x " + std::to_string(n) + " values");
    Eigen::VectorXd q(n), qd(n), qdd(n);
    for (int i = 0; i < n; ++i) {
      q[i] = std::strtod(argv[2 + i], nullptr);
      qd[i] = std::strtod(argv[2 + n + i], nullptr);
      qdd[i] = std::strtod(argv[2 + 2 * n + i], nullptr);
    }
    const Eigen::Isometry3d tool = sirupp::core::ToolPose(model, q);
    Print("fkine", tool.matrix());
    Print("jacob0", sirupp::core::GeometricJacobian(model, q));
    Print("gravload", sirupp::core::GravityEffort(model, q));
    Print("inertia", sirupp::core::MassMatrix(model, q));
    Print("bias", sirupp::core::BiasEffort(model, q, qd));
    Print("rne", sirupp::core::InverseDynamics(model, q, qd, qdd));
    if (!sirupp::core::PumaIkNotApplicable(model)) {
      Eigen::VectorXd home(n);
      for (int i = 0; i < n; ++i) home[i] = model.joints[static_cast<size_t>(i)].home;
      const sirupp::core::IkResult ik = sirupp::core::SolvePumaIk(model, tool, home);
      for (const sirupp::core::IkSolution& s : ik.solutions) {
        Print(("ik " + s.config->Name()).c_str(), s.q);
      }
    }
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "python_model_oracle: %s\n", error.what());
    return 2;
  }
}
