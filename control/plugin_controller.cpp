#include "control/plugin_controller.hpp"

#include <cxxabi.h>
#include <dlfcn.h>

#include <Eigen/Core>
#include <cstdlib>
#include <stdexcept>
#include <typeinfo>

namespace sirupp::control {
namespace {

using AbiVersionFunction = int (*)();
using CreateFunction = sirupp::Controller* (*)(const char*, char*, std::size_t);

constexpr const char* kAbiSymbol = "sirupp_controller_abi_version";
constexpr const char* kCreateSymbol = "sirupp_controller_create";
constexpr const char* kDestroySymbol = "sirupp_controller_destroy";
constexpr const char* kHowToExport =
    "export the factory functions with SIRUPP_EXPORT_CONTROLLER(YourClass) from "
    "<sirupp/controller.h>";

// dlsym's result as a function pointer (POSIX guarantees the conversion works).
template <class Function>
Function Symbol(void* handle, const char* symbol) {
  return reinterpret_cast<Function>(dlsym(handle, symbol));
}

// The demangled type name of an exception, e.g. "std::out_of_range".
std::string TypeName(const std::exception& exception) {
  const char* mangled = typeid(exception).name();
  int status = 0;
  char* demangled = abi::__cxa_demangle(mangled, nullptr, nullptr, &status);
  std::string name = status == 0 && demangled != nullptr ? demangled : mangled;
  std::free(demangled);
  return name;
}

// Calls into the student's code (`call` is "Reset" or "Update"); anything it throws reaches
// ControlNode as a std::runtime_error naming the call and the exception:
// "Update threw std::out_of_range: vector::at".
template <class Body>
void Guarded(const char* call, Body body) {
  try {
    body();
  } catch (const std::exception& exception) {
    throw std::runtime_error(std::string(call) + " threw " + TypeName(exception) + ": " +
                             exception.what());
  } catch (...) {
    throw std::runtime_error(std::string(call) +
                             " threw an exception not derived from std::exception");
  }
}

}  // namespace

PluginEffortLaw::PluginEffortLaw(const std::string& library, const std::string& args,
                                 const core::RobotModel& model)
    : dynamics_(model), model_name_(model.name) {
  const size_t slash = library.find_last_of('/');
  name_ = slash == std::string::npos ? library : library.substr(slash + 1);
  // dlopen searches the library path for a bare name; a student means the file in front of them.
  const std::string path = slash == std::string::npos ? "./" + library : library;
  handle_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle_ == nullptr) {
    throw ControllerLoadError(library,
                              std::string("cannot load the controller library: ") + dlerror());
  }
  try {
    const auto abi_version = Symbol<AbiVersionFunction>(handle_, kAbiSymbol);
    if (abi_version == nullptr) {
      throw ControllerLoadError(library, std::string("not a SIRUPP controller: no symbol ") +
                                             kAbiSymbol + "; " + kHowToExport);
    }
    const int version = abi_version();
    if (version != SIRUPP_CONTROLLER_ABI_VERSION) {
      throw ControllerLoadError(
          library, "built against controller ABI version " + std::to_string(version) +
                       ", this sirupp-control needs version " +
                       std::to_string(SIRUPP_CONTROLLER_ABI_VERSION) +
                       ": rebuild it against the installed include/sirupp/controller.h");
    }
    const auto create = Symbol<CreateFunction>(handle_, kCreateSymbol);
    destroy_ = Symbol<DestroyFunction>(handle_, kDestroySymbol);
    if (create == nullptr || destroy_ == nullptr) {
      const std::string missing = create == nullptr && destroy_ == nullptr
                                      ? std::string(kCreateSymbol) + " and " + kDestroySymbol
                                      : (create == nullptr ? kCreateSymbol : kDestroySymbol);
      throw ControllerLoadError(
          library, "not a SIRUPP controller: no symbol " + missing + "; " + kHowToExport);
    }
    char error[512] = "";
    controller_ = create(args.c_str(), error, sizeof error);
    if (controller_ == nullptr) {
      throw ControllerLoadError(library, "the controller refused its arguments '" + args + "': " +
                                             (error[0] != '\0' ? error : "no reason given"));
    }
  } catch (...) {
    dlclose(handle_);
    throw;
  }

  const int n = model.num_joints();
  for (const core::Joint& joint : model.joints) {
    effort_max_.push_back(joint.effort_max);
    position_min_.push_back(joint.position_min);
    position_max_.push_back(joint.position_max);
  }
  arm_.num_joints = n;
  arm_.model_name = model_name_.c_str();
  arm_.servo_tick_s = model.servo_tick_s;
  arm_.effort_max = effort_max_.data();
  arm_.position_min = position_min_.data();
  arm_.position_max = position_max_.data();
  gravity_.resize(static_cast<size_t>(n));
  bias_.resize(static_cast<size_t>(n));
  mass_.resize(static_cast<size_t>(n) * static_cast<size_t>(n));
}

PluginEffortLaw::~PluginEffortLaw() {
  destroy_(controller_);
  dlclose(handle_);
}

void PluginEffortLaw::Prepare(const ControlInput& input) {
  const int n = dynamics_.num_joints();
  const core::ArmState& measured = *input.state;
  const Eigen::Map<const Eigen::VectorXd> q(measured.position.data(), n);
  const Eigen::Map<const Eigen::VectorXd> qd(measured.velocity.data(), n);
  Eigen::Map<Eigen::VectorXd>(gravity_.data(), n) = dynamics_.GravityEffort(q);
  Eigen::Map<Eigen::VectorXd>(bias_.data(), n) = dynamics_.BiasEffort(q, qd);
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      mass_.data(), n, n) = dynamics_.MassMatrix(q);

  state_.time_s = input.time_s;
  state_.tick = input.tick;
  state_.num_joints = n;
  state_.position = measured.position.data();
  state_.velocity = measured.velocity.data();
  state_.effort = measured.effort.data();
  state_.setpoint_position = input.setpoint_position.data();
  state_.setpoint_velocity = input.setpoint_velocity.data();
  state_.setpoint_acceleration = input.setpoint_acceleration.data();
  state_.goal = input.goal.data();
  state_.gravity_effort = gravity_.data();
  state_.bias_effort = bias_.data();
  state_.mass_matrix = mass_.data();
}

void PluginEffortLaw::Reset(const ControlInput& input) {
  Prepare(input);
  Guarded("Reset", [this] { controller_->Reset(arm_, state_); });
}

void PluginEffortLaw::Update(const ControlInput& input, std::vector<double>& effort) {
  Prepare(input);
  effort.assign(static_cast<size_t>(dynamics_.num_joints()), 0.0);
  Guarded("Update", [this, &effort] { controller_->Update(state_, effort.data()); });
}

}  // namespace sirupp::control
