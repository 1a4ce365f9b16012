#pragma once
// sirupp-control's side of loading another robot model into the running rig (docs/panel.md,
// "Applying an edited model"). The sim owns the model; the controller is told first, on ARM_PLAN
// COMMAND_LOAD_MODEL with the model's text, then the sim loads the same text (SIM_COMMAND
// LOAD_MODEL) and publishes it on ROBOT_MODEL. ModelSwitch holds the model the controller agreed
// to take: while one waits, targets and plans are refused, so nothing starts between the two
// steps; the sim's ROBOT_MODEL with the same text's hash hands it over; an empty text (the sim
// refused) or 5 s of waiting drops it. A ROBOT_MODEL of another robot that nobody announced stays
// a mismatch (core/model_check.hpp).

#include <chrono>
#include <optional>
#include <sirupp/robot_model_t.hpp>
#include <string>

#include "core/robot_model.hpp"

namespace sirupp::control {

class ModelSwitch {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;
  static constexpr double kWaitS = 5.0;

  // COMMAND_LOAD_MODEL from `source` (the channel): parses `text` as the file `name` (a bad file
  // throws core::MessageError on `source` with name:line and the field) and checks it is the same
  // arm as `running` (joint count, servo tick). An empty text cancels what waits. The caller checks
  // first that the sequencer may change its model (Sequencer::RequireModelChangeAllowed).
  void Request(const std::string& source, const std::string& name, const std::string& text,
               const core::RobotModel& running, TimePoint now);
  // Throws core::MessageError on `source` while a model waits for the sim.
  void RequireNone(const std::string& source, TimePoint now);
  // The announced model when `sim` (from ROBOT_MODEL) is it; it no longer waits then.
  std::optional<core::RobotModel> Take(const sirupp::robot_model_t& sim, TimePoint now);
  bool waiting(TimePoint now);

 private:
  std::optional<core::RobotModel> waiting_;
  TimePoint since_;
};

}  // namespace sirupp::control
