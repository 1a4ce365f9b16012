#pragma once
// Every command the panel sends to the rig, in one place: joint and tool targets, plans,
// gains, the e-stop and the hardware bridge's verbs. Each checks what it can before sending
// (limits, the plan text, gain ranges, with the rules of the libraries the controller uses:
// control::ParsePlan, servo::ChipGainsFromMessage) and then publishes one message through the hub.
// The controller's answer (accepted, refused and why) reaches the page through CONTROLLER_STATUS
// in the live state, as it reaches `sirupp status`.
//
// This file is the seam for the client library (client/): when it lands these functions become
// calls into it, and nothing else in panel/ changes.

#include <atomic>
#include <optional>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "panel/panel_hub.hpp"

namespace sirupp::panel {

// The outcome of a command: ok, or the HTTP status and one line saying why not.
struct CommandResult {
  bool ok = true;
  int status = 200;
  std::string message;
  Json detail = Json::object();

  static CommandResult Fail(int status, std::string message, Json detail = Json::object()) {
    return CommandResult{false, status, std::move(message), std::move(detail)};
  }
};

class RigCommands {
 public:
  RigCommands(PanelHub& hub, std::string sender) : hub_(hub), sender_(std::move(sender)) {}

  // Joint targets in the model's display units (deg / mm); nullopt leaves the joint alone.
  // speed_scale in (0, 1].
  CommandResult MoveJoints(const std::vector<std::optional<double>>& targets, double speed_scale);
  // Tool target: metres and degrees (roll pitch yaw); config "nearest" or e.g. "right-up-noflip".
  CommandResult MovePose(const std::vector<double>& xyz_rpy, const std::string& config,
                         double speed_scale);
  // Parses `text` from the present goals (or home); the error names line and column.
  CommandResult CheckPlan(const std::string& name, const std::string& text);
  CommandResult RunPlan(const std::string& name, const std::string& text);
  // "pause", "resume", "abort", "manual", "automatic", "clear-fault".
  CommandResult PlanControl(const std::string& verb);
  // `joint` 0-based, or -1 for all; fields kp kd ki il ol el db (PIC-SERVO units).
  CommandResult SetGains(int joint, const std::vector<std::pair<std::string, double>>& values);
  CommandResult Estop(bool engaged, const std::string& who, const std::string& reason);
  // "connect", "calibrate", "arm", "disarm", "link", "unlink", "home", "clear-faults".
  CommandResult Hardware(const std::string& verb, const std::string& who);

 private:
  int64_t NowMicros() const;

  PanelHub& hub_;
  std::string sender_;
  std::atomic<int64_t> seq_{0};  // HTTP threads send concurrently
};

}  // namespace sirupp::panel
