#pragma once
// One robot: a process that loaded a model file checks it against the model the physics runs
// (ROBOT_MODEL, published by sirupp-sim). Same name, same file contents (FNV-1a hash) and same
// servo tick, or the process refuses to drive, naming both files.

#include <sirupp/robot_model_t.hpp>
#include <string>

#include "core/robot_model.hpp"

namespace sirupp::core {

// Empty when `sim` is the robot `ours` describes; otherwise one line naming both models and files,
// as `who` (e.g. "sirupp-control") sees it, and what to do about it.
std::string ModelMismatch(const RobotModel& ours, const sirupp::robot_model_t& sim,
                          const std::string& who);

// What a process keeps to check each ROBOT_MODEL it hears (the sim publishes it again now and
// then): the verdict for the last model seen. Check() validates the message (a malformed one
// throws MessageError naming `channel` and is refused, never taken for another robot) and returns
// true when the verdict changed: a new mismatch to report, or a match again after one.
class ModelWatch {
 public:
  ModelWatch(const RobotModel& ours, std::string who) : ours_(ours), who_(std::move(who)) {}
  bool Check(const sirupp::robot_model_t& sim, const std::string& channel);
  // Empty while the sim's model is ours (or none was heard yet); else ModelMismatch's line.
  const std::string& mismatch() const { return mismatch_; }
  bool heard() const { return !last_hash_.empty(); }

 private:
  const RobotModel& ours_;
  std::string who_;
  std::string last_hash_;
  std::string last_name_;
  std::string mismatch_;
};

}  // namespace sirupp::core
