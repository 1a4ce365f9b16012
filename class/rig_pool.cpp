#include "class/rig_pool.hpp"

#include <sched.h>

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <utility>

#include "class/rig_job.hpp"
#include "class/rig_spawner.hpp"
#include "panel/panel_api.hpp"
#include "panel/panel_hub.hpp"
#include "proc/udpm_listen.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

// How long a rig's port must be silent before a rig starts on it: every SIRUPP process sends a
// heartbeat each second.
constexpr double kQuietListenS = 1.2;

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
      .count();
}

std::string WallClock() {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char text[16];
  std::strftime(text, sizeof text, "%H:%M:%S", &local);
  return text;
}

}  // namespace

std::string StudentFolder(const ClassConfig& config, const std::string& name) {
  return config.data_dir + "/students/" + name;
}

// One student's place in the class: their rig when it runs, and what the pages show about it.
struct RigPool::Seat {
  std::string name;
  std::mutex mutex;  // held while the rig starts or stops
  // Where the rig runs (class/rig_spawner.hpp): the server's own processes, or a cluster job.
  std::unique_ptr<RigSpawner> rig;
  // Read by the pages; written under `mutex` and `info_mutex`.
  mutable std::mutex info_mutex;
  // stopped, starting, running, failed; a cluster job also pending (waiting for the cluster or
  // starting on its node) and unknown (the cluster did not say; never read as stopped)
  std::string state = "stopped";
  std::string last_stop;                // why the rig last stopped ("" = never ran in this server)
  std::string waiting;                  // pending or unknown: why
  std::string where;                    // "udpm port 7910", "Slurm job 12 on node07"
  std::shared_ptr<RigPanel> panel;      // a local rig's panel
  std::optional<RigEndpoint> endpoint;  // a job's endpoint, once it reported
  Json remote_state;                    // a job's live state, fetched by the monitor
  std::string lcm_url;                  // a local rig's bus ("" for a job)
  std::chrono::steady_clock::time_point submitted{};
  std::chrono::steady_clock::time_point next_poll{};
  int starts = 0;
  double start_s = 0;
  double cpu = 0;
  // The CPU the rig's processes run on (limits.pin_rigs), else -1; counted under start_mutex_.
  std::atomic<int> on_cpu{-1};
  int port = 0;
  std::string started_at;  // wall clock
  std::atomic<int64_t> activity_ns{0};
  std::atomic<int> streams{0};  // the student's open event streams (activity while open)

  void Touch() { activity_ns = NowNs(); }
  double IdleSeconds() const {
    if (streams > 0) return 0;
    return static_cast<double>(NowNs() - activity_ns.load()) / 1e9;
  }
};

RigPool::RigPool(const ClassConfig& config, RigPoolOptions options, ProcessLauncher& launcher)
    : config_(config), options_(std::move(options)), launcher_(launcher) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (config_.pin_rigs && ::sched_getaffinity(0, sizeof allowed, &allowed) == 0) {
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
      if (CPU_ISSET(cpu, &allowed)) cpus_.push_back(cpu);
    }
    rigs_on_cpu_.assign(cpus_.size(), 0);
  }
  for (const std::string& name : config_.students) {
    auto seat = std::make_unique<Seat>();
    seat->name = name;
    seat->Touch();
    seats_[name] = std::move(seat);
  }
  if (config_.cluster) {
    cluster::SlurmOptions slurm;
    slurm.command_timeout_s = config_.cluster->command_timeout_s;
    engine_ = std::make_unique<cluster::SlurmEngine>(cluster_runner_, slurm);
    Reattach();
  }
}

