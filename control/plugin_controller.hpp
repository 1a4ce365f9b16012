#pragma once
// A student's controller loaded from a shared library built against include/sirupp/controller.h
// (`sirupp-control --controller LIB.so --controller-args "..."`), as the EffortLaw of ControlNode.
// Each tick it computes the arm's dynamics at the measured state (core/dynamics.hpp: gravity,
// bias and mass matrix), hands them to the student's Update with the state and the set-points, and
// returns the student's efforts. Tutorial: docs/student-controllers.md.

#include <sirupp/controller.h>

#include <string>
#include <vector>

#include "control/effort_law.hpp"
#include "core/dynamics.hpp"
#include "core/errors.hpp"
#include "core/robot_model.hpp"

namespace sirupp::control {

// A controller library that cannot be used: what() is "LIBRARY: problem" (the file cannot be
// loaded, is not a SIRUPP controller, was built against another ABI version, or refused its
// arguments). A ConfigError, so process mains print it on one line and exit 2.
class ControllerLoadError : public core::ConfigError {
 public:
  ControllerLoadError(const std::string& library, const std::string& problem)
      : core::ConfigError(core::SourceLocation{library, 0, 0}, "", problem) {}
};

class PluginEffortLaw : public EffortLaw {
 public:
  // Loads `library` (a path; one without '/' is taken relative to the working directory, not
  // searched for), checks its ABI version and factory functions, and creates the controller with
  // `args`. Throws ControllerLoadError naming the file and what is wrong.
  PluginEffortLaw(const std::string& library, const std::string& args,
                  const core::RobotModel& model);
  ~PluginEffortLaw() override;
  PluginEffortLaw(const PluginEffortLaw&) = delete;
  PluginEffortLaw& operator=(const PluginEffortLaw&) = delete;

  // The library's file name, e.g. "pd_gravity.so" (used in CONTROLLER_STATUS.last_error).
  const std::string& name() const override { return name_; }
  void Reset(const ControlInput& input) override;
  void Update(const ControlInput& input, std::vector<double>& effort) override;

 private:
  using DestroyFunction = void (*)(sirupp::Controller*);

  // Points state_ at the input and at freshly computed dynamics for its measured state.
  void Prepare(const ControlInput& input);

  std::string name_;
  void* handle_ = nullptr;  // from dlopen
  sirupp::Controller* controller_ = nullptr;
  DestroyFunction destroy_ = nullptr;

  core::Dynamics dynamics_;
  std::string model_name_;
  std::vector<double> effort_max_, position_min_, position_max_;
  sirupp::ArmInfo arm_{};
  sirupp::State state_{};
  std::vector<double> gravity_, bias_, mass_;  // mass_ row-major
};

}  // namespace sirupp::control
