// Example 6: drive a rig with the client library (client/client.hpp), as the `sirupp` CLI, a
// panel or a grader do: a refused target and why, a joint move followed to its end, a short plan,
// and the status snapshot. Each command's answer is the reply that names its request.
//
//   build/bin/example_06_client                     an in-process rig (sim + controller, memq://)
//   build/bin/example_06_client udpm://...?ttl=0    a running rig (sirupp launch, sirupp demo)
//
// The in-process rig is only there so the example runs anywhere; the lines that use `rig` are the
// same for a real one.
#include <iostream>
#include <memory>

#include "client/client.hpp"
#include "control/control_node.hpp"
#include "core/model_loader.hpp"
#include "sim/sim_node.hpp"

int main(int argc, char** argv) {
  using namespace sirupp;
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");

  // The rig: a running one on the URL given, or sirupp-sim's and sirupp-control's logic here.
  std::unique_ptr<core::Bus> bus;
  std::unique_ptr<sim::ArmWorld> world;
  std::unique_ptr<sim::SimNode> sim;
  std::unique_ptr<control::ControlNode> controller;
  std::unique_ptr<client::Client> owned;
  if (argc > 1) {
    client::Options options;
    options.lcm_url = argv[1];
    owned = std::make_unique<client::Client>(options);
  } else {
    bus = std::make_unique<core::Bus>("memq://");
    world = std::make_unique<sim::ArmWorld>(model, core::Environment{});
    sim = std::make_unique<sim::SimNode>(*bus, *world, core::Environment{}, sim::NodeOptions{});
    controller = std::make_unique<control::ControlNode>(*bus, model, control::ControlOptions{});
    owned = std::make_unique<client::Client>(*bus, client::Options{});
    owned->SetIdle([&] {  // the in-process processes run while the client waits
      sim->Service(0);
      controller->Service(0);
    });
  }
  client::Client& rig = *owned;
  if (!rig.WaitForController(5)) {
    std::cerr << "no sirupp-control heard\n";
    return 1;
  }

  // 1. A target beyond joint 2's limits: refused, with the controller's reason.
  const double rad = 3.14159265358979323846 / 180;
  client::Answer answer = rig.MoveJoints({{0, 200 * rad, 0, 0, 0, 0}});
  std::cout << "target j2=200 deg: "
            << (answer.result == client::Result::kRefused ? "refused: " + answer.error : "?")
            << "\n";

  // 2. Joint 1 to 45 degrees, followed to its end.
  answer = rig.MoveJoints({{45 * rad, 0, 0, 0, 0, 0}});
  if (!answer.accepted()) {
    std::cerr << "move refused: " << answer.error << "\n";
    return 1;
  }
  const client::Outcome move = rig.WaitForMove(answer.move_id, 120, answer.status_seq);
  std::cout << "move " << answer.move_id << ": " << move.detail << "\n";

  // 3. A two-step plan, each step printed as the controller starts it.
  answer = rig.RunPlan("example.plan", "move j1=0 j2=-20\nwait done\n");
  if (!answer.accepted()) {
    std::cerr << "plan refused: " << answer.error << "\n";
    return 1;
  }
  const client::Outcome plan = rig.WaitForPlan(
      "example.plan", 2, 120, [](int step) { std::cout << "  plan step " << step + 1 << "\n"; },
      answer.status_seq);
  std::cout << plan.detail << "\n";

  // 4. What the rig reports now.
  rig.WatchJoints(true);
  rig.Listen(0.2);
  const client::Snapshot& now = rig.snapshot();
  std::cout << "controller " << client::ControllerStateName(now.controller->state) << ", move "
            << now.controller->move_id << ", " << now.heartbeats.size()
            << " processes heard on HEARTBEAT\n";
  return move.ok() && plan.ok() ? 0 : 1;
}
