// sirupp.Model: the robot model with its kinematics and dynamics (core/), RTB-like names.
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>

#include "core/dynamics.hpp"
#include "core/errors.hpp"
#include "core/inverse_kinematics.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"
#include "core/robot_model.hpp"
#include "python/bindings.hpp"
#include "python/convert.hpp"

namespace sirupp::python {

namespace {

// One model, loaded once, with its chain and dynamics prepared for repeated calls.
class Model {
 public:
  explicit Model(core::RobotModel model)
      : model_(std::make_shared<const core::RobotModel>(std::move(model))),
        chain_(*model_),
        dynamics_(*model_) {}

  const core::RobotModel& model() const { return *model_; }
  const std::shared_ptr<const core::RobotModel>& shared_model() const { return model_; }
  int n() const { return model_->num_joints(); }

  Eigen::VectorXd Joints(const py::handle& q, const char* name) const {
    return VectorArg(q, n(), name, model_->name + " has " + std::to_string(n()) + " joints");
  }

  py::array_t<double> Fkine(const py::handle& q) const {
    return ToArray(chain_.ToolPose(Joints(q, "q")));
  }

  py::array_t<double> FkineAll(const py::handle& q) const {
    const core::ForwardResult result = chain_.Forward(Joints(q, "q"));
    py::array_t<double> out(
        {static_cast<py::ssize_t>(result.frames.size()), py::ssize_t{4}, py::ssize_t{4}});
    auto view = out.mutable_unchecked<3>();
    for (size_t k = 0; k < result.frames.size(); ++k) {
      const Eigen::Matrix4d m = result.frames[k].matrix();
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) view(static_cast<py::ssize_t>(k), r, c) = m(r, c);
      }
    }
    return out;
  }

  py::array_t<double> Jacob0(const py::handle& q) const {
    return ToArray(Eigen::MatrixXd(chain_.GeometricJacobian(Joints(q, "q"))));
  }

  double Manipulability(const py::handle& q) const {
    return core::Manipulability(chain_.GeometricJacobian(Joints(q, "q")));
  }

  py::list Singularities(const py::handle& q) const {
    py::list names;
    for (const std::string& name : core::Singularities(*model_, Joints(q, "q"))) names.append(name);
    return names;
  }

  py::list Ikine(const py::handle& target, const py::object& q0,
                 const std::optional<std::string>& config, bool position_only) const {
    const Eigen::Isometry3d pose = PoseArg(target, "T");
    std::optional<core::IkConfiguration> wanted;
    if (config) {
      wanted = core::IkConfiguration::Parse(*config);
      if (!wanted) {
        throw py::value_error("config: '" + *config +
                              "'; expected shoulder-elbow-wrist like 'left-up-noflip' (left|right, "
                              "up|down, noflip|flip)");
      }
    }
    Eigen::VectorXd reference(n());
    for (int i = 0; i < n(); ++i) reference[i] = model_->joints[static_cast<size_t>(i)].home;
    if (!q0.is_none()) reference = Joints(q0, "q0");
    const core::IkRequest request{!q0.is_none(), position_only};  // q0: numeric, from there
    const core::IkSolverChoice choice = core::ChooseIkSolver(*model_, request);
    if (wanted && !choice.closed_form) {
      throw py::value_error("config: " + *config +
                            " needs the closed-form solver, which does not apply here (" +
                            choice.not_closed_form + ")");
    }
    core::IkResult result;
    {
      py::gil_scoped_release release;
      result = core::SolveIk(*model_, pose, reference, request);
    }
    py::list solutions;
    for (const core::IkSolution& s : result.solutions) {
      if (wanted && !(s.config && *s.config == *wanted)) continue;
      solutions.append(MakeIkSolution(s));
    }
    if (py::len(solutions) == 0) {
      std::string reason = result.ok() ? "configuration " + config.value_or("") +
                                             " has no solution inside the joint limits"
                                       : result.reason;
      throw IkError(reason);
    }
    return solutions;
  }

  py::array_t<double> Gravload(const py::handle& q) const {
    return ToArray(dynamics_.GravityEffort(Joints(q, "q")));
  }
  py::array_t<double> Inertia(const py::handle& q) const {
    return ToArray(dynamics_.MassMatrix(Joints(q, "q")));
  }
  py::array_t<double> Coriolis(const py::handle& q, const py::handle& qd) const {
    const Eigen::VectorXd qv = Joints(q, "q");
    return ToArray(
        Eigen::VectorXd(dynamics_.BiasEffort(qv, Joints(qd, "qd")) - dynamics_.GravityEffort(qv)));
  }
  py::array_t<double> Bias(const py::handle& q, const py::handle& qd) const {
    return ToArray(dynamics_.BiasEffort(Joints(q, "q"), Joints(qd, "qd")));
  }
  py::array_t<double> Rne(const py::handle& q, const py::handle& qd, const py::handle& qdd) const {
    return ToArray(dynamics_.InverseDynamics(Joints(q, "q"), Joints(qd, "qd"), Joints(qdd, "qdd")));
  }

