#include "class/rig_pool.hpp"

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <utility>

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::string WallClock() {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char text[16];
  std::strftime(text, sizeof text, "%H:%M:%S", &local);
  return text;
}

int64_t Ns(std::chrono::steady_clock::time_point at) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(at.time_since_epoch()).count();
}

}  // namespace

std::string StudentFolder(const ClassConfig& config, const std::string& name) {
  return config.data_dir + "/students/" + name;
}

// One student's place in the class: their rig when it runs, and what the pages show about it.
struct RigPool::Seat {
  std::string name;
  std::mutex mutex;  // held while the rig starts, stops or is polled
  // Read by the pages; written under `mutex` and `info_mutex`.
  mutable std::mutex info_mutex;
  // Where the rig runs (class/rig_spawner.hpp); shared with a page reading its live state.
  std::shared_ptr<RigSpawner> rig;
  RigPhase phase = RigPhase::kStopped;
  std::string last_stop;  // why the rig last stopped ("" = never ran in this server)
  std::string waiting;    // pending or unknown: why
  std::string where;      // "udpm port 7910", "Slurm job 12 on node07"
  RigReach reach;         // how the server reaches it (empty while it is not running)
  std::chrono::steady_clock::time_point submitted{};
  std::chrono::steady_clock::time_point next_poll{};
  int starts = 0;
  double start_s = 0;
  double cpu = 0;
  int port = 0;                         // the last local rig's udpm port (kept after it stopped)
  std::string started_at;               // wall clock
  std::atomic<int64_t> activity_ns{0};  // on the pool's clock
  std::atomic<int> streams{0};          // the student's open event streams (activity while open)

  void Touch(std::chrono::steady_clock::time_point now) { activity_ns = Ns(now); }
  double IdleSeconds(std::chrono::steady_clock::time_point now) const {
    if (streams > 0) return 0;
    return static_cast<double>(Ns(now) - activity_ns.load()) / 1e9;
  }
};

RigPool::RigPool(const ClassConfig& config, RigPoolOptions options, ProcessLauncher& launcher)
    : config_(config),
      options_(std::move(options)),
      own_spawners_(MakeRigSpawnerFactory(config, RigSpawnerOptions{options_.bin_dir, options_.log},
                                          launcher)),
      spawners_(*own_spawners_) {
  AddSeats();
}

RigPool::RigPool(const ClassConfig& config, RigPoolOptions options, RigSpawnerFactory& spawners)
    : config_(config), options_(std::move(options)), spawners_(spawners) {
  AddSeats();
}

void RigPool::AddSeats() {
  for (const std::string& name : config_.students) {
    auto seat = std::make_unique<Seat>();
    seat->name = name;
    seat->Touch(Now());
    seats_[name] = std::move(seat);
  }
  Reattach();
}

RigPool::~RigPool() {
  BeginStop();
  StopAll("the class server stopped");
}

RigPool::Clock::time_point RigPool::Now() const {
  return options_.clock ? options_.clock() : Clock::now();
}

void RigPool::SetRealArmHooks(
    std::function<void(const std::string& student, const std::string& why)> stopped,
    std::function<bool(const std::string& student)> involved) {
  arm_stopped_ = std::move(stopped);
  arm_involved_ = std::move(involved);
}

void RigPool::SetServerPort(int port) { server_port_ = port; }

RigPool::Seat* RigPool::Find(const std::string& student) const {
  const auto found = seats_.find(student);
  return found == seats_.end() ? nullptr : found->second.get();
}

bool RigPool::Has(const std::string& student) const { return Find(student) != nullptr; }

std::vector<std::string> RigPool::Students() const {
  std::vector<std::string> names;
  for (const auto& [name, seat] : seats_) names.push_back(name);
  return names;
}

void RigPool::Log(const std::string& line) const {
  if (options_.log) options_.log(line);
}

void RigPool::Touch(const std::string& student) {
  if (Seat* seat = Find(student)) seat->Touch(Now());
}

// --- starting and stopping ----------------------------------------------------------------------

std::string RigPool::Ensure(const std::string& student) {
  Seat* seat = Find(student);
  if (seat == nullptr) return "no student '" + student + "' in this class";
  return EnsureRig(*seat);
}

void RigPool::Stop(const std::string& student, const std::string& why) {
  Seat* seat = Find(student);
  if (seat == nullptr) return;
  const std::lock_guard<std::mutex> lock(seat->mutex);
  StopRig(*seat, why);
}

