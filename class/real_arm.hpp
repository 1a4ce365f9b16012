#pragma once
// The one real arm in the class server (issue 33): the class file's `real_arm:` turned into a
// turns::TurnManager on the bridge's bus, serviced by a thread of its own, with what the student's
// and the teacher's pages show and the commands they send.
//
// The bridge (sirupp-hardware) runs on the bus `real_arm.lcm_url`, started by the teacher (or by
// `sirupp launch`); each student's rig is on its own leased port. The manager opens a rig's bus
// only for that student's handover and turn (turn_manager.hpp). A rig that runs as a job on a
// cluster node (class file cluster:) has its bus on the node: the manager gets a bus in this
// process instead, relayed to the node through the rig job's endpoint (class/bus_relay.hpp). Only
// the holder's hardware commands reach the arm (the server refuses the others with the reason,
// RealArm::MayCommand); anyone's "e-stop the real arm" does.
//
// Thread-safe: every method may be called from any request thread.

#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "class/bus_relay.hpp"
#include "class/class_config.hpp"
#include "core/bus.hpp"
#include "core/robot_model.hpp"
#include "turns/turn_manager.hpp"

namespace sirupp::classroom {

class RealArm {
 public:
  // The LCM address of `student`'s rig now; "" when it is not running.
  using RigUrlOf = std::function<std::string(const std::string& student)>;
  // The endpoint of `student`'s rig job (a rig on a cluster node) while it runs; none otherwise.
  using RigEndpointOf = std::function<std::optional<RigEndpoint>(const std::string& student)>;

  // Opens the bridge's bus (throws core::BusError naming the address when it cannot) and starts
  // the service thread. `log_path`: the turns' log (one JSON line per event and per turn). A rig
  // without an LCM address here but with an endpoint (`endpoint_of`) is relayed through it.
  RealArm(const ClassConfig& config, const std::string& log_path, RigUrlOf rig_url_of,
          std::function<void(const std::string&)> on_event = {}, RigEndpointOf endpoint_of = {});
  ~RealArm();
  RealArm(const RealArm&) = delete;
  RealArm& operator=(const RealArm&) = delete;

  // Ends the service thread (the bridge's command expiry then holds a linked arm).
  void Stop();

  // Who may have the real arm: "" or why not (a submission not passing the safety tasks, ...).
  void SetAdmit(std::function<std::string(const std::string&)> admit);

  // A student's view: the queue's state, their place and estimated wait, their turn's time left
  // and whether they may command the arm now (may_command: "" or why not).
  nlohmann::json StudentJson(const std::string& student) const;
  // The teacher's view: everything, the queue in order, the turns so far and the recent events.
  nlohmann::json TeacherJson() const;

  // A student's command: join, leave, done, estop. Throws turns::TurnError with the refusal,
  // std::invalid_argument for an unknown verb.
  void StudentCommand(const std::string& student, const std::string& verb);
  // The teacher's: end, pause, resume, estop, release, skip (needs `student`).
  void TeacherCommand(const std::string& verb, const std::string& student);

  // "" when `student` may command the real arm now; else why not.
  std::string MayCommand(const std::string& student) const;
  // In the queue or holding the arm: their rig is not idle.
  bool Involved(const std::string& student) const;
  // `student`'s rig stopped: out of the queue; a turn of theirs ends (the arm is handed back).
  void RigStopped(const std::string& student, const std::string& why);

 private:
  void Serve();
  void ServiceRemote();  // with mutex_ held
  void Event(const std::string& line);

  core::RobotModel model_;
  core::Bus arm_bus_;
  mutable std::mutex mutex_;  // the manager and everything below
  // Relays to rigs on nodes, from the manager's opening of such a rig's bus until the relay's last
  // exchange after the manager let go of it. Before manager_: destroyed after it.
  std::vector<std::unique_ptr<RemoteRigBus>> remote_;
  std::unique_ptr<turns::TurnManager> manager_;
  std::function<std::string(const std::string&)> admit_;
  std::deque<std::string> events_;  // the latest, newest last
  std::function<void(const std::string&)> on_event_;
  bool stopping_ = false;
  std::thread service_;
};

}  // namespace sirupp::classroom
