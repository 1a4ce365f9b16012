#include "panel/panel_hub.hpp"

#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sirupp/robot_model_t.hpp>
#include <sstream>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/translate.hpp"
#include "core/units.hpp"

namespace sirupp::panel {
namespace {

using Clock = std::chrono::steady_clock;
// Through LCM (memq://, or --lcm-ticks) the hub thread pauses this long between two rounds of
// handling; LCM's queue of one message per channel keeps each per-tick channel's newest meanwhile.
constexpr std::chrono::milliseconds kBatchPeriod{5};
// With the tick reader (udpm), LCM's own messages (statuses, replies, heartbeats: a few dozen a
// second) are handled as they come, and the per-tick channels (1953 Hz each) wait in the reader's
// socket and are taken this often: each channel's newest, fresher than a 60 Hz page needs. The hub
// thread then wakes about 80 times a second rather than 400 (a class server has one per rig).
constexpr std::chrono::milliseconds kTickPeriod{15};
constexpr int kNewestOnly = 1;

Json Vec(const double* values, size_t n) {
  Json out = Json::array();
  for (size_t i = 0; i < n; ++i) out.push_back(values[i]);
  return out;
}

// Frames 0..n of the arm at q as [x y z qw qx qy qz] each, plus the tool pose.
Json FramesJson(const core::KinematicChain& chain, const std::vector<double>& q) {
  const core::ForwardResult fk = chain.Forward(core::ToJointVector(q));
  Json frames = Json::array();
  const auto pose = [](const Eigen::Isometry3d& t) {
    const Eigen::Quaterniond r(t.linear());
    return Json::array({t.translation().x(), t.translation().y(), t.translation().z(), r.w(), r.x(),
                        r.y(), r.z()});
  };
  for (const Eigen::Isometry3d& frame : fk.frames) frames.push_back(pose(frame));
  const Eigen::Vector3d rpy = core::RollPitchYaw(fk.tool.linear());
  return Json{{"frames", frames},
              {"tool",
               {fk.tool.translation().x(), fk.tool.translation().y(), fk.tool.translation().z(),
                rpy.x() * 180 / kPi, rpy.y() * 180 / kPi, rpy.z() * 180 / kPi}}};
}

Json GainsOf(const sirupp::servo_gains_t& g) {
  Json joints = Json::array();
  const auto n = static_cast<size_t>(std::max(0, g.num_joints));
  for (size_t j = 0; j < n; ++j) {
    joints.push_back(Json{{"kp", g.kp[j]},
                          {"kd", g.kd[j]},
                          {"ki", g.ki[j]},
                          {"il", g.integration_limit[j]},
                          {"ol", g.output_limit[j]},
                          {"cl", g.current_limit[j]},
                          {"el", g.error_limit[j]},
                          {"sr", g.servo_rate_divisor[j]},
                          {"db", g.deadband[j]}});
  }
  return joints;
}

}  // namespace

Json ShapeJson(const sirupp::shape_t& shape) {
  static const char* const kTypes[] = {"box", "cylinder", "sphere", "capsule"};
  const int type = shape.type >= 0 && shape.type <= 3 ? shape.type : 0;
  return Json{{"type", kTypes[type]},
              {"position", Vec(shape.position, 3)},
              {"orientation", Vec(shape.orientation, 4)},
              {"size", Vec(shape.size, 3)},
              {"color", {shape.color[0], shape.color[1], shape.color[2], shape.color[3]}}};
}

double ToDisplay(const core::Joint& joint, double value) {
  return joint.type == core::JointType::kRevolute ? value * 180 / kPi : value * 1000;
}
double FromDisplay(const core::Joint& joint, double value) {
  return joint.type == core::JointType::kRevolute ? value * kPi / 180 : value / 1000;
}
const char* DisplayUnit(const core::Joint& joint) {
  return joint.type == core::JointType::kRevolute ? "deg" : "mm";
}

const char* ControllerStateName(int8_t state) {
  static const char* const kNames[] = {"idle", "moving", "waiting", "paused", "fault", "off"};
  return state >= 0 && state <= 5 ? kNames[state] : "unknown";
}
const char* HardwareStateName(int8_t state) {
  static const char* const kNames[] = {"disconnected", "connected", "calibrating", "armed",
                                       "linked",       "fault",     "estopped"};
  return state >= 0 && state <= 6 ? kNames[state] : "unknown";
}

PanelHub::PanelHub(core::Bus& bus, HubOptions options)
    : options_(std::move(options)),
      channels_(core::Channels{}),
      bus_(bus),
      heartbeat_(bus_, "sirupp-panel", channels_.heartbeat) {
  if (options_.fallback_model) SetModel(*options_.fallback_model);
  Subscribe();
  client::Options client_options;
  client_options.sender = "sirupp-panel";
  client_options.answer_timeout_s = options_.answer_timeout_s;
  client_ = std::make_unique<client::Client>(bus_, client_options);
  // Called by the client between rounds of handling while a command waits for its reply, with
  // mutex_ held (WithClient): waits for the bus without the lock, as ServiceOnce does.
  client_->SetIdle([this] {
    pollfd fd{};
    fd.fd = bus_.Fileno();
    fd.events = POLLIN;
    mutex_.unlock();
    ::poll(&fd, 1, 5);
    mutex_.lock();
  });
  heartbeat_.Publish(core::ProcessState::kStarting, "");
  if (options_.batch_ticks) StartTickReader();
}

void PanelHub::StartTickReader() {
  // The per-tick channels the panel draws; LCM's socket drops them and, as no subscription here
  // wants them, the other per-tick channels too (core::Bus).
  ticks_ = core::TickFeed::Open(
      bus_,
      {bus_.FullName(channels_.sim_arm_state), bus_.FullName(channels_.arm_setpoint),
       bus_.FullName(channels_.real_arm_state), bus_.FullName(channels_.sim_arm_ticks)},
      "sirupp-panel");
}

bool PanelHub::batching_ticks() const { return ticks_ != nullptr; }

PanelHub::~PanelHub() { Stop(); }

void PanelHub::Start() {
  thread_ = std::thread([this] { Run(); });
}

void PanelHub::Stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool PanelHub::stopping() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return stop_;
}

