// sirupp.Scene: the arm in its world for students (planning/): is-free queries, contacts with
// their depth, edge checks, OMPL planning and C-space slices, all through planning/'s one
// CollisionModel, so what Python answers is what `sirupp plan check --env` and the sim answer.
// Also `_path_to_plan_text` (planning/plan_text.hpp) for Rig.run_path.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/model_loader.hpp"
#include "core/motion_limits.hpp"
#include "core/robot_model.hpp"
#include "planning/collision_model.hpp"
#include "planning/plan_text.hpp"
#include "planning/planner.hpp"
#include "python/bindings.hpp"
#include "python/convert.hpp"

namespace sirupp::python {

namespace {

constexpr double kPi = 3.14159265358979323846;

// A model argument: a sirupp.Model or a model file's path.
std::shared_ptr<const core::RobotModel> ModelArg(const py::handle& value) {
  if (py::isinstance<py::str>(value)) {
    try {
      return std::make_shared<const core::RobotModel>(
          core::LoadRobotModel(value.cast<std::string>()));
    } catch (const core::ConfigError& error) {
      throw ModelError(error.what());
    }
  }
  if (auto model = ModelOf(value)) return model;
  throw py::value_error("model: " + std::string(py::str(py::repr(value))).substr(0, 80) +
                        "; expected a sirupp.Model or a model file (config/robots/*.yaml)");
}

// "RRTConnect", "rrt*", "BIT*" ... -> planning's names ("rrtconnect", "rrtstar", "bitstar").
std::string PlannerArg(const std::string& name) {
  std::string key;
  for (char c : name) {
    if (c == '*') {
      key += "star";
    } else if (c != '-' && c != '_' && c != ' ') {
      key += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
  }
  const auto& names = planning::PlannerNames();
  if (std::find(names.begin(), names.end(), key) == names.end()) {
    throw py::value_error("planner: '" + name +
                          "'; allowed: RRTConnect, RRT, PRM, RRT*, BIT*, KPIECE, SBL (any case)");
  }
  return key;
}

py::array_t<double> PathArray(const std::vector<core::JointVector>& path, int n) {
  py::array_t<double> out({static_cast<py::ssize_t>(path.size()), static_cast<py::ssize_t>(n)});
  auto view = out.mutable_unchecked<2>();
  for (size_t i = 0; i < path.size(); ++i) {
    for (int j = 0; j < n; ++j) view(static_cast<py::ssize_t>(i), j) = path[i][j];
  }
  return out;
}

// A k x n array-like of joint vectors, named `name` in messages.
std::vector<core::JointVector> PathArg(const py::handle& value, int n, const std::string& name,
                                       const std::string& what_n) {
  if (value.is_none() || py::isinstance<py::str>(value)) {
    throw py::value_error(name + ": expected a k x " + std::to_string(n) +
                          " array of joint vectors (" + what_n + ")");
  }
  std::vector<core::JointVector> path;
  py::ssize_t index = 0;
  for (const py::handle row : py::iter(value)) {
    path.push_back(VectorArg(row, n, name + "[" + std::to_string(index) + "]", what_n));
    ++index;
  }
  if (path.empty()) throw py::value_error(name + ": empty; expected at least one joint vector");
  return path;
}

double PositiveArg(double value, const std::string& name, double low, double high,
                   const std::string& unit) {
  if (!(value > low && value <= high)) {
    throw py::value_error(name + ": " + core::FormatNumber(value) + "; allowed (" +
                          core::FormatNumber(low) + ", " + core::FormatNumber(high) + "] " + unit);
  }
  return value;
}

class Scene {
 public:
  Scene(const py::handle& model, const std::string& environment_file, double padding,
        bool self_collision)
      : model_(ModelArg(model)) {
    try {
      environment_ = core::LoadEnvironment(environment_file);
    } catch (const core::ConfigError& error) {
      throw py::value_error(error.what());
    }
    if (!(padding >= 0 && padding <= 0.1)) {
      throw py::value_error("padding: " + core::FormatNumber(padding) +
                            " m; allowed 0 to 0.1 m (around the arm's shapes)");
    }
    planning::CollisionOptions options;
    options.padding_m = padding;
    options.self_collision = self_collision;
    collision_ = std::make_unique<planning::CollisionModel>(*model_, environment_, options);
  }

  int n() const { return model_->num_joints(); }
  const core::RobotModel& model() const { return *model_; }
  const core::Environment& environment() const { return environment_; }
  planning::CollisionModel& collision() { return *collision_; }

  core::JointVector Joints(const py::handle& q, const std::string& name) const {
    return VectorArg(q, n(), name, model_->name + " has " + std::to_string(n()) + " joints");
  }
  std::vector<core::JointVector> Path(const py::handle& path, const std::string& name) const {
    return PathArg(path, n(), name, model_->name + " has " + std::to_string(n()) + " joints");
  }

  static planning::CheckFilter Filter(bool free_objects) {
    return free_objects ? planning::CheckFilter{} : planning::CheckFilter::StaticAndSelf();
  }

  py::dict ContactDict(const planning::Contact& c) const {
    py::dict d;
    d["kind"] = std::string(planning::ContactKindName(c.kind));
    d["link"] = c.link;
    d["link_name"] = collision_->LinkName(c.link);
    if (c.kind == planning::ContactKind::kSelf) {
      d["other"] = collision_->LinkName(c.other_link);
      d["other_link"] = c.other_link;
      d["object"] = py::none();
    } else {
      const std::string& name = environment_.objects[static_cast<size_t>(c.object)].name;
      d["other"] = collision_->ObjectName(c.object);
      d["other_link"] = py::none();
      d["object"] = name;
    }
    d["depth_m"] = c.depth_m;
    d["point"] = ToArray(Eigen::VectorXd(c.point_m));
    d["text"] = collision_->Describe(c);
    return d;
  }

  py::dict EdgeDict(const planning::EdgeCheck& e) const {
    py::dict d;
    d["free"] = e.free;
    d["fraction"] = e.fraction;
    d["q"] = e.free ? py::object(py::none()) : py::object(ToArray(e.state));
    d["contact"] = e.contact ? py::object(ContactDict(*e.contact)) : py::object(py::none());
    d["states_checked"] = e.states_checked;
    return d;
  }

  py::dict PlanDict(const planning::PlanResult& r) const {
    py::dict d;
    d["solved"] = r.solved;
    d["message"] = r.message;
    d["planner"] = r.planner;
    d["solved_by"] = r.solved_by;
    d["fell_back"] = r.fell_back;
    d["solve_s"] = r.solve_s;
    d["simplify_s"] = r.simplify_s;
    d["states_checked"] = r.states_checked;
    d["raw_length_rad"] = r.raw_length_rad;
    d["length_rad"] = r.length_rad;
    d["path"] = PathArray(r.path, n());
    d["tree_vertices"] = PathArray(r.tree.vertices, n());
    py::array_t<int64_t> edges({static_cast<py::ssize_t>(r.tree.edges.size()), py::ssize_t{2}});
    auto view = edges.mutable_unchecked<2>();
    for (size_t i = 0; i < r.tree.edges.size(); ++i) {
      view(static_cast<py::ssize_t>(i), 0) = r.tree.edges[i].first;
      view(static_cast<py::ssize_t>(i), 1) = r.tree.edges[i].second;
    }
    d["tree_edges"] = edges;
    return d;
  }

 private:
  std::shared_ptr<const core::RobotModel> model_;
  core::Environment environment_;
  std::unique_ptr<planning::CollisionModel> collision_;
};

// planning's std::invalid_argument (a start touching the table, ...) as a ValueError.
template <typename F>
auto Checked(F&& f) {
  try {
    return f();
  } catch (const std::invalid_argument& error) {
    throw py::value_error(error.what());
  }
}

// A path argument as plan text (planning/plan_text.hpp), for Scene.plan_text and Rig.run_path.
std::string PlanText(const core::RobotModel& robot, const py::handle& path, double speed_fraction,
                     double accel_fraction, bool move_to_start,
                     const std::vector<std::string>& comments) {
  const std::string what_n = robot.name + " has " + std::to_string(robot.num_joints()) + " joints";
  const auto waypoints = PathArg(path, robot.num_joints(), "path", what_n);
  planning::PlanTextOptions options;
  options.speed_fraction = PositiveArg(speed_fraction, "speed_fraction", 0, 1, "");
  options.accel_fraction = PositiveArg(accel_fraction, "accel_fraction", 0, 4, "");
  options.move_to_start = move_to_start;
  options.comments = comments;
  return Checked([&] { return planning::PathToPlanText(robot, waypoints, options); });
}

}  // namespace

void BindPlanning(py::module_& m) {
  m.def(
      "_path_to_plan_text",
      [](const py::handle& model, const py::handle& path, double speed_fraction,
         double accel_fraction, bool move_to_start, const std::vector<std::string>& comments) {
        return PlanText(*ModelArg(model), path, speed_fraction, accel_fraction, move_to_start,
                        comments);
      },
      py::arg("model"), py::arg("path"), py::arg("speed_fraction") = 1.0,
      py::arg("accel_fraction") = 1.0, py::arg("move_to_start") = true,
      py::arg("comments") = std::vector<std::string>{},
      "a k x n joint path as a movement plan's text (planning/plan_text.hpp)");

  py::class_<Scene>(m, "Scene", R"(The arm of a model in an environment (config/environments/*.xml):
collision queries, planning and C-space slices over planning/'s collision model (the one
`sirupp plan check --env` and the sim use). Joint vectors in rad (m for prismatic joints).

    scene = sirupp.Scene("config/robots/puma260.yaml", "config/environments/table.xml")
    scene.is_free(q); scene.contacts(q); scene.edge_free(q0, q1, 0.01)
    path = scene.plan(q_start, q_goal)            # k x n array, start first
    qa, qb, cells = scene.cspace(1, 2, q_fixed)   # 0 free, 1 static, 2 free object, 3 self)")
      .def(py::init([](const py::handle& model, const std::string& environment, double padding,
                       bool self_collision) {
             return std::make_unique<Scene>(model, environment, padding, self_collision);
           }),
           py::arg("model"), py::arg("environment"), py::arg("padding") = 0.01,
           py::arg("self_collision") = true,
           "model: a sirupp.Model or a model file; environment: an environment file; padding: "
           "metres added around the arm's shapes against objects (0 to 0.1, default 0.01, as "
           "`sirupp plan make`)")
      .def_property_readonly("n", &Scene::n, "number of joints")
      .def_property_readonly("model_file", [](const Scene& s) { return s.model().source_file; })
      .def_property_readonly("environment_file",
                             [](const Scene& s) { return s.environment().source_file; })
      .def_property_readonly(
          "objects",
          [](const Scene& s) {
            py::list out;
            for (const auto& o : s.environment().objects) {
              py::dict d;
              d["name"] = o.name;
              d["static"] = o.is_static;
              d["shape"] = std::string(core::ShapeTypeName(o.shape.type));
              d["pose"] = ToArray(o.shape.pose.ToIsometry());
              out.append(d);
            }
            return out;
          },
          "the environment's objects: dicts with name, static, shape, pose")
      .def_property(
          "padding", [](Scene& s) { return s.collision().options().padding_m; },
          [](Scene& s, double padding) {
            Checked([&] {
              s.collision().SetPadding(padding);
              return 0;
            });
          },
          "m around the arm's shapes against objects (0 to 0.1)")
      .def_property_readonly(
          "qlim",
          [](Scene& s) {
            const core::MotionLimits soft = core::DefaultMotionLimits(s.model());
            Eigen::MatrixXd limits(2, s.n());
            for (int j = 0; j < s.n(); ++j) {
              limits(0, j) = core::SoftMin(s.model(), soft, j);
              limits(1, j) = core::SoftMax(s.model(), soft, j);
            }
            return ToArray(limits);
          },
          "2 x n: the soft limits (the model's limits moved inward by sirupp-control's margin): "
          "what the planner samples within and a plan may reach (row 0 lower, row 1 upper)")
      .def(
          "is_free",
          [](Scene& s, const py::handle& q, bool free_objects) {
            return s.collision().IsFree(s.Joints(q, "q"), Scene::Filter(free_objects));
          },
          py::arg("q"), py::arg("free_objects") = true,
          "True when the arm at q touches nothing (free_objects=False: the blocks may be "
          "touched; static objects and the arm itself still count)")
      .def(
          "contacts",
          [](Scene& s, const py::handle& q, bool free_objects) {
            py::list out;
            for (const planning::Contact& c :
                 s.collision().Contacts(s.Joints(q, "q"), Scene::Filter(free_objects))) {
              out.append(s.ContactDict(c));
            }
            return out;
          },
          py::arg("q"), py::arg("free_objects") = true,
          "every touching pair at q, as dicts: kind ('static object', 'free object', 'self'), "
          "link, link_name, other (the object's or other link's name), object, other_link, "
          "depth_m, point (world, m), text; [] when free")
      .def(
          "edge_free",
          [](Scene& s, const py::handle& q0, const py::handle& q1, double step, bool free_objects) {
            const auto a = s.Joints(q0, "q0");
            const auto b = s.Joints(q1, "q1");
            PositiveArg(step, "step", 0, 1, "rad");
            return s.collision().CheckEdge(a, b, step, Scene::Filter(free_objects)).free;
          },
          py::arg("q0"), py::arg("q1"), py::arg("step") = 0.01, py::arg("free_objects") = true,
          "True when the straight joint-space segment q0 -> q1 is free, checked at states no "
          "joint of which moves more than `step` rad from the previous (q0 and q1 included)")
      .def(
          "check_edge",
          [](Scene& s, const py::handle& q0, const py::handle& q1, double step, bool free_objects) {
            const auto a = s.Joints(q0, "q0");
            const auto b = s.Joints(q1, "q1");
            PositiveArg(step, "step", 0, 1, "rad");
            return s.EdgeDict(s.collision().CheckEdge(a, b, step, Scene::Filter(free_objects)));
          },
          py::arg("q0"), py::arg("q1"), py::arg("step") = 0.01, py::arg("free_objects") = true,
          "edge_free with the first touching state: dict free, fraction (0..1), q, contact, "
          "states_checked")
      .def(
          "plan",
          [](Scene& s, const py::handle& start, const py::handle& goal, const std::string& planner,
             int64_t seed, double time, int64_t iterations, bool simplify, double step,
             bool free_objects, bool tree) {
            planning::PlanRequest request;
            request.planner = PlannerArg(planner);
            if (seed < 0 || seed > 4294967295LL) {
              throw py::value_error("seed: " + std::to_string(seed) + "; allowed 0 to 4294967295");
            }
            request.seed = static_cast<uint32_t>(seed);
            request.time_limit_s = PositiveArg(time, "time", 0, 600, "s");
            if (iterations < 0 || iterations > 1000000000) {
              throw py::value_error("iterations: " + std::to_string(iterations) +
                                    "; allowed 0 (no limit) to 10^9");
            }
            request.iteration_limit = iterations;
            request.simplify = simplify;
            request.edge_step_rad = PositiveArg(step, "step", 0, 0.2, "rad");
            request.avoid = Scene::Filter(free_objects);
            request.keep_tree = tree;
            const auto a = s.Joints(start, "start");
            const auto b = s.Joints(goal, "goal");
            planning::PlanResult result;
            {
              py::gil_scoped_release release;
              result = Checked([&] { return planning::PlanPath(s.collision(), a, b, request); });
            }
            return s.PlanDict(result);
          },
          py::arg("start"), py::arg("goal"), py::arg("planner") = "RRTConnect", py::arg("seed") = 1,
          py::arg("time") = 1.0, py::arg("iterations") = 0, py::arg("simplify") = true,
          py::arg("step") = 0.01, py::arg("free_objects") = true, py::arg("tree") = false,
          "planning.PlanPath; sirupp.Scene.plan wraps it")
      .def(
          "cspace",
          [](Scene& s, int joint_a, int joint_b, const py::handle& q_fixed, double step_deg,
             bool free_objects) {
            if (joint_a < 0 || joint_a >= s.n() || joint_b < 0 || joint_b >= s.n() ||
                joint_a == joint_b) {
              throw py::value_error("joints: " + std::to_string(joint_a) + ", " +
                                    std::to_string(joint_b) + "; expected two different joints " +
                                    "0 to " + std::to_string(s.n() - 1) + " (0-based)");
            }
            PositiveArg(step_deg, "step_deg", 0, 30, "degrees");
            const auto q = s.Joints(q_fixed, "q_fixed");
            planning::CSpaceSlice slice;
            {
              py::gil_scoped_release release;
              slice = Checked([&] {
                return planning::ComputeCSpaceSlice(s.collision(), q, joint_a, joint_b,
                                                    step_deg * kPi / 180,
                                                    Scene::Filter(free_objects));
              });
            }
            py::array_t<uint8_t> cells({static_cast<py::ssize_t>(slice.values_b.size()),
                                        static_cast<py::ssize_t>(slice.values_a.size())});
            std::copy(slice.cells.begin(), slice.cells.end(), cells.mutable_data());
            return py::make_tuple(ToArray(slice.values_a), ToArray(slice.values_b), cells);
          },
          py::arg("j_a"), py::arg("j_b"), py::arg("q_fixed"), py::arg("step_deg") = 1.0,
          py::arg("free_objects") = true,
          R"(A C-space slice: joints j_a and j_b (0-based) on a grid over their limits every
step_deg degrees, the other joints at q_fixed. Returns (qa, qb, cells): qa and qb the grid values
(rad), cells[ib, ia] 0 free, 1 a static object, 2 a free object (only), 3 the arm itself (only).
    plt.pcolormesh(qa, qb, cells))")
      .def(
          "plan_text",
          [](const Scene& s, const py::handle& path, double speed_fraction, double accel_fraction,
             bool move_to_start, const std::vector<std::string>& comments) {
            return PlanText(s.model(), path, speed_fraction, accel_fraction, move_to_start,
                            comments);
          },
          py::arg("path"), py::arg("speed_fraction") = 1.0, py::arg("accel_fraction") = 1.0,
          py::arg("move_to_start") = true, py::arg("comments") = std::vector<std::string>{},
          R"(The path (k x n) as a movement plan's text (docs/plan-format.md): each segment one
synchronized trapezoid, so the controller's set-points stay on the checked straight segments;
first a move to the path's start unless move_to_start=False. speed_fraction (0, 1] of the joints'
default speeds, accel_fraction (0, 4].)")
      .def("__repr__", [](const Scene& s) {
        return "<sirupp.Scene " + s.model().name + " in " + s.environment().name + " (" +
               std::to_string(s.environment().objects.size()) + " objects)>";
      });
}

}  // namespace sirupp::python
