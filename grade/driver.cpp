#include "grade/driver.hpp"

#include <sirupp/controller_status_t.hpp>

namespace sirupp::grade {
namespace {

client::Options DriverOptions(double answer_timeout_s) {
  client::Options options;
  options.sender = "sirupp-grade";
  options.answer_timeout_s = answer_timeout_s;
  return options;
}

}  // namespace

PlanDriver::PlanDriver(core::Bus& bus, double answer_timeout_s)
    : client_(bus, DriverOptions(answer_timeout_s)) {}

std::string PlanDriver::RunPlan(const std::string& name, const std::string& text) {
  const client::Answer answer = client_.RunPlan(name, text);
  accepted_ = answer.accepted();
  if (accepted_) return "";
  if (answer.result == client::Result::kRefused) {
    return "the controller refused the plan: " + answer.error;
  }
  return "the plan was not taken: " + answer.error;
}

std::string PlanDriver::Fault() const {
  const auto& status = client_.snapshot().controller;
  if (!status || status->state != sirupp::controller_status_t::STATE_FAULT) return "";
  return status->last_error.empty() ? "fault (no cause given)" : status->last_error;
}

}  // namespace sirupp::grade