// A new student's folder gets a copy of config/ (what the panel's file lists show and where a
// saved model goes). The class's robot model is copied into it at every start, so the rig runs
// a file the student's panel may read. Returns the rig's model file.
std::string RigPool::PrepareFolder(const std::string& folder) const {
  if (!fs::exists(folder + "/config")) {
    fs::create_directories(folder);
    fs::copy(options_.config_dir, folder + "/config", fs::copy_options::recursive);
  }
  fs::create_directories(folder + "/config/robots");
  const std::string model =
      folder + "/config/robots/" + fs::path(config_.robot).filename().string();
  if (fs::absolute(model).lexically_normal() != fs::path(config_.robot)) {
    fs::copy_file(config_.robot, model, fs::copy_options::overwrite_existing);
  }
  return model;
}

// Counts a rig in against max_rigs, or says why not: the server is stopping or the class runs
// its limit. The caller gives the place back (--running_) when the start fails.
std::string RigPool::TakeRigPlace() {
  {
    const std::lock_guard<std::mutex> stop_lock(monitor_mutex_);
    if (stopping_) return "the class server is stopping";
  }
  const std::lock_guard<std::mutex> count_lock(start_mutex_);
  if (running_ >= config_.max_rigs) {
    return "the class server already runs its limit of " + std::to_string(config_.max_rigs) +
           " rigs; try again in a few minutes (idle rigs stop after " +
           std::to_string(static_cast<int>(config_.idle_timeout_s)) + " s)";
  }
  ++running_;
  return "";
}

// Starts the seat's rig unless it runs: running when Start returns (a local rig), or pending
// until it reports (a job). Returns "" or why it cannot (for a 503).
std::string RigPool::EnsureRig(Seat& seat) {
  const std::lock_guard<std::mutex> lock(seat.mutex);
  if (seat.rig) return "";
  if (std::string why = TakeRigPlace(); !why.empty()) return why;
  try {
    RigRequest request;
    request.student = seat.name;
    request.folder = StudentFolder(config_, seat.name);
    request.robot = PrepareFolder(request.folder);
    request.controller = options_.controller ? options_.controller(seat.name) : "";
    request.server_url = BaseUrl(config_, server_port_.load());
    std::shared_ptr<RigSpawner> rig = spawners_.Make(request);
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.phase = RigPhase::kStarting;
    }
    const RigStatus started = rig->Start();
    const auto now = Now();
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.reach = rig->Reach();
      seat.where = rig->Where();
      seat.submitted = now;
      seat.next_poll = now;
      if (started.phase == RigPhase::kRunning) {
        seat.phase = RigPhase::kRunning;
        seat.waiting.clear();
        seat.start_s = rig->ReadySeconds();
        seat.started_at = WallClock();
        if (seat.reach.port > 0) seat.port = seat.reach.port;
        ++seat.starts;
      } else {
        seat.phase = RigPhase::kPending;
        seat.waiting = started.reason;
      }
      seat.rig = rig;
    }
    seat.Touch(now);
    SaveRigs();
    if (started.phase == RigPhase::kRunning) {
      Log("started " + seat.name + "'s rig on " + seat.where +
          (seat.reach.cpu >= 0 ? " (CPU " + std::to_string(seat.reach.cpu) + ")" : "") + " in " +
          std::to_string(seat.start_s).substr(0, 4) + " s");
    } else {
      Log("submitted " + seat.name + "'s rig as " + seat.where);
    }
    return "";
  } catch (const std::exception& e) {
    return StartFailed(seat, e.what());
  }
}

std::string RigPool::StartFailed(Seat& seat, const std::string& why) {
  --running_;
  const std::lock_guard<std::mutex> info(seat.info_mutex);
  seat.phase = RigPhase::kFailed;
  seat.last_stop = "could not start: " + why;
  Log(seat.name + "'s rig could not start: " + why);
  return seat.last_stop;
}

