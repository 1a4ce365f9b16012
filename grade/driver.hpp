#pragma once
// The one place where the grader drives sirupp-control: through the client library (client/), on
// the task's own bus. It runs the task's plan (ARM_PLAN), takes sirupp-control's reply to that
// request (accepted, or refused with the controller's reason; none within the limit) and reads
// the controller's state from the client's status snapshot (a fault and its cause).
//
// The client handles the bus while it waits for the reply, so the runner's own handlers (the
// lockstep answers, the recording) keep running meanwhile.

#include <string>

#include "client/client.hpp"
#include "core/bus.hpp"

namespace sirupp::grade {

class PlanDriver {
 public:
  // `answer_timeout_s`: how long RunPlan waits for the controller's reply.
  PlanDriver(core::Bus& bus, double answer_timeout_s);

  // Sends `text` to run as plan `name` and waits for the reply. Returns "" when the controller
  // took it, else why not: its refusal, or that it did not answer.
  std::string RunPlan(const std::string& name, const std::string& text);
  // The plan was taken (RunPlan's reply accepted it).
  bool PlanAccepted() const { return accepted_; }
  // The controller's status shows a fault: its cause; "" while there is none.
  std::string Fault() const;

 private:
  client::Client client_;
  bool accepted_ = false;
};

}  // namespace sirupp::grade