RigPool::~RigPool() {
  BeginStop();
  StopAll("the class server stopped");
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
  if (Seat* seat = Find(student)) seat->Touch();
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

// Counts a rig in against max_rigs (and, for a `local` seat, picks its CPU), or says why not: the
// server is stopping or the class runs its limit. The caller gives the place back (--running_)
// when the start fails.
std::string RigPool::TakeRigPlace(Seat* local) {
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
  if (local != nullptr) local->on_cpu = PickCpu();
  return "";
}

// Starts the seat's rig unless it runs. Returns "" or why it cannot (for a 503).
std::string RigPool::EnsureRig(Seat& seat) {
  const std::lock_guard<std::mutex> lock(seat.mutex);
  if (seat.rig) return "";
  if (config_.cluster) return StartJob(seat);
  return StartLocal(seat);
}

// The seat's rig as this server's own processes, ready when it returns. Holds seat.mutex.
std::string RigPool::StartLocal(Seat& seat) {
  if (std::string why = TakeRigPlace(&seat); !why.empty()) return why;
  try {
    grade::PortLease lease = LeaseQuietPort();
    const std::string folder = StudentFolder(config_, seat.name);
    RigSpec spec;
    spec.robot = PrepareFolder(folder);
    spec.student = seat.name;
    spec.bin_dir = options_.bin_dir;
    spec.folder = folder;
    spec.port = lease.port();
    spec.limits = ChildLimits{config_.rig_nice, config_.rig_memory_mb, seat.on_cpu.load()};
    spec.pace_ticks = config_.pace_ticks;
    spec.controller = options_.controller ? options_.controller(seat.name) : "";
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.state = "starting";
    }
    auto rig = std::make_unique<LocalRigSpawner>(spec, launcher_, std::move(lease));
    rig->Start();
    const std::lock_guard<std::mutex> info(seat.info_mutex);
    seat.panel = rig->panel();
    seat.lcm_url = rig->lcm_url();
    seat.where = rig->Where();
    seat.start_s = rig->start_seconds();
    seat.port = spec.port;
    seat.state = "running";
    ++seat.starts;
    seat.started_at = WallClock();
    seat.rig = std::move(rig);
    seat.Touch();
    Log("started " + seat.name + "'s rig on " + RigUrl(spec.port) +
        (spec.limits.cpu >= 0 ? " (CPU " + std::to_string(spec.limits.cpu) + ")" : "") + " in " +
        std::to_string(seat.start_s).substr(0, 4) + " s");
    return "";
  } catch (const std::exception& e) {
    ReleaseCpu(seat);
    return StartFailed(seat, e.what());
  }
}

// A port of the rigs' range that no other class server or grader holds (grade::PortLease) and
// on which nothing is heard: LCM shares its port, so another program on it (a lab's `sirupp
// launch`, a test's rig, a rig that did not end) would talk on the student's bus. Ports where
// something talks are held while the next is tried, then given back; at most kQuietTries.
grade::PortLease RigPool::LeaseQuietPort() {
  constexpr int kQuietTries = 8;
  std::vector<grade::PortLease> busy;
  std::string heard;
  const int offset = static_cast<int>(NowNs() % config_.port_count);
  for (int k = 0; k < std::min(kQuietTries, config_.port_count); ++k) {
    grade::PortLease lease;
    try {
      lease = grade::PortLease::Acquire(config_.first_port, config_.port_count, offset + k);
    } catch (const std::exception&) {
      if (busy.empty()) throw;
      break;  // the rest are held by others
    }
    const std::string talk = proc::HeardOnUdpm(proc::kRigGroup, lease.port(), kQuietListenS);
    if (talk.empty()) return lease;
    Log("udpm port " + std::to_string(lease.port()) + " skipped: something else talks on it (" +
        talk + ")");
    heard = talk;
    busy.push_back(std::move(lease));
  }
  throw std::runtime_error("no quiet udpm port for a rig in " + std::to_string(config_.first_port) +
                           ".." + std::to_string(config_.first_port + config_.port_count - 1) +
                           ": " + std::to_string(busy.size()) +
                           " tried, something else talks on each (" + heard + ")");
}

