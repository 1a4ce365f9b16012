#include "class/real_arm.hpp"

#include <cctype>
#include <chrono>
#include <stdexcept>

#include "core/model_loader.hpp"

namespace sirupp::classroom {
namespace {

using Json = nlohmann::json;
constexpr size_t kEventsKept = 30;
constexpr auto kServicePeriod = std::chrono::milliseconds(2);

// A character of a student's name (class_config.cpp: letters, digits, '-', '_', '.').
bool NameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_' || c == '.';
}

// Whether an event's line names `student`: the whole name, not part of a longer one ("bob" is not
// named in "bobby joined the queue"; it is in "bob's turn ends" and "... by bob.").
bool NamesStudent(const std::string& line, const std::string& student) {
  if (student.empty()) return false;
  for (size_t at = line.find(student); at != std::string::npos; at = line.find(student, at + 1)) {
    const size_t end = at + student.size();
    const bool starts = at == 0 || !NameChar(line[at - 1]);
    const bool ends = end == line.size() || !NameChar(line[end]) ||
                      (line[end] == '.' && (end + 1 == line.size() || !NameChar(line[end + 1])));
    if (starts && ends) return true;
  }
  return false;
}

}  // namespace

RealArm::RealArm(const ClassConfig& config, const std::string& log_path, RigUrlOf rig_url_of,
                 std::function<void(const std::string&)> on_event, RigEndpointOf endpoint_of)
    : model_(core::LoadRobotModel(config.robot)),
      arm_bus_(config.real_arm.value().lcm_url, ""),
      on_event_(std::move(on_event)) {
  const RealArmConfig& arm = *config.real_arm;
  turns::TurnOptions options;
  options.turn_s = arm.turn_s;
  options.warn_before_s = arm.warn_before_s;
  options.home_tolerance_deg = arm.home_tolerance_deg;
  options.home_speed_fraction = arm.home_speed_fraction;
  options.log_path = log_path;
  options.sender = "sirupp class";
  // Called by the manager, so with mutex_ held.
  options.on_event = [this](const std::string& line) { Event(line); };
  options.admit = [this](const std::string& student) {
    return admit_ ? admit_(student) : std::string();
  };
  manager_ = std::make_unique<turns::TurnManager>(arm_bus_, model_, options);
  for (const std::string& student : config.students) {
    // Called by the manager, so with mutex_ held.
    manager_->AddRig(student, [this, rig_url_of, endpoint_of, student] {
      const std::string url = rig_url_of(student);
      if (!url.empty()) return std::make_shared<core::Bus>(url, "");
      const std::optional<RigEndpoint> endpoint = endpoint_of ? endpoint_of(student) : std::nullopt;
      if (!endpoint) throw turns::TurnError(student + "'s rig is not running");
      remote_.push_back(std::make_unique<RemoteRigBus>(student, *endpoint));
      Event(student + "'s rig runs on " + endpoint->host +
            ": its bus is relayed through its rig job's endpoint " + endpoint->Address());
      return remote_.back()->bus();
    });
  }
  service_ = std::thread([this] { Serve(); });
}

RealArm::~RealArm() { Stop(); }

void RealArm::Stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  if (service_.joinable()) service_.join();
}

void RealArm::Serve() {
  for (;;) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) return;
      try {
        for (const auto& remote : remote_) remote->Pump();  // the nodes' messages, then handled
        manager_->Service();
        ServiceRemote();
      } catch (const std::exception& e) {
        // A bad message or a rig's bus that failed: said, and serviced again next time.
        Event(std::string("real arm: ") + e.what());
      }
    }
    std::this_thread::sleep_for(kServicePeriod);
  }
}

void RealArm::ServiceRemote() {
  for (auto it = remote_.begin(); it != remote_.end();) {
    RemoteRigBus& remote = **it;
    const std::string news = remote.TakeNewError();
    if (!news.empty()) Event(news);
    if (remote.Released()) remote.Close();  // the manager let go: its last messages sent
    if (!remote.Finished()) {
      ++it;
      continue;
    }
    Event("relay to " + remote.student() + "'s rig closed: " + remote.RoundTrips());
    it = remote_.erase(it);
  }
}

void RealArm::Event(const std::string& line) {
  events_.push_back(line);
  while (events_.size() > kEventsKept) events_.pop_front();
  if (on_event_) on_event_(line);
}

