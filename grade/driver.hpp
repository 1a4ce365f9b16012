#pragma once
// The one place where the grader drives sirupp-control over the bus: it runs a plan (ARM_PLAN)
// and follows CONTROLLER_STATUS (accepted, refused, fault). Kept this narrow so it can be swapped
// for the typed client library (client/) when that lands.

#include <cstdint>
#include <sirupp/controller_status_t.hpp>
#include <string>

#include "core/bus.hpp"

namespace sirupp::grade {

class PlanDriver {
 public:
  explicit PlanDriver(core::Bus& bus);

  // Sends `text` to run as plan `name`.
  void RunPlan(const std::string& name, const std::string& text);
  // The plan named `name` was taken (the status names it with a move started, or it is moving
  // or waiting).
  bool PlanAccepted(const std::string& name) const;
  // A refusal or fault text from the controller, or "" while there is none.
  std::string Problem() const;
  bool Faulted() const {
    return have_status_ && status_.state == sirupp::controller_status_t::STATE_FAULT;
  }

 private:
  core::Bus& bus_;
  bool have_status_ = false;
  bool sent_ = false;
  sirupp::controller_status_t status_{};
};

}  // namespace sirupp::grade