// Stops the seat's rig (if any), saying why. The caller holds seat.mutex.
void RigPool::StopRig(Seat& seat, const std::string& why, bool failed) {
  std::unique_ptr<RigSpawner> rig;
  {
    const std::lock_guard<std::mutex> info(seat.info_mutex);
    if (!seat.rig) return;
    rig = std::move(seat.rig);
    seat.panel.reset();
    seat.endpoint.reset();
    seat.remote_state = nullptr;
    seat.lcm_url.clear();
    seat.waiting.clear();
    seat.state = failed ? "failed" : "stopped";
    seat.last_stop = why;
    seat.cpu = 0;
  }
  if (arm_stopped_) arm_stopped_(seat.name, why);
  const std::string not_stopped = rig->Stop();
  if (!not_stopped.empty()) {
    // The engine did not answer: the job may still run. Cancelled again each second (and
    // after a restart: the list is saved) until the engine takes it.
    const Json state = rig->State();
    const std::lock_guard<std::mutex> jobs(jobs_mutex_);
    const auto job = state.is_object() ? state.find("job") : state.end();
    if (job != state.end() && job->is_string()) cancel_later_.push_back(job->get<std::string>());
    Log(seat.name + "'s rig job: " + not_stopped + "; cancelled again until it is taken");
  }
  rig.reset();
  ReleaseCpu(seat);
  --running_;
  SaveJobs();
  Log("stopped " + seat.name + "'s rig: " + why);
}

// The allowed CPU with the fewest rigs (the lowest of equals), counted for the seat; -1 when
// nothing is pinned. Under start_mutex_.
int RigPool::PickCpu() {
  if (cpus_.size() < 2) return -1;
  const size_t least = static_cast<size_t>(
      std::min_element(rigs_on_cpu_.begin(), rigs_on_cpu_.end()) - rigs_on_cpu_.begin());
  ++rigs_on_cpu_[least];
  return cpus_[least];
}

void RigPool::ReleaseCpu(Seat& seat) {
  const std::lock_guard<std::mutex> count_lock(start_mutex_);
  const int cpu = seat.on_cpu.exchange(-1);
  if (cpu < 0) return;
  const auto at = std::find(cpus_.begin(), cpus_.end(), cpu);
  if (at != cpus_.end()) --rigs_on_cpu_[static_cast<size_t>(at - cpus_.begin())];
}

// --- rigs as cluster jobs (class file cluster:) -------------------------------------------------

std::string RigPool::JobsFile() const { return config_.data_dir + "/cluster/rigs.json"; }

// A path under the data folder, as the nodes see it.
std::string RigPool::OnNodes(const std::string& path) const {
  if (path.rfind(config_.data_dir + "/", 0) != 0) return path;
  const std::string node_data =
      config_.cluster->node_data.empty() ? config_.data_dir : config_.cluster->node_data;
  return node_data + path.substr(config_.data_dir.size());
}

// Saves every job's state (and the cancels still owed), so a restarted server reattaches.
void RigPool::SaveJobs() {
  if (!config_.cluster) return;
  SavedRigJobs saved;
  for (auto& [name, seat] : seats_) {
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    if (!seat->rig) continue;
    const Json state = seat->rig->State();
    if (!state.is_null()) saved.rigs.push_back(state);
  }
  {
    const std::lock_guard<std::mutex> jobs(jobs_mutex_);
    saved.cancel = cancel_later_;
  }
  try {
    SaveRigJobs(JobsFile(), saved);
  } catch (const std::exception& e) {
    Log(std::string("cannot save the rig jobs: ") + e.what());
  }
}