// Stops the seat's rig (if any), saying why. The caller holds seat.mutex.
void RigPool::StopRig(Seat& seat, const std::string& why, bool failed) {
  std::shared_ptr<RigSpawner> rig;
  {
    const std::lock_guard<std::mutex> info(seat.info_mutex);
    if (!seat.rig) return;
    rig = std::move(seat.rig);
    seat.reach = RigReach{};
    seat.waiting.clear();
    seat.phase = failed ? RigPhase::kFailed : RigPhase::kStopped;
    seat.last_stop = why;
    seat.cpu = 0;
  }
  if (arm_stopped_) arm_stopped_(seat.name, why);
  const std::string not_stopped = rig->Stop();
  if (!not_stopped.empty()) {
    // The engine did not answer: the rig may still run. Stopped again each second (and after a
    // restart: the list is saved) until the engine takes it.
    const Json state = rig->State();
    if (!state.is_null()) {
      const std::lock_guard<std::mutex> stops(stops_mutex_);
      owed_stops_.push_back(state);
    }
    Log(seat.name + "'s rig, " + rig->Where() + ": " + not_stopped +
        "; stopped again until it is taken");
  }
  rig.reset();
  --running_;
  SaveRigs();
  Log("stopped " + seat.name + "'s rig: " + why);
}

// --- kept for a restarted server ----------------------------------------------------------------

// Saves every rig's state (and the stops still owed) through the factory, so a restarted server
// reattaches. A kind that keeps nothing saves nothing.
void RigPool::SaveRigs() {
  SavedRigs saved;
  for (auto& [name, seat] : seats_) {
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    if (!seat->rig) continue;
    const Json state = seat->rig->State();
    if (!state.is_null()) saved.rigs.push_back(state);
  }
  {
    const std::lock_guard<std::mutex> stops(stops_mutex_);
    saved.stops = owed_stops_;
  }
  try {
    spawners_.Save(saved);
  } catch (const std::exception& e) {
    Log(std::string("cannot save the rigs for a restarted server: ") + e.what());
  }
}

// The rigs a previous server left (for a Slurm class DATA/cluster/rigs.json): each seat takes its
// rig back as it was (running where it was reached, or pending); the monitor's first poll says
// what became of it. No rig is started twice, none is left without a seat.
void RigPool::Reattach() {
  SavedRigs saved;
  try {
    saved = spawners_.Load();
  } catch (const std::exception& e) {
    Log(std::string("the saved rigs are not readable (") + e.what() + "); none reattached");
    return;
  }
  owed_stops_ = saved.stops;
  const auto now = Now();
  for (const Json& state : saved.rigs) {
    std::shared_ptr<RigSpawner> rig;
    try {
      rig = spawners_.Restore(state);
    } catch (const std::exception& e) {
      Log(std::string("a saved rig is not readable: ") + e.what());
      continue;
    }
    const std::string student = rig->student();
    Seat* seat = Find(student);
    if (seat == nullptr || seat->rig) {  // no longer in the class, or twice: end it
      owed_stops_.push_back(rig->State());
      continue;
    }
    ++running_;
    seat->reach = rig->Reach();
    const bool reachable = seat->reach.reachable();
    seat->phase = reachable ? RigPhase::kRunning : RigPhase::kPending;
    seat->waiting = reachable ? "" : "reattached after a restart of the class server";
    seat->where = rig->Where();
    // Its start as the rig saw it, not this server's: the start's wall-clock time moved onto the
    // pool's clock (a state saved without it counts from now).
    const auto submitted = rig->Submitted();
    const double ago = submitted ? std::max(0.0, std::chrono::duration<double>(
                                                     std::chrono::system_clock::now() - *submitted)
                                                     .count())
                                 : 0.0;
    seat->submitted =
        now - std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(ago));
    seat->start_s = reachable ? rig->ReadySeconds() : 0;
    seat->started_at = reachable ? rig->ReadyAt() : "";
    seat->next_poll = now;
    seat->rig = rig;
    Log("reattached " + student + "'s rig, " + seat->where +
        (submitted ? ", submitted " + std::to_string(static_cast<int>(ago)) + " s ago"
                   : ", its submission time unknown") +
        (reachable && !seat->started_at.empty()
             ? ", ready since " + seat->started_at + " (" +
                   std::to_string(seat->start_s).substr(0, 4) + " s after it was submitted)"
             : ""));
  }
}