void PanelHub::Run() {
  // Batches: the per-tick channels come at 1953 Hz each; waking and decoding for every message
  // cost most of the panel's CPU (LCM's receive thread wakes per datagram: core/tick_reader.hpp).
  // The page samples at most 60 Hz.
  auto next_ticks = Clock::now();
  while (!stopping()) {
    if (!ticks_) {
      ServiceOnce(50);
      std::this_thread::sleep_for(kBatchPeriod);
      continue;
    }
    const auto now = Clock::now();
    const bool due = now >= next_ticks;
    if (due) next_ticks = std::max(next_ticks + kTickPeriod, now);
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(next_ticks - now);
    Service(due ? 0 : static_cast<int>(std::clamp<int64_t>(wait.count(), 1, 50)), due);
  }
  const std::lock_guard<std::mutex> lock(mutex_);
  heartbeat_.Publish(core::ProcessState::kStopping, "");
}

void PanelHub::ServiceOnce(int timeout_ms) { Service(timeout_ms, true); }

void PanelHub::Service(int timeout_ms, bool ticks) {
  pollfd fds[2]{};
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    fds[0].fd = bus_.Fileno();
  }
  fds[0].events = POLLIN;
  fds[1].fd = ticks && ticks_ ? ticks_->reader().fd() : -1;  // poll() skips a negative fd
  fds[1].events = POLLIN;
  ::poll(fds, 2, timeout_ms);  // waits without the lock, so HTTP threads can publish meanwhile
  const std::lock_guard<std::mutex> lock(mutex_);
  bus_.HandleAvailable(2000);
  // Only each channel's newest message of the round is decoded and handled.
  if (ticks && ticks_) ticks_->DeliverNewest();
  heartbeat_.PublishIfDue(core::ProcessState::kRunning, model_ ? "model " + model_->name : "");
}