// Submits the seat's rig as a job; it is pending until the job reports its endpoint. Holds
// seat.mutex. Returns "" or why it cannot.
std::string RigPool::StartJob(Seat& seat) {
  if (std::string why = TakeRigPlace(nullptr); !why.empty()) return why;
  try {
    const std::string folder = StudentFolder(config_, seat.name);
    const std::string model = PrepareFolder(folder);
    fs::create_directories(folder + "/logs");
    fs::create_directories(folder + "/results");
    RigJobSpec spec;
    spec.student = seat.name;
    spec.folder = OnNodes(folder);
    spec.robot = OnNodes(model);
    spec.bin_dir = options_.bin_dir;
    const std::string secret_file = config_.data_dir + "/cluster/secrets/" + seat.name;
    spec.secret_file = OnNodes(secret_file);
    spec.report_url = config_.cluster->report_url.empty() ? BaseUrl(config_, server_port_.load())
                                                          : config_.cluster->report_url;
    spec.controller = OnNodes(options_.controller ? options_.controller(seat.name) : "");
    spec.pace_ticks = config_.pace_ticks;
    spec.memory_mb = config_.rig_memory_mb;
    auto rig =
        std::make_unique<SlurmRigSpawner>(*engine_, *config_.cluster, spec, secret_file, folder);
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.state = "starting";
    }
    rig->Start();
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.state = "pending";
      seat.waiting = "submitted to the cluster";
      seat.where = rig->Where();
      seat.submitted = Clock::now();
      seat.next_poll = Clock::now();
      seat.rig = std::move(rig);
    }
    seat.Touch();
    SaveJobs();
    Log("submitted " + seat.name + "'s rig as " + seat.where);
    return "";
  } catch (const std::exception& e) {
    return StartFailed(seat, e.what());
  }
}

std::string RigPool::StartFailed(Seat& seat, const std::string& why) {
  --running_;
  const std::lock_guard<std::mutex> info(seat.info_mutex);
  seat.state = "failed";
  seat.last_stop = "could not start: " + why;
  Log(seat.name + "'s rig could not start: " + why);
  return seat.last_stop;
}

// The rig jobs a previous server left (DATA/cluster/rigs.json): each seat takes its job back
// as it was (running at its endpoint, or pending); the monitor's first poll says what became of
// it. No job is started twice, none is left without a seat.
void RigPool::Reattach() {
  SavedRigJobs saved;
  try {
    saved = LoadRigJobs(JobsFile());
  } catch (const std::exception& e) {
    Log(std::string("the saved rig jobs are not readable (") + e.what() + "); none reattached");
    return;
  }
  cancel_later_ = saved.cancel;
  for (const Json& state : saved.rigs) {
    const auto named = state.is_object() ? state.find("student") : state.end();
    const std::string student =
        named != state.end() && named->is_string() ? named->get<std::string>() : "";
    Seat* seat = Find(student);
    std::unique_ptr<SlurmRigSpawner> rig;
    try {
      rig = std::make_unique<SlurmRigSpawner>(*engine_, *config_.cluster, state,
                                              StudentFolder(config_, student));
    } catch (const std::exception& e) {
      Log(std::string("a saved rig job is not readable: ") + e.what());
      continue;
    }
    if (seat == nullptr || seat->rig) {  // no longer in the class, or twice: end it
      cancel_later_.push_back(rig->job_id());
      continue;
    }
    ++running_;
    seat->endpoint = rig->endpoint();
    seat->state = seat->endpoint ? "running" : "pending";
    seat->waiting = seat->endpoint ? "" : "reattached after a restart of the class server";
    seat->where = rig->Where();
    // Its start as the job saw it, not this server's: the submission's wall-clock time moved onto
    // this server's steady clock (a state saved without it counts from now).
    const auto submitted = rig->submitted();
    const double ago = submitted ? std::max(0.0, std::chrono::duration<double>(
                                                     std::chrono::system_clock::now() - *submitted)
                                                     .count())
                                 : 0.0;
    seat->submitted = Clock::now() - std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(ago));
    seat->start_s = seat->endpoint ? rig->ready_s() : 0;
    seat->started_at = seat->endpoint && !rig->ready_at().empty() ? rig->ready_at() : "";
    seat->next_poll = Clock::now();
    seat->rig = std::move(rig);
    Log("reattached " + student + "'s rig, " + seat->where +
        (submitted ? ", submitted " + std::to_string(static_cast<int>(ago)) + " s ago"
                   : ", its submission time unknown") +
        (seat->endpoint && !seat->started_at.empty()
             ? ", ready since " + seat->started_at + " (" +
                   std::to_string(seat->start_s).substr(0, 4) + " s after it was submitted)"
             : ""));
  }
}

