#include "control/model_switch.hpp"

#include "core/errors.hpp"
#include "core/model_loader.hpp"

namespace sirupp::control {

void ModelSwitch::Request(const std::string& source, const std::string& name,
                          const std::string& text, const core::RobotModel& running, TimePoint now) {
  if (text.empty()) {
    waiting_.reset();
    return;
  }
  core::RobotModel model;
  try {
    model = core::ParseRobotModel(text, name.empty() ? "(model text)" : name);
  } catch (const core::ConfigError& error) {
    throw core::MessageError(source, "text", error.what());
  }
  if (model.num_joints() != running.num_joints()) {
    throw core::MessageError(source, "text",
                             name + ": the model has " + std::to_string(model.num_joints()) +
                                 " joints; the running arm has " +
                                 std::to_string(running.num_joints()));
  }
  if (model.servo_tick_s != running.servo_tick_s) {
    throw core::MessageError(source, "text",
                             name + ": servo tick " + core::FormatNumber(model.servo_tick_s) +
                                 " s; the running arm's is " +
                                 core::FormatNumber(running.servo_tick_s) + " s");
  }
  waiting_ = std::move(model);
  since_ = now;
}

bool ModelSwitch::waiting(TimePoint now) {
  if (waiting_ && std::chrono::duration<double>(now - since_).count() > kWaitS) waiting_.reset();
  return waiting_.has_value();
}

void ModelSwitch::RequireNone(const std::string& source, TimePoint now) {
  if (!waiting(now)) return;
  throw core::MessageError(source, "command",
                           "refused while the model '" + waiting_->name + "' from " +
                               waiting_->source_file + " is being loaded into the sim");
}

std::optional<core::RobotModel> ModelSwitch::Take(const sirupp::robot_model_t& sim, TimePoint now) {
  if (!waiting(now) || sim.source_hash != waiting_->source_hash) return std::nullopt;
  std::optional<core::RobotModel> taken = std::move(waiting_);
  waiting_.reset();
  return taken;
}

}  // namespace sirupp::control