void RealArm::SetAdmit(std::function<std::string(const std::string&)> admit) {
  const std::lock_guard<std::mutex> lock(mutex_);
  admit_ = std::move(admit);
}

Json RealArm::StudentJson(const std::string& student) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  const turns::TurnStatus s = manager_->status();
  Json you{{"holder", s.holder == student},
           {"in_turn", s.holder == student && s.phase == turns::Phase::kTurn},
           {"place", 0},
           {"estimated_wait_s", 0},
           {"may_command", manager_->MayCommand(student)}};
  for (size_t i = 0; i < s.queue.size(); ++i) {
    if (s.queue[i].student != student) continue;
    you["place"] = i + 1;
    you["estimated_wait_s"] = s.queue[i].estimated_wait_s;
  }
  if (s.holder == student) {
    you["turn_left_s"] = s.turn_left_s;
    you["step"] = s.step;
  }
  // The events about this student, newest last (warnings before the end, the handovers).
  Json mine = Json::array();
  for (const std::string& line : events_) {
    if (NamesStudent(line, student)) mine.push_back(line);
  }
  while (mine.size() > 5) mine.erase(mine.begin());
  return Json{{"enabled", true},
              {"phase", turns::PhaseName(s.phase)},
              {"holder", s.holder},
              {"paused", s.paused},
              {"stopped", s.stopped_reason},
              {"bridge", s.bridge},
              {"queue_length", s.queue.size()},
              {"turn_s", manager_->options().turn_s},
              {"warn_before_s", manager_->options().warn_before_s},
              {"you", you},
              {"events", mine}};
}

Json RealArm::TeacherJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  const turns::TurnStatus s = manager_->status();
  Json queue = Json::array();
  for (const turns::Waiting& w : s.queue) {
    queue.push_back(Json{{"student", w.student}, {"estimated_wait_s", w.estimated_wait_s}});
  }
  Json history = Json::array();
  for (const turns::TurnRecord& r : manager_->history()) {
    history.push_back(Json{{"student", r.student},
                           {"start_us", r.start_wall_us},
                           {"end_us", r.end_wall_us},
                           {"plans", r.plans},
                           {"ended", r.ended},
                           {"handover_in_s", r.handover_in_s},
                           {"handover_out_s", r.handover_out_s},
                           {"handover", r.handover_result}});
  }
  return Json{{"enabled", true},
              {"phase", turns::PhaseName(s.phase)},
              {"holder", s.holder},
              {"turn_left_s", s.turn_left_s},
              {"step", s.step},
              {"paused", s.paused},
              {"stopped", s.stopped_reason},
              {"bridge", s.bridge},
              {"turn_s", manager_->options().turn_s},
              {"queue", queue},
              {"history", history},
              {"events", Json(events_)}};
}

void RealArm::StudentCommand(const std::string& student, const std::string& verb) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (verb == "join") {
    manager_->Join(student);
  } else if (verb == "leave") {
    manager_->Leave(student);
  } else if (verb == "done") {
    manager_->Done(student);
  } else if (verb == "estop") {
    manager_->Estop(student, "e-stop of the real arm from " + student + "'s page");
  } else {
    throw std::invalid_argument("no such command '" + verb +
                                "'; allowed: join, leave, done, estop");
  }
}

void RealArm::TeacherCommand(const std::string& verb, const std::string& student) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (verb == "end") {
    manager_->EndTurn("the teacher");
  } else if (verb == "pause") {
    manager_->Pause();
  } else if (verb == "resume") {
    manager_->Resume();
  } else if (verb == "estop") {
    manager_->Estop("the teacher", "e-stop of the real arm from the teacher's page");
  } else if (verb == "release") {
    manager_->ReleaseEstop("the teacher");
  } else if (verb == "skip") {
    manager_->Skip(student);
  } else {
    throw std::invalid_argument("no such command '" + verb +
                                "'; allowed: end, pause, resume, estop, release, skip");
  }
}

std::string RealArm::MayCommand(const std::string& student) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return manager_->MayCommand(student);
}

bool RealArm::Involved(const std::string& student) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return manager_->Involved(student);
}

void RealArm::RigStopped(const std::string& student, const std::string& why) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!manager_->Involved(student)) return;
  Event(student + "'s rig stopped (" + why + "): out of the queue for the real arm");
  try {
    manager_->Leave(student);
  } catch (const turns::TurnError&) {
    // In the handover after their turn: the rig is unlinked already; the handover goes on.
  }
}

}  // namespace sirupp::classroom