bool RigPool::Reported(const std::string& student, const std::string& secret,
                       const std::string& job_id, const std::string& host, int port) {
  Seat* seat = config_.cluster ? Find(student) : nullptr;
  if (seat == nullptr) return false;
  {
    const std::lock_guard<std::mutex> lock(seat->mutex);
    auto* job = dynamic_cast<SlurmRigSpawner*>(seat->rig.get());
    if (job == nullptr || !job->Reported(secret, job_id, host, port)) return false;
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    seat->endpoint = job->endpoint();
    seat->state = "running";
    seat->waiting.clear();
    seat->where = job->Where();
    seat->start_s = job->ready_s() > 0
                        ? job->ready_s()
                        : std::chrono::duration<double>(Clock::now() - seat->submitted).count();
    seat->started_at = WallClock();
    ++seat->starts;
  }
  SaveJobs();
  Log(seat->name + "'s rig job is ready at " + seat->endpoint->Address() + ", " +
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
    RetryCancels();
    for (auto& [name, seat] : seats_) {
      std::unique_lock<std::mutex> seat_lock(seat->mutex, std::try_to_lock);
      if (!seat_lock.owns_lock() || !seat->rig) continue;
      const bool runs = PollRig(*seat);
      if (!seat->rig) continue;  // it ended
      if (runs) {
        const double cpu = seat->rig->CpuPercent();
        const std::lock_guard<std::mutex> info(seat->info_mutex);
        seat->cpu = cpu;
      }
      // A job waiting for the cluster is idle too when nobody asks for it (its place goes).
      if (seat->IdleSeconds() > config_.idle_timeout_s &&
          !(arm_involved_ && arm_involved_(name))) {  // waiting for the real arm is not idle
        StopRig(*seat, "stopped after " + std::to_string(static_cast<int>(config_.idle_timeout_s)) +
                           " s without a visit (idle)");
      }
    }
    lock.lock();
  }
}

// Asks the seat's rig where it is (a job: at most every cluster.poll_s) and acts on it: ended ->
// stopped with the reason; pending or unknown -> shown with why. False when it is not running.
// A running job's live state is fetched for the teacher's page. Holds seat.mutex.
bool RigPool::PollRig(Seat& seat) {
  const bool job = seat.rig->panel() == nullptr;
  if (job && Clock::now() < seat.next_poll) {
    if (seat.endpoint) FetchRemoteState(seat);
    return seat.endpoint.has_value();
  }
  if (job) {
    seat.next_poll =
        Clock::now() + std::chrono::milliseconds(static_cast<int>(config_.cluster->poll_s * 1000));
  }
  const RigStatus status = seat.rig->Poll();
  if (status.phase == RigPhase::kEnded) {
    StopRig(seat, status.reason, true);
    return false;
  }
  {
    const std::lock_guard<std::mutex> info(seat.info_mutex);
    if (status.phase == RigPhase::kPending || status.phase == RigPhase::kUnknown) {
      seat.state = status.phase == RigPhase::kPending && !seat.endpoint ? "pending" : "unknown";
      if (status.phase == RigPhase::kPending && seat.endpoint) seat.state = "running";
      seat.waiting = status.reason;
    } else if (seat.state != "running" && (!job || seat.endpoint)) {
      seat.state = "running";
      seat.waiting.clear();
    }
    seat.where = seat.rig->Where();
  }
  if (job && seat.endpoint) FetchRemoteState(seat);
  return status.phase == RigPhase::kRunning;
}

void RigPool::FetchRemoteState(Seat& seat) {
  const std::optional<Json> state = FetchJson(*seat.endpoint, "/api/state", 1.0);
  const std::lock_guard<std::mutex> info(seat.info_mutex);
  seat.remote_state = state ? *state : Json();
}