void PanelHub::Touch() {
  ++generation_;
  changed_.notify_all();
}

void PanelHub::SetModel(const core::RobotModel& model) {
  model_ = model;
  chain_.emplace(model);
  model_hash_ = model.source_hash;
  ++model_version_;
}

void PanelHub::Subscribe() {
  // Handlers run inside HandleAvailable(), under mutex_.
  bus_.Subscribe<sirupp::robot_model_t>(
      channels_.robot_model, [this](const sirupp::robot_model_t& msg, const core::ReceiveInfo&) {
        if (model_ && msg.source_hash == model_hash_ && msg.name == model_->name) {
          return;  // the 1 Hz repeat of the model in use
        }
        SetModel(core::RobotModelFromMessage(msg, bus_.FullName(channels_.robot_model)));
        Touch();
      });
  bus_.Subscribe<sirupp::environment_t>(
      channels_.environment, [this](const sirupp::environment_t& msg, const core::ReceiveInfo&) {
        core::EnvironmentFromMessage(msg, bus_.FullName(channels_.environment));  // validates
        environment_ = msg;
      });
  bus_.Subscribe<sirupp::arm_state_t>(
      channels_.sim_arm_state,
      [this](const sirupp::arm_state_t& msg, const core::ReceiveInfo& info) {
        if (!model_ || msg.num_joints != model_->num_joints()) {
          throw core::MessageError(
              info.channel, "num_joints",
              std::to_string(msg.num_joints) + " does not match the model in use");
        }
        sim_state_ = msg;
        sim_state_recv_utime_ = info.recv_utime;
        ++states_received_;
        Touch();
      },
      kNewestOnly);
  bus_.Subscribe<sirupp::servo_setpoint_t>(
      channels_.arm_setpoint,
      [this](const sirupp::servo_setpoint_t& msg, const core::ReceiveInfo&) { setpoint_ = msg; },
      kNewestOnly);
  bus_.Subscribe<sirupp::arm_state_t>(
      channels_.real_arm_state,
      [this](const sirupp::arm_state_t& msg, const core::ReceiveInfo&) {
        real_state_ = msg;
        real_state_at_ = Clock::now();
        Touch();
      },
      kNewestOnly);
  bus_.Subscribe<sirupp::controller_status_t>(
      channels_.controller_status,
      [this](const sirupp::controller_status_t& msg, const core::ReceiveInfo&) {
        controller_ = msg;
        Touch();
      });
  bus_.Subscribe<sirupp::hardware_status_t>(
      channels_.hardware_status,
      [this](const sirupp::hardware_status_t& msg, const core::ReceiveInfo&) {
        hardware_ = msg;
        hardware_at_ = Clock::now();
      });
  bus_.Subscribe<sirupp::sim_status_t>(
      channels_.sim_status,
      [this](const sirupp::sim_status_t& msg, const core::ReceiveInfo&) { sim_status_ = msg; });
  bus_.Subscribe<sirupp::servo_gains_t>(
      channels_.controller_gains,
      [this](const sirupp::servo_gains_t& msg, const core::ReceiveInfo&) { virtual_gains_ = msg; });
  bus_.Subscribe<sirupp::servo_gains_t>(
      channels_.real_arm_gains,
      [this](const sirupp::servo_gains_t& msg, const core::ReceiveInfo&) { real_gains_ = msg; });
  bus_.Subscribe<sirupp::estop_t>(
      channels_.estop,
      [this](const sirupp::estop_t& msg, const core::ReceiveInfo&) { estop_ = msg; });
  bus_.Subscribe<sirupp::heartbeat_t>(
      channels_.heartbeat, [this](const sirupp::heartbeat_t& msg, const core::ReceiveInfo& info) {
        heartbeats_[msg.process + "@" + msg.host + ":" + std::to_string(msg.pid)] = {
            msg, info.recv_utime};
      });
}

