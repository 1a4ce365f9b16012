#pragma once
// The panel's side of the bus: one core::Bus served by one thread, the newest message of every
// channel the page shows, and the JSON the page is given (model, environment, live state, gains,
// processes). HTTP threads read snapshots and send commands through its client (client/, the typed
// API with replies matched to requests); one mutex guards the bus, the client and the data, held
// for a HandleAvailable() batch, a snapshot or a command, and let go while a command waits for its
// reply.
//
// The live state is decimated: the sim may publish at 1953 Hz, the hub keeps the newest message and
// bumps a generation counter; each page's event stream samples it at that page's rate.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/shape_t.hpp>
#include <sirupp/sim_status_t.hpp>
#include <string>
#include <thread>

#include "client/client.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/environment.hpp"
#include "core/heartbeat.hpp"
#include "core/kinematics.hpp"
#include "core/robot_model.hpp"
#include "core/tick_reader.hpp"

namespace sirupp::panel {

using Json = nlohmann::json;

struct HubOptions {
  double real_fresh_s = 0.5;  // the real arm is drawn while its newest state is younger than this
  // Drawn until ROBOT_MODEL arrives (--model FILE); the bus's model replaces it.
  std::optional<core::RobotModel> fallback_model;
  // How long a command waits for sirupp-control's (or sirupp-hardware's) reply.
  double answer_timeout_s = 2.0;
  // On udpm: the per-tick channels read in batches by the hub's own socket (core/tick_reader.hpp)
  // instead of LCM's one wake-up per datagram. false: everything through LCM.
  bool batch_ticks = true;
};

class PanelHub {
 public:
  // `bus` must outlive the hub; from Start() on only the hub's thread and Publish() use it.
  PanelHub(core::Bus& bus, HubOptions options);
  ~PanelHub();
  PanelHub(const PanelHub&) = delete;
  PanelHub& operator=(const PanelHub&) = delete;

  // Starts the bus thread (Run() without it: ServiceOnce() from the caller, for tests).
  void Start();
  void Stop();
  // Handles what is waiting on the bus, waiting up to timeout_ms for the first message.
  void ServiceOnce(int timeout_ms);

  // Runs fn(client) under the hub's lock and returns what it returns: every command the panel
  // sends goes through here. While the client waits for a reply it lets go of the lock (polling
  // the bus without it), so the hub thread keeps serving the pages and an e-stop from another
  // HTTP thread goes out at once; the client's state is only touched under the lock, so commands
  // of several threads may interleave, each matched to its own reply. Throws core::BusError.
  template <class Fn>
  auto WithClient(Fn&& fn) {
    const std::lock_guard<std::mutex> lock(mutex_);
    return fn(*client_);
  }

  const core::Channels& channels() const { return channels_; }
  std::string url() const { return bus_.url(); }

  // A copy of the model in use (bus or fallback); nullopt before any.
  std::optional<core::RobotModel> Model() const;
  // The sim's environment (ENVIRONMENT, decoded) or nullopt before any or when it does not decode.
  std::optional<core::Environment> Environment() const;
  // The present goals (ARM_SETPOINT) or nullopt when none heard.
  std::optional<std::vector<double>> PresentGoals() const;
  // The virtual arm's joints (SIM_ARM_STATE) or nullopt.
  std::optional<std::vector<double>> VirtualJoints() const;
  std::optional<sirupp::controller_status_t> ControllerStatus() const;
  std::optional<sirupp::servo_gains_t> VirtualGains() const;

  // "" when `model` may be loaded into the running rig; else why not, in one line: a
  // sirupp-hardware heard in the last 3 s (HEARTBEAT) while the real arm is linked
  // (HARDWARE_STATUS) keeps its own model file and faults on another model, which stops the real
  // arm. A model it reports as its own (heartbeat detail "model NAME hash HASH") is allowed.
  std::string BridgeRefusal(const core::RobotModel& model) const;

  // Page data. model_version goes up each time a different model arrives.
  Json ModelJson() const;
  Json EnvironmentJson() const;
  Json StateJson() const;      // the live frame: joints, link frames, status, tool pose
  Json GainsJson() const;      // virtual and real gains
  Json ProcessesJson() const;  // the heartbeat table
  int64_t model_version() const;

  // Waits until the live state changes past `generation` (or timeout); returns the newest
  // generation. Returns at once when Stop() was called.
  int64_t WaitForState(int64_t generation, std::chrono::milliseconds timeout);
  bool stopping() const;

  // Counters for the benchmark and tests.
  int64_t states_received() const;
  // True when the per-tick channels come through the batched reader (udpm and batch_ticks).
  bool batching_ticks() const;

 private:
  // ServiceOnce, with the per-tick channels (`ticks`) or LCM's messages alone: the tick reader
  // waits in its socket between two rounds (Run).
  void Service(int timeout_ms, bool ticks);
  void Subscribe();
  void StartTickReader();
  void Run();
  void SetModel(const core::RobotModel& model);
  void Touch();  // new live data: bump the generation and wake the streams

  HubOptions options_;
  core::Channels channels_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  core::Bus& bus_;
  core::Heartbeat heartbeat_;
  std::thread thread_;
  bool stop_ = false;
  int64_t generation_ = 0;
  int64_t states_received_ = 0;

  std::optional<core::RobotModel> model_;
  std::optional<core::KinematicChain> chain_;
  int64_t model_version_ = 0;
  std::string model_hash_;
  std::optional<sirupp::environment_t> environment_;
  std::optional<sirupp::arm_state_t> sim_state_;
  int64_t sim_state_recv_utime_ = 0;
  std::optional<sirupp::servo_setpoint_t> setpoint_;
  std::optional<sirupp::arm_state_t> real_state_;
  std::chrono::steady_clock::time_point real_state_at_;
  std::chrono::steady_clock::time_point hardware_at_;  // when hardware_ was heard
  std::optional<sirupp::controller_status_t> controller_;
  std::optional<sirupp::hardware_status_t> hardware_;
  std::optional<sirupp::sim_status_t> sim_status_;
  std::optional<sirupp::servo_gains_t> virtual_gains_;
  std::optional<sirupp::servo_gains_t> real_gains_;
  std::optional<sirupp::estop_t> estop_;
  std::map<std::string, std::pair<sirupp::heartbeat_t, int64_t>> heartbeats_;  // key process@host
  // Last: subscribes on bus_ after the hub's own handlers; its idle function lets go of mutex_.
  std::unique_ptr<client::Client> client_;
  // The per-tick channels on udpm (set up after every subscription, so LCM's socket exists).
  std::unique_ptr<core::TickFeed> ticks_;
};

// Shared with the API: degrees (revolute) or millimetres (prismatic) <-> rad / m.
double ToDisplay(const core::Joint& joint, double value);
double FromDisplay(const core::Joint& joint, double value);
const char* DisplayUnit(const core::Joint& joint);
const char* ControllerStateName(int8_t state);
const char* HardwareStateName(int8_t state);
// A shape as the page draws it: type, position, orientation (w x y z), size, colour.
Json ShapeJson(const sirupp::shape_t& shape);

}  // namespace sirupp::panel