bool RigPool::Reported(const std::string& student, const std::string& secret,
                       const std::string& job_id, const std::string& host, int port,
                       int udpm_port) {
  Seat* seat = Find(student);
  if (seat == nullptr) return false;
  std::string address;
  {
    const std::lock_guard<std::mutex> lock(seat->mutex);
    if (!seat->rig || !seat->rig->Report(RigReport{secret, job_id, host, port, udpm_port}))
      return false;
    const RigSpawner& rig = *seat->rig;
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    seat->reach = rig.Reach();
    seat->phase = RigPhase::kRunning;
    seat->waiting.clear();
    seat->where = rig.Where();
    seat->start_s = rig.ReadySeconds() > 0
                        ? rig.ReadySeconds()
                        : std::chrono::duration<double>(Now() - seat->submitted).count();
    seat->started_at = WallClock();
    ++seat->starts;
    address = seat->reach.endpoint ? seat->reach.endpoint->Address() : seat->where;
  }
  SaveRigs();
  Log(seat->name + "'s rig job is ready at " + address + ", " +
      std::to_string(seat->start_s).substr(0, 4) + " s after it was submitted");
  return true;
}

// --- the monitor --------------------------------------------------------------------------------

bool RigPool::StartMonitor() {
  // Made under the lock BeginStop() sets `stopping_` under, so a BeginStop() that comes first
  // sees no thread to join and none starts.
  const std::lock_guard<std::mutex> lock(monitor_mutex_);
  if (stopping_) return false;
  monitor_ = std::thread([this] { Monitor(); });
  return true;
}

void RigPool::BeginStop() {
  {
    const std::lock_guard<std::mutex> lock(monitor_mutex_);
    stopping_ = true;
  }
  monitor_wake_.notify_all();
  if (monitor_.joinable()) monitor_.join();
}

bool RigPool::Stopping() const {
  const std::lock_guard<std::mutex> lock(monitor_mutex_);
  return stopping_;
}

void RigPool::StopAll(const std::string& why) {
  for (auto& [name, seat] : seats_) {
    const std::lock_guard<std::mutex> lock(seat->mutex);
    StopRig(*seat, why);
  }
}

void RigPool::Monitor() {
  std::unique_lock<std::mutex> lock(monitor_mutex_);
  while (!stopping_) {
    monitor_wake_.wait_for(lock, std::chrono::seconds(1));
    if (stopping_) break;
    lock.unlock();
    MonitorPass();
    lock.lock();
  }
}

void RigPool::MonitorPass() {
  RetryStops();
  for (auto& [name, seat] : seats_) {
    std::unique_lock<std::mutex> seat_lock(seat->mutex, std::try_to_lock);
    if (!seat_lock.owns_lock() || !seat->rig) continue;
    const auto now = Now();
    const bool runs = PollRig(*seat, now);
    if (!seat->rig) continue;  // it ended
    if (runs) {
      const double cpu = seat->rig->CpuPercent();
      const std::lock_guard<std::mutex> info(seat->info_mutex);
      seat->cpu = cpu;
    }
    // A rig waiting for the cluster is idle too when nobody asks for it (its place goes).
    if (seat->IdleSeconds(now) > config_.idle_timeout_s &&
        !(arm_involved_ && arm_involved_(name))) {  // waiting for the real arm is not idle
      StopRig(*seat, "stopped after " + std::to_string(static_cast<int>(config_.idle_timeout_s)) +
                         " s without a visit (idle)");
    }
  }
}

// Asks the seat's rig where it is (at most every PollIntervalS) and acts on it: failed ->
// stopped with the reason; pending or unknown -> shown with why. False when it is not running.
// The rig's live state is refreshed at every pass. Holds seat.mutex.
bool RigPool::PollRig(Seat& seat, Clock::time_point now) {
  RigSpawner& rig = *seat.rig;
  if (now < seat.next_poll) {
    rig.Refresh();
    const std::lock_guard<std::mutex> info(seat.info_mutex);
    return seat.phase == RigPhase::kRunning;
  }
  seat.next_poll = now + std::chrono::duration_cast<Clock::duration>(
                             std::chrono::duration<double>(rig.PollIntervalS()));
  const RigStatus status = rig.Poll();
  if (status.phase == RigPhase::kFailed || status.phase == RigPhase::kStopped) {
    StopRig(seat, status.reason, true);
    return false;
  }
  {
    const std::lock_guard<std::mutex> info(seat.info_mutex);
    const bool reachable = seat.reach.reachable();
    if (status.phase == RigPhase::kPending || status.phase == RigPhase::kUnknown) {
      // Pending while it is reached: it runs (the engine is behind); unknown is never stopped.
      if (status.phase == RigPhase::kPending) {
        seat.phase = reachable ? RigPhase::kRunning : RigPhase::kPending;
      } else {
        seat.phase = RigPhase::kUnknown;
      }
      seat.waiting = status.reason;
    } else if (seat.phase != RigPhase::kRunning && reachable) {
      seat.phase = RigPhase::kRunning;
      seat.waiting.clear();
    }
    seat.where = rig.Where();
  }
  rig.Refresh();
  return status.phase == RigPhase::kRunning;
}

