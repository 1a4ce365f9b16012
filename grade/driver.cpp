#include "grade/driver.hpp"

#include <sirupp/plan_command_t.hpp>

#include "core/channels.hpp"

namespace sirupp::grade {

PlanDriver::PlanDriver(core::Bus& bus) : bus_(bus) {
  bus_.Subscribe<sirupp::controller_status_t>(
      core::Channels{}.controller_status,
      [this](const sirupp::controller_status_t& message, const core::ReceiveInfo&) {
        status_ = message;
        have_status_ = true;
      });
}

void PlanDriver::RunPlan(const std::string& name, const std::string& text) {
  sirupp::plan_command_t command{};
  command.utime = 0;
  command.seq = 0;
  command.command = sirupp::plan_command_t::COMMAND_RUN;
  command.name = name;
  command.text = text;
  bus_.Publish(core::Channels{}.arm_plan, command);
  sent_ = true;
}

bool PlanDriver::PlanAccepted(const std::string& name) const {
  using S = sirupp::controller_status_t;
  return have_status_ && status_.plan_name == name &&
         (status_.move_id > 0 || status_.state == S::STATE_MOVING ||
          status_.state == S::STATE_WAITING);
}

std::string PlanDriver::Problem() const {
  if (!have_status_ || !sent_) return "";
  if (Faulted()) return status_.last_error.empty() ? "fault (no cause given)" : status_.last_error;
  return status_.last_error;
}

}  // namespace sirupp::grade