  py::array_t<double> Dh() const {
    Eigen::MatrixXd table(n(), 4);
    for (int i = 0; i < n(); ++i) {
      const core::DhRow& row = model_->joints[static_cast<size_t>(i)].dh;
      table.row(i) << row.a_m, row.alpha_rad, row.d_m, row.theta_rad;
    }
    return ToArray(table);
  }

  py::array_t<double> Qlim() const {
    Eigen::MatrixXd limits(2, n());
    for (int i = 0; i < n(); ++i) {
      limits(0, i) = model_->joints[static_cast<size_t>(i)].position_min;
      limits(1, i) = model_->joints[static_cast<size_t>(i)].position_max;
    }
    return ToArray(limits);
  }

  template <class Field>
  py::array_t<double> PerJoint(Field field) const {
    std::vector<double> values;
    for (const core::Joint& joint : model_->joints) values.push_back(field(joint));
    return ToArray(values);
  }

  py::dict Poses() const {
    py::dict poses;
    for (const core::NamedPose& pose : model_->named_poses) {
      poses[py::str(pose.name)] = ToArray(pose.position);
    }
    return poses;
  }

  py::array_t<double> Pose(const std::string& name) const {
    const core::NamedPose* pose = model_->FindNamedPose(name);
    if (pose == nullptr) {
      std::string known;
      for (const core::NamedPose& p : model_->named_poses)
        known += (known.empty() ? "" : ", ") + p.name;
      throw py::value_error("pose '" + name + "': " + model_->name + " has no such named pose (" +
                            (known.empty() ? "it has none" : "it has " + known) + ")");
    }
    return ToArray(pose->position);
  }

 private:
  static py::dict MakeIkSolution(const core::IkSolution& s) {
    py::dict d;
    d["q"] = ToArray(s.q);
    if (s.config) {
      d["config"] = s.config->Name();
      d["shoulder_left"] = s.config->shoulder_left;
      d["elbow_up"] = s.config->elbow_up;
      d["wrist_flip"] = s.config->wrist_flip;
    } else {
      d["config"] = py::none();
    }
    d["within_limits"] = s.within_limits;
    d["position_error_m"] = s.error.position_m;
    d["rotation_error_rad"] = s.error.rotation_rad;
    py::list singular;
    for (const std::string& name : s.singularities) singular.append(name);
    d["singularities"] = singular;
    return d;
  }

  std::shared_ptr<const core::RobotModel> model_;
  core::KinematicChain chain_;
  core::Dynamics dynamics_;
};

Model LoadModel(const std::string& file) {
  try {
    return Model(core::LoadRobotModel(file));
  } catch (const core::ConfigError& error) {
    throw ModelError(error.what());
  }
}

}  // namespace

std::shared_ptr<const core::RobotModel> ModelOf(const py::handle& value) {
  if (!py::isinstance<Model>(value)) return nullptr;
  return value.cast<const Model&>().shared_model();
}