std::optional<core::RobotModel> PanelHub::Model() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return model_;
}

std::optional<core::Environment> PanelHub::Environment() const {
  std::optional<sirupp::environment_t> message;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    message = environment_;
  }
  if (!message) return std::nullopt;
  try {
    return core::EnvironmentFromMessage(*message, channels_.environment.name());
  } catch (const std::exception&) {
    return std::nullopt;  // the page shows the sim's own error (EnvironmentJson)
  }
}

std::optional<std::vector<double>> PanelHub::PresentGoals() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!setpoint_ || !model_ || setpoint_->num_joints != model_->num_joints()) return std::nullopt;
  return setpoint_->goal;
}

std::optional<std::vector<double>> PanelHub::VirtualJoints() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!sim_state_) return std::nullopt;
  return sim_state_->position;
}

std::optional<sirupp::controller_status_t> PanelHub::ControllerStatus() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return controller_;
}

std::optional<sirupp::servo_gains_t> PanelHub::VirtualGains() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return virtual_gains_;
}

int64_t PanelHub::model_version() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return model_version_;
}

int64_t PanelHub::states_received() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return states_received_;
}

int64_t PanelHub::WaitForState(int64_t generation, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return stop_ || generation_ != generation; });
  return generation_;
}

std::string PanelHub::BridgeRefusal(const core::RobotModel& model) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!hardware_ || hardware_->state != sirupp::hardware_status_t::STATE_LINKED) return "";
  const int64_t now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count();
  for (const auto& [key, entry] : heartbeats_) {
    const sirupp::heartbeat_t& beat = entry.first;
    if (beat.process != "sirupp-hardware" || now_us - entry.second > 3000000) continue;
    std::istringstream words(beat.detail);
    std::string model_word;
    std::string name;
    std::string hash_word;
    std::string hash;
    words >> model_word >> name >> hash_word >> hash;
    if (!hash.empty() && hash.back() == ';') hash.pop_back();  // "...; the bridge's last error"
    const bool reported = model_word == "model" && hash_word == "hash" && !hash.empty();
    if (reported && name == model.name && hash == model.source_hash) continue;
    return "sirupp-hardware on " + beat.host + " (pid " + std::to_string(beat.pid) +
           ") has the real arm linked and keeps its own model file (" +
           (reported ? name + ", hash " + hash : std::string("not reported")) + "); loading " +
           model.source_file + " (" + model.name + ", hash " + model.source_hash +
           ") would make it fault and stop the arm: unlink the real arm first";
  }
  return "";
}