// Stops whose engine did not answer before, again.
void RigPool::RetryStops() {
  std::vector<Json> owed;
  {
    const std::lock_guard<std::mutex> stops(stops_mutex_);
    owed.swap(owed_stops_);
  }
  if (owed.empty()) return;
  std::vector<Json> still;
  for (const Json& state : owed) {
    if (!spawners_.StopSaved(state).empty()) still.push_back(state);
  }
  {
    const std::lock_guard<std::mutex> stops(stops_mutex_);
    owed_stops_.insert(owed_stops_.end(), still.begin(), still.end());
  }
  if (still.size() != owed.size()) SaveRigs();
}

// --- what the routes and pages are told ---------------------------------------------------------

RigAccess RigPool::Access(const std::string& student) const {
  RigAccess access;
  const Seat* seat = Find(student);
  if (seat == nullptr) return access;
  const std::lock_guard<std::mutex> info(seat->info_mutex);
  access.panel = seat->reach.panel;
  access.endpoint = seat->reach.endpoint;
  access.phase = seat->phase;
  access.waiting = seat->waiting;
  access.last_stop = seat->last_stop;
  return access;
}

std::shared_ptr<void> RigPool::OpenStream(const std::string& student) {
  Seat* seat = Find(student);
  if (seat == nullptr) return nullptr;
  ++seat->streams;
  // The count goes down when the stream's provider (and so this guard) is destroyed.
  return std::shared_ptr<void>(nullptr, [this, seat](void*) {
    --seat->streams;
    seat->Touch(Now());
  });
}

bool RigPool::StillAt(const std::string& student, const RigEndpoint& endpoint) const {
  const Seat* seat = Find(student);
  if (seat == nullptr) return false;
  {
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    const std::optional<RigEndpoint>& at = seat->reach.endpoint;
    if (!at || at->port != endpoint.port || at->host != endpoint.host) return false;
  }
  return !Stopping();
}

std::string RigPool::LcmUrl(const std::string& student) const {
  const Seat* seat = Find(student);
  if (seat == nullptr) return "";
  const std::lock_guard<std::mutex> info(seat->info_mutex);
  return seat->phase == RigPhase::kRunning ? seat->reach.lcm_url : "";
}

NotebookSite RigPool::Notebook(const std::string& student) const {
  const Seat* seat = Find(student);
  NotebookSite site;
  if (seat == nullptr) {
    site.why_not = "no student '" + student + "' in this class";
    return site;
  }
  std::shared_ptr<RigSpawner> rig;
  {
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    rig = seat->rig;
    if (!rig) {
      site.why_not = student + "'s rig is not running" +
                     (seat->last_stop.empty() ? std::string() : " (" + seat->last_stop + ")");
      return site;
    }
  }
  return rig->Notebook();
}

Json RigPool::SeatJson(const std::string& student, bool live) const {
  const Seat* seat = Find(student);
  if (seat == nullptr) return nullptr;
  std::shared_ptr<RigSpawner> rig;
  Json out;
  const auto now = Now();
  {
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    rig = seat->rig;
    out = Json{{"name", seat->name},
               {"state", RigPhaseName(seat->phase)},
               {"waiting", seat->waiting},
               {"where", seat->where},
               {"starts", seat->starts},
               {"start_s", seat->start_s},
               {"last_stop", seat->last_stop},
               {"cpu_percent", seat->cpu},
               {"on_cpu", seat->reach.cpu},
               {"port", seat->port},
               {"started_at", seat->started_at},
               {"idle_s", seat->IdleSeconds(now)},
               {"streams", seat->streams.load()}};
  }
  if (live && rig) {
    const Json state = rig->LiveState();
    if (state.is_object()) {
      for (const char* key : {"controller", "sim", "estop", "lock"}) {
        if (state.contains(key)) out[key] = state[key];
      }
      if (state.contains("virtual") && state["virtual"].is_object() &&
          state["virtual"].contains("q")) {
        out["q"] = state["virtual"]["q"];
      }
    }
  }
  return out;
}

}  // namespace sirupp::classroom