void BindModel(py::module_& m) {
  m.def(
      "_pose_parts",
      [](const py::handle& target) {
        const Eigen::Isometry3d pose = PoseArg(target, "T");
        const Eigen::Quaterniond q(pose.linear());
        return py::make_tuple(
            ToArray(Eigen::VectorXd(pose.translation())),
            ToArray(Eigen::VectorXd(Eigen::Vector4d(q.w(), q.x(), q.y(), q.z()))));
      },
      py::arg("T"), "position (3) and unit quaternion w x y z (4) of a checked 4x4 pose");
  py::class_<Model>(m, "Model", R"(A robot model (config/robots/*.yaml) with its kinematics and
dynamics. SI units: rad, m, s, kg, N*m. Joint vectors are 1-D numpy arrays of n values.)")
      .def(py::init(&LoadModel), py::arg("file"),
           "Loads a model file; ModelError with 'file:line:col: key: problem' when it is bad.")
      .def_static(
          "from_yaml",
          [](const std::string& text, const std::string& name) {
            try {
              return Model(core::ParseRobotModel(text, name));
            } catch (const core::ConfigError& error) {
              throw ModelError(error.what());
            }
          },
          py::arg("text"), py::arg("name") = "<string>", "A model from YAML text.")
      .def_property_readonly("n", &Model::n, "number of joints")
      .def_property_readonly("name", [](const Model& self) { return self.model().name; })
      .def_property_readonly("file", [](const Model& self) { return self.model().source_file; })
      .def_property_readonly("description",
                             [](const Model& self) { return self.model().description; })
      .def_property_readonly(
          "convention",
          [](const Model& self) {
            return std::string(core::DhConventionName(self.model().dh_convention));
          })
      .def_property_readonly("dh", &Model::Dh,
                             "n x 4 array, one row per joint: a (m), alpha (rad), d (m), theta "
                             "offset (rad); theta = q + offset (revolute) or d = q + d (prismatic)")
      .def_property_readonly("joint_types",
                             [](const Model& self) {
                               py::list types;
                               for (const core::Joint& j : self.model().joints) {
                                 types.append(core::JointTypeName(j.type));
                               }
                               return types;
                             })
      .def_property_readonly("joint_names",
                             [](const Model& self) {
                               py::list names;
                               for (const core::Joint& j : self.model().joints)
                                 names.append(j.name);
                               return names;
                             })
      .def_property_readonly("qlim", &Model::Qlim, "2 x n: row 0 lower, row 1 upper limits")
      .def_property_readonly(
          "qd_max",
          [](const Model& self) {
            return self.PerJoint([](const core::Joint& j) { return j.velocity_max; });
          })
      .def_property_readonly(
          "effort_max",
          [](const Model& self) {
            return self.PerJoint([](const core::Joint& j) { return j.effort_max; });
          })
      .def_property_readonly("home",
                             [](const Model& self) {
                               return self.PerJoint([](const core::Joint& j) { return j.home; });
                             })
      .def_property_readonly("poses", &Model::Poses, "named poses: {name: q}")
      .def("pose", &Model::Pose, py::arg("name"), "q of a named pose")
      .def_property_readonly("servo_tick_s",
                             [](const Model& self) { return self.model().servo_tick_s; })
      .def_property_readonly(
          "gravity",
          [](const Model& self) { return ToArray(Eigen::VectorXd(self.model().gravity_m_s2)); })
      .def_property_readonly(
          "base", [](const Model& self) { return ToArray(self.model().base.ToIsometry()); })
      .def_property_readonly(
          "tool", [](const Model& self) { return ToArray(self.model().tool.ToIsometry()); })
      .def("fkine", &Model::Fkine, py::arg("q"), "tool pose in the world: 4x4 array")
      .def("fkine_all", &Model::FkineAll, py::arg("q"),
           "world poses of DH frames 0..n: (n+1) x 4 x 4 array (the tool is fkine(q))")
      .def("jacob0", &Model::Jacob0, py::arg("q"),
           "geometric Jacobian in the world frame, 6 x n: rows vx vy vz wx wy wz")
      .def("manipulability", &Model::Manipulability, py::arg("q"), "Yoshikawa's sqrt(det(J J^T))")
      .def("singularities", &Model::Singularities, py::arg("q"),
           "names of the singularities at q ('wrist', 'elbow', 'shoulder'), [] when regular")
      .def("ikine", &Model::Ikine, py::arg("T"), py::arg("q0") = py::none(),
           py::arg("config") = py::none(), py::arg("position_only") = false,
           R"(Joint vectors that put the tool at pose T (4x4).

Without q0: every closed-form solution (PUMA-type arms, up to 8), within the joint limits first,
each a dict with q, config ('left-up-noflip'...), shoulder_left, elbow_up, wrist_flip,
within_limits, position_error_m, rotation_error_rad, singularities. config='left-up-noflip' keeps
that one. With q0 (or for arms the closed form does not fit): the numeric solver from q0, nearest
first. IKError with the reason when there is none.)")
      .def("gravload", &Model::Gravload, py::arg("q"), "G(q): efforts holding the arm still")
      .def("inertia", &Model::Inertia, py::arg("q"), "M(q): n x n mass matrix, armature included")
      .def("coriolis", &Model::Coriolis, py::arg("q"), py::arg("qd"),
           "C(q, qd) qd: the Coriolis and centrifugal efforts (a vector)")
      .def("bias", &Model::Bias, py::arg("q"), py::arg("qd"), "C(q, qd) qd + G(q)")
      .def("rne", &Model::Rne, py::arg("q"), py::arg("qd"), py::arg("qdd"),
           "inverse dynamics: M(q) qdd + C(q, qd) qd + G(q)")
      .def("__repr__", [](const Model& self) {
        return "<sirupp.Model " + self.model().name + ", " + std::to_string(self.n()) +
               " joints, " + self.model().source_file + ">";
      });
}

}  // namespace sirupp::python