Json PanelHub::ModelJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!model_) return Json{{"loaded", false}, {"version", model_version_}};
  const core::RobotModel& m = *model_;
  const sirupp::robot_model_t msg = core::ToMessage(m, 0, 0);
  Json joints = Json::array();
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const core::Joint& joint = m.joints[j];
    const double length = joint.type == core::JointType::kRevolute ? 1 : 1000;
    joints.push_back(
        Json{{"name", joint.name},
             {"type", joint.type == core::JointType::kRevolute ? "revolute" : "prismatic"},
             {"unit", DisplayUnit(joint)},
             {"min", ToDisplay(joint, joint.position_min)},
             {"max", ToDisplay(joint, joint.position_max)},
             {"home", ToDisplay(joint, joint.home)},
             {"velocity_max", ToDisplay(joint, joint.velocity_max)},
             {"default_velocity", ToDisplay(joint, joint.servo.default_velocity)},
             {"default_acceleration", ToDisplay(joint, joint.servo.default_acceleration)},
             {"effort_max", joint.effort_max},
             {"dh",
              {{"a_mm", joint.dh.a_m * 1000},
               {"alpha_deg", joint.dh.alpha_rad * 180 / kPi},
               {"d_mm", joint.dh.d_m * 1000},
               {"theta_deg", joint.dh.theta_rad * 180 / kPi}}},
             {"friction",
              {{"static", joint.friction.static_effort},
               {"coulomb_positive", joint.friction.coulomb_positive},
               {"coulomb_negative", joint.friction.coulomb_negative},
               {"viscous", joint.friction.viscous / length}}},
             {"gear_ratio", joint.servo.gear_ratio},
             {"encoder_counts_per_rev", joint.servo.encoder_counts_per_rev}});
  }
  Json links = Json::array();
  for (int32_t l = 0; l < msg.num_links; ++l) {
    const sirupp::link_model_t& link = msg.links[static_cast<size_t>(l)];
    Json shapes = Json::array();
    for (const sirupp::shape_t& shape : link.shapes) shapes.push_back(ShapeJson(shape));
    links.push_back(Json{{"name", link.name},
                         {"mass", link.mass},
                         {"com", Vec(link.com, 3)},
                         {"inertia", Vec(link.inertia, 6)},
                         {"shapes", shapes}});
  }
  Json poses = Json::object();
  for (const core::NamedPose& pose : m.named_poses) {
    Json values = Json::array();
    for (size_t j = 0; j < pose.position.size() && j < m.joints.size(); ++j) {
      values.push_back(ToDisplay(m.joints[j], pose.position[j]));
    }
    poses[pose.name] = values;
  }
  return Json{{"loaded", true},
              {"version", model_version_},
              {"name", m.name},
              {"description", m.description},
              {"source_file", m.source_file},
              {"source_hash", m.source_hash},
              {"dh_convention", core::DhConventionName(m.dh_convention)},
              {"base_position", Vec(msg.base_position, 3)},
              {"base_orientation", Vec(msg.base_orientation, 4)},
              {"gravity", Vec(msg.gravity, 3)},
              {"servo_tick_s", m.servo_tick_s},
              {"joints", joints},
              {"links", links},
              {"named_poses", poses}};
}

Json PanelHub::EnvironmentJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!environment_) return Json{{"loaded", false}, {"objects", Json::array()}};
  Json objects = Json::array();
  for (const sirupp::environment_object_t& object : environment_->objects) {
    objects.push_back(Json{{"name", object.name},
                           {"shape", ShapeJson(object.shape)},
                           {"static", object.is_static != 0},
                           {"mass", object.mass},
                           {"friction", object.friction},
                           {"restitution", object.restitution}});
  }
  return Json{{"loaded", true},
              {"name", environment_->name},
              {"source_file", environment_->source_file},
              {"objects", objects}};
}

