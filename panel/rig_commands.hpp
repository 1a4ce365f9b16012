#pragma once
// Every command the panel sends to the rig, in one place: joint and tool targets, plans,
// gains, the e-stop, the hardware bridge's verbs, environment loads and recording. Each turns the
// page's input (display units, joints left alone, one joint's gains) into the client library's
// request (client/client.hpp), checks what the page needs shown at a field before sending (limits
// in the page's units, the plan's line and column, the IK's configuration, gain ranges: with the
// libraries the controller itself uses, control::ParsePlan, control::SolvePoseGoal,
// servo::ChipGainsFromMessage), sends it through the hub's client and answers with the reply that
// names the request:
//   accepted -> 200 with "CHANNEL: accepted ..." (and move_id, status_seq),
//   refused  -> 409 with the replier's reason,
//   no reply -> 504 saying which process was not heard.

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
  explicit RigCommands(PanelHub& hub) : hub_(hub) {}

  // Joint targets in the model's display units (deg / mm); nullopt leaves the joint alone.
  // speed_scale in (0, 1].
  CommandResult MoveJoints(const std::vector<std::optional<double>>& targets, double speed_scale);
  // Tool target: metres and degrees (roll pitch yaw); config "nearest" or e.g. "right-up-noflip".
  CommandResult MovePose(const std::vector<double>& xyz_rpy, const std::string& config,
                         double speed_scale);
  // Parses `text` from the present goals (or home); the error names line and column. With objects
  // in the sim's environment, also sweeps its set-points through them as sirupp-control will
  // (control/plan_collision.hpp): a contact is 422 with the line and what touches.
  CommandResult CheckPlan(const std::string& name, const std::string& text);
  // A path around the sim's objects from the present goals (or home) to `goal`: joints in display
  // units (deg / mm), or (tool) x y z in m and roll pitch yaw in deg with an IK `config`. The
  // answer holds the plan text (run it with RunPlan), the waypoints (display units), the tool's
  // path in m (for the 3D view) and the planner's tree (for the C-space view). Nothing is sent.
  struct PlanGoal {
    std::vector<double> joints;  // or
    std::vector<double> tool;    // x y z roll pitch yaw
    std::string config = "nearest";
    std::string planner = "rrtconnect";
    uint32_t seed = 1;
  };
  CommandResult MakePlan(const PlanGoal& goal);
  // The C-space slice of joints a and b (0-based) at step_deg, the other joints at the present
  // goals (or home), against the sim's environment. Nothing is sent.
  CommandResult CSpace(int joint_a, int joint_b, double step_deg);
  CommandResult RunPlan(const std::string& name, const std::string& text);
  // "pause", "resume", "abort", "manual", "automatic", "clear-fault".
  CommandResult PlanControl(const std::string& verb);
  // `joint` 0-based, or -1 for all; fields kp kd ki il ol el db (PIC-SERVO units).
  CommandResult SetGains(int joint, const std::vector<std::pair<std::string, double>>& values);
  CommandResult Estop(bool engaged, const std::string& who, const std::string& reason);
  // "connect", "calibrate", "arm", "disarm", "link", "unlink", "home", "clear-faults".
  CommandResult Hardware(const std::string& verb);
  // An environment file's text into the running sim (SIM_COMMAND): checked here first with the
  // sim's parser (422 with the line), then the sim's reply.
  CommandResult LoadEnvironment(const std::string& name, const std::string& text);
  // Another robot model into the running sim and controller (client::Client::LoadModel); a bad
  // file is refused here with its line before anything is sent.
  CommandResult LoadModel(const std::string& name, const std::string& text);
  // Recording through sirupp-logger (LOGGER_COMMAND): start run `name` ("" = the logger's
  // default name, checked here with the logger's rule), stop the present one.
  CommandResult StartRecording(const std::string& name);
  CommandResult StopRecording();

 private:
  PanelHub& hub_;
};

// The HTTP answer for a reply (see above); `what` says what was sent, for the message.
CommandResult FromAnswer(const client::Answer& answer, const std::string& what,
                         Json detail = Json::object());

}  // namespace sirupp::panel
