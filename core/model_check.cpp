#include "core/model_check.hpp"

#include <cmath>

#include "core/errors.hpp"
#include "core/translate.hpp"

namespace sirupp::core {

std::string ModelMismatch(const RobotModel& ours, const sirupp::robot_model_t& sim,
                          const std::string& who) {
  std::string differs;
  if (sim.name != ours.name) {
    differs = "another robot";
  } else if (sim.source_hash != ours.source_hash) {
    differs = "another version of the model file";
  } else if (std::abs(sim.servo_tick_s - ours.servo_tick_s) > 1e-12) {
    differs = "another servo tick (" + FormatNumber(sim.servo_tick_s * 1e3) + " ms against " +
              FormatNumber(ours.servo_tick_s * 1e3) + " ms)";
  } else {
    return "";
  }
  return "one robot: sirupp-sim runs '" + sim.name + "' from " + sim.source_file + " (hash " +
         sim.source_hash + "), " + who + " loaded '" + ours.name + "' from " + ours.source_file +
         " (hash " + ours.source_hash + "): " + differs +
         "; refusing to drive it (give every process the same --model)";
}

bool ModelWatch::Check(const sirupp::robot_model_t& sim, const std::string& channel) {
  if (!last_hash_.empty() && sim.source_hash == last_hash_ && sim.name == last_name_) return false;
  RobotModelFromMessage(sim, channel);  // throws MessageError for a malformed model
  last_hash_ = sim.source_hash;
  last_name_ = sim.name;
  std::string verdict = ModelMismatch(ours_, sim, who_);
  if (verdict == mismatch_) return false;
  mismatch_ = std::move(verdict);
  return true;
}

}  // namespace sirupp::core