Json PanelHub::StateJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  Json out{{"generation", generation_}, {"model_version", model_version_}};
  const auto display = [this](const std::vector<double>& q) {
    Json values = Json::array();
    for (size_t j = 0; j < q.size() && j < model_->joints.size(); ++j) {
      values.push_back(ToDisplay(model_->joints[j], q[j]));
    }
    return values;
  };
  if (model_ && sim_state_ && sim_state_->num_joints == model_->num_joints()) {
    out["virtual"] = FramesJson(*chain_, sim_state_->position);
    out["virtual"]["q"] = display(sim_state_->position);
    out["sim_utime"] = sim_state_->utime;
    out["tick"] = sim_state_->tick;
    out["recv_ms"] = static_cast<double>(sim_state_recv_utime_) / 1000.0;
  }
  if (model_ && setpoint_ && setpoint_->num_joints == model_->num_joints()) {
    out["setpoint"] = FramesJson(*chain_, setpoint_->position);
    out["setpoint"]["q"] = display(setpoint_->position);
    out["setpoint"]["goal"] = display(setpoint_->goal);
    out["move_id"] = setpoint_->move_id;
  }
  const double real_age = std::chrono::duration<double>(Clock::now() - real_state_at_).count();
  if (model_ && real_state_ && real_state_->num_joints == model_->num_joints() &&
      real_age < options_.real_fresh_s) {
    out["real"] = FramesJson(*chain_, real_state_->position);
    out["real"]["q"] = display(real_state_->position);
  }
  if (controller_) {
    out["controller"] = Json{{"mode", controller_->mode == 1 ? "automatic" : "manual"},
                             {"state", ControllerStateName(controller_->state)},
                             {"move_id", controller_->move_id},
                             {"plan_name", controller_->plan_name},
                             {"plan_step", controller_->plan_step},
                             {"plan_steps", controller_->plan_steps},
                             {"plan_line", controller_->plan_line},
                             {"last_error", controller_->last_error}};
  }
  if (hardware_) {
    Json modules = Json::array();
    for (size_t j = 0; j < hardware_->module_status.size(); ++j) {
      modules.push_back(Json{{"status", hardware_->module_status[j]},
                             {"aux", hardware_->module_aux_status[j]},
                             {"counts", hardware_->position_counts[j]},
                             {"error_counts", hardware_->position_error_counts[j]}});
    }
    out["hardware"] =
        Json{{"state", HardwareStateName(hardware_->state)},
             {"calibrated", hardware_->calibrated != 0},
             {"port", hardware_->port},
             {"baud", hardware_->baud},
             {"checksum_errors", hardware_->checksum_errors},
             {"timeouts", hardware_->timeouts},
             {"last_error", hardware_->last_error},
             // HARDWARE_STATUS comes at 10 Hz: older than a second, the bridge
             // is gone and this is its last word (the page says "lost").
             {"age_s", std::chrono::duration<double>(Clock::now() - hardware_at_).count()},
             {"modules", modules}};
  }
  if (sim_status_) {
    out["sim"] = Json{{"realtime_factor", sim_status_->realtime_factor},
                      {"sim_time_s", sim_status_->sim_time_s},
                      {"estop", sim_status_->estop != 0},
                      {"estop_reason", sim_status_->estop_reason}};
  }
  if (estop_) {
    out["estop"] = Json{
        {"engaged", estop_->engaged != 0}, {"sender", estop_->sender}, {"reason", estop_->reason}};
  }
  return out;
}

Json PanelHub::GainsJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  Json out = Json::object();
  out["virtual"] = virtual_gains_ ? GainsOf(*virtual_gains_) : Json(nullptr);
  out["real"] = real_gains_ ? GainsOf(*real_gains_) : Json(nullptr);
  return out;
}

Json PanelHub::ProcessesJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  static const char* const kStates[] = {"starting", "running", "degraded", "fault", "stopping"};
  const double now_ms = static_cast<double>(std::chrono::duration_cast<std::chrono::microseconds>(
                                                std::chrono::system_clock::now().time_since_epoch())
                                                .count()) /
                        1000.0;
  Json rows = Json::array();
  for (const auto& [key, entry] : heartbeats_) {
    const sirupp::heartbeat_t& hb = entry.first;
    int64_t rejected = 0;
    int64_t late = 0;
    int64_t decode_errors = 0;
    Json rates = Json::object();
    for (const sirupp::channel_stats_t& channel : hb.channels) {
      rejected += channel.rejected;
      late += channel.late;
      decode_errors += channel.decode_errors;
      if (channel.rate_hz > 0) {
        rates[(channel.publishing ? "out " : "in ") + channel.channel] = channel.rate_hz;
      }
    }
    const double age_s = (now_ms - static_cast<double>(entry.second) / 1000.0) / 1000.0;
    rows.push_back(Json{{"process", hb.process},
                        {"host", hb.host},
                        {"pid", hb.pid},
                        {"state", hb.state >= 0 && hb.state <= 4 ? kStates[hb.state] : "unknown"},
                        {"detail", hb.detail},
                        {"uptime_s", hb.uptime_s},
                        {"rejected", rejected},
                        {"late", late},
                        {"decode_errors", decode_errors},
                        {"rates", rates},
                        {"silent_s", age_s},
                        {"alive", age_s < 3.0}});
  }
  Json out{{"processes", rows}};
  if (sim_status_) out["realtime_factor"] = sim_status_->realtime_factor;
  return out;
}

}  // namespace sirupp::panel