// Cancels whose engine did not answer before, again.
void RigPool::RetryCancels() {
  std::vector<std::string> owed;
  {
    const std::lock_guard<std::mutex> jobs(jobs_mutex_);
    owed.swap(cancel_later_);
  }
  if (owed.empty() || !engine_) return;
  std::vector<std::string> still;
  for (const std::string& id : owed) {
    const std::string error = engine_->Cancel(id);
    if (!error.empty()) still.push_back(id);
  }
  {
    const std::lock_guard<std::mutex> jobs(jobs_mutex_);
    cancel_later_.insert(cancel_later_.end(), still.begin(), still.end());
  }
  if (still.size() != owed.size()) SaveJobs();
}

// --- what the routes and pages are told ---------------------------------------------------------

RigAccess RigPool::Access(const std::string& student) const {
  RigAccess access;
  const Seat* seat = Find(student);
  if (seat == nullptr) return access;
  const std::lock_guard<std::mutex> info(seat->info_mutex);
  access.panel = seat->panel;
  access.endpoint = seat->endpoint;
  access.state = seat->state;
  access.waiting = seat->waiting;
  access.last_stop = seat->last_stop;
  return access;
}

std::shared_ptr<void> RigPool::OpenStream(const std::string& student) {
  Seat* seat = Find(student);
  if (seat == nullptr) return nullptr;
  ++seat->streams;
  // The count goes down when the stream's provider (and so this guard) is destroyed.
  return std::shared_ptr<void>(nullptr, [seat](void*) {
    --seat->streams;
    seat->Touch();
  });
}

bool RigPool::StillAt(const std::string& student, const RigEndpoint& endpoint) const {
  const Seat* seat = Find(student);
  if (seat == nullptr) return false;
  {
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    if (!seat->endpoint || seat->endpoint->port != endpoint.port ||
        seat->endpoint->host != endpoint.host) {
      return false;
    }
  }
  return !Stopping();
}

std::string RigPool::LcmUrl(const std::string& student) const {
  const Seat* seat = Find(student);
  if (seat == nullptr) return "";
  const std::lock_guard<std::mutex> info(seat->info_mutex);
  return seat->state == "running" ? seat->lcm_url : "";
}

Json RigPool::SeatJson(const std::string& student, bool live) const {
  const Seat* seat = Find(student);
  if (seat == nullptr) return nullptr;
  std::shared_ptr<RigPanel> rig_panel;
  Json out;
  Json remote;
  {
    const std::lock_guard<std::mutex> info(seat->info_mutex);
    rig_panel = seat->panel;
    remote = seat->remote_state;
    out = Json{{"name", seat->name},
               {"state", seat->state},
               {"waiting", seat->waiting},
               {"where", seat->where},
               {"starts", seat->starts},
               {"start_s", seat->start_s},
               {"last_stop", seat->last_stop},
               {"cpu_percent", seat->cpu},
               {"on_cpu", seat->on_cpu.load()},
               {"port", seat->port},
               {"started_at", seat->started_at},
               {"idle_s", seat->IdleSeconds()},
               {"streams", seat->streams.load()}};
  }
  if (live && rig_panel) {
    const Json state = rig_panel->hub->StateJson();
    if (state.contains("controller")) out["controller"] = state["controller"];
    if (state.contains("sim")) out["sim"] = state["sim"];
    if (state.contains("estop")) out["estop"] = state["estop"];
    if (state.contains("virtual")) out["q"] = state["virtual"]["q"];
    out["lock"] = rig_panel->api->LockHolder();
  }
  if (live && !rig_panel && remote.is_object()) {  // a job's, as the monitor last fetched it
    for (const char* key : {"controller", "sim", "estop"}) {
      if (remote.contains(key)) out[key] = remote[key];
    }
    if (remote.contains("virtual") && remote["virtual"].contains("q")) {
      out["q"] = remote["virtual"]["q"];
    }
  }
  return out;
}

}  // namespace sirupp::classroom
