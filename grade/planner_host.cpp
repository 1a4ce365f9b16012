#include "grade/planner_host.hpp"

#include <cxxabi.h>
#include <dlfcn.h>
#include <signal.h>
#include <sirupp/student_planner.h>
#include <sys/mman.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <optional>
#include <stdexcept>
#include <string>
#include <typeinfo>
#include <vector>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/motion_limits.hpp"
#include "planning/collision_model.hpp"

namespace sirupp::grade {
namespace {

using PlanFunction = int (*)(const double*, const double*, int, const sirupp_planning_scene*,
                             double*, int, int*, char*, int);
using VersionFunction = int (*)();

constexpr const char* kUsage =
    "usage: sirupp-planner-host LIBRARY MODEL ENVIRONMENT PADDING_M TIME_S OUT START... GOAL...\n"
    "Runs a student's C++ planning library on one query for sirupp grade, in the sandbox. Started "
    "by sirupp grade for a planning assignment (include/sirupp/student_planner.h, "
    "docs/grading.md); not for use by hand.\n";

// ---- What the signal handlers may touch (set before the library runs) ----------------------

// The messages are composed before the library runs: a handler only write()s them.
std::string g_timeout_loading, g_timeout_planning, g_past_end, g_before_start;
volatile sig_atomic_t g_planning = 0;
const char* g_guard_low = nullptr;   // the page before the path buffer
const char* g_guard_high = nullptr;  // the page after it
size_t g_page = 4096;

std::string TypeName(const std::type_info& type) {
  int status = 0;
  char* demangled = abi::__cxa_demangle(type.name(), nullptr, nullptr, &status);
  std::string name = status == 0 && demangled != nullptr ? demangled : type.name();
  std::free(demangled);
  return name;
}

void WriteAll(const char* text, size_t size) {
  while (size > 0) {
    const ssize_t wrote = ::write(STDERR_FILENO, text, size);
    if (wrote <= 0) return;
    text += wrote;
    size -= static_cast<size_t>(wrote);
  }
}

void OnAlarm(int) {
  const std::string& text = g_planning ? g_timeout_planning : g_timeout_loading;
  WriteAll(text.data(), text.size());
  ::_exit(1);
}

bool Within(const void* address, const char* page) {
  const char* at = static_cast<const char*>(address);
  return page != nullptr && at >= page && at < page + g_page;
}

void OnFault(int signal, siginfo_t* info, void*) {
  if (Within(info->si_addr, g_guard_high)) WriteAll(g_past_end.data(), g_past_end.size());
  if (Within(info->si_addr, g_guard_low)) WriteAll(g_before_start.data(), g_before_start.size());
  // Die by the signal itself, so the grader names it: back to the default, and the faulting
  // instruction runs again on return.
  struct sigaction default_action {};
  default_action.sa_handler = SIG_DFL;
  ::sigaction(signal, &default_action, nullptr);
}

void InstallHandlers() {
  static char alternate_stack[64 * 1024];  // a stack overflow still reaches OnFault
  stack_t stack{};
  stack.ss_sp = alternate_stack;
  stack.ss_size = sizeof alternate_stack;
  ::sigaltstack(&stack, nullptr);
  struct sigaction fault {};
  fault.sa_sigaction = OnFault;
  fault.sa_flags = SA_SIGINFO | SA_ONSTACK;
  sigemptyset(&fault.sa_mask);
  ::sigaction(SIGSEGV, &fault, nullptr);
  ::sigaction(SIGBUS, &fault, nullptr);
  struct sigaction timeout {};
  timeout.sa_handler = OnAlarm;
  sigemptyset(&timeout.sa_mask);
  ::sigaction(SIGALRM, &timeout, nullptr);
}

void ArmTimer(double seconds) {
  itimerval timer{};
  timer.it_value.tv_sec = static_cast<time_t>(seconds);
  timer.it_value.tv_usec =
      std::max<suseconds_t>(timer.it_value.tv_sec == 0 ? 1 : 0,
                            static_cast<suseconds_t>((seconds - std::floor(seconds)) * 1e6));
  ::setitimer(ITIMER_REAL, &timer, nullptr);
}

void DisarmTimer() {
  itimerval off{};
  ::setitimer(ITIMER_REAL, &off, nullptr);
}

// ---- The scene ---------------------------------------------------------------------------

struct SceneContext {
  planning::CollisionModel* model = nullptr;
  int n = 0;
  std::string misuse;  // the first callback called with bad arguments

  // q as a joint vector, or nullopt (and the misuse noted) when it is not n finite numbers.
  std::optional<core::JointVector> Joints(const char* call, const char* name, const double* q) {
    if (q == nullptr) {
      Misuse(std::string(call) + ": " + name + " is NULL");
      return std::nullopt;
    }
    core::JointVector v(n);
    for (int j = 0; j < n; ++j) {
      v[j] = q[j];
      if (!std::isfinite(q[j])) {
        Misuse(std::string(call) + ": " + name + "[" + std::to_string(j) +
               "] = " + core::FormatNumber(q[j]));
        return std::nullopt;
      }
    }
    return v;
  }
  void Misuse(const std::string& what) {
    if (misuse.empty()) misuse = what;
  }
};

SceneContext* Context(void* context) { return static_cast<SceneContext*>(context); }

int IsFreeCallback(void* context, const double* q) {
  SceneContext* scene = Context(context);
  try {
    const auto v = scene->Joints("is_free", "q", q);
    if (!v) return -1;
    return scene->model->IsFree(*v) ? 1 : 0;
  } catch (const std::exception& error) {
    scene->Misuse(std::string("is_free: ") + error.what());
    return -1;
  }
}

int EdgeFreeCallback(void* context, const double* q0, const double* q1, double step_rad) {
  SceneContext* scene = Context(context);
  try {
    const auto a = scene->Joints("edge_free", "q0", q0);
    if (!a) return -1;
    const auto b = scene->Joints("edge_free", "q1", q1);
    if (!b) return -1;
    if (!(step_rad > 0 && step_rad <= 1)) {
      scene->Misuse("edge_free: step_rad = " + core::FormatNumber(step_rad) +
                    "; allowed more than 0, at most 1");
      return -1;
    }
    return scene->model->CheckEdge(*a, *b, step_rad).free ? 1 : 0;
  } catch (const std::exception& error) {
    scene->Misuse(std::string("edge_free: ") + error.what());
    return -1;
  }
}

int DescribeCallback(void* context, const double* q, char* text, int size) {
  SceneContext* scene = Context(context);
  try {
    if (text == nullptr || size < 1) {
      scene->Misuse("describe: text is NULL or size < 1");
      return -1;
    }
    text[0] = '\0';
    const auto v = scene->Joints("describe", "q", q);
    if (!v) return -1;
    const auto contact = scene->model->FirstContact(*v);
    if (!contact) return 1;
    std::snprintf(text, static_cast<size_t>(size), "%s", scene->model->Describe(*contact).c_str());
    return 0;
  } catch (const std::exception& error) {
    scene->Misuse(std::string("describe: ") + error.what());
    return -1;
  }
}

unsigned long long StatesCheckedCallback(void* context) {  // NOLINT(google-runtime-int): the C ABI
  return Context(context)->model->states_checked();
}

// ---- The path buffer between guard pages -----------------------------------------------------

struct GuardedBuffer {
  void* mapping = MAP_FAILED;
  size_t mapping_size = 0;
  double* data = nullptr;  // its end is the start of the high guard page

  explicit GuardedBuffer(size_t count) {
    g_page = static_cast<size_t>(::sysconf(_SC_PAGESIZE));
    const size_t bytes = count * sizeof(double);
    const size_t pages = (bytes + g_page - 1) / g_page;
    mapping_size = (pages + 2) * g_page;
    mapping =
        ::mmap(nullptr, mapping_size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapping == MAP_FAILED) throw std::runtime_error("cannot map the path buffer");
    char* base = static_cast<char*>(mapping);
    g_guard_low = base;
    g_guard_high = base + (pages + 1) * g_page;
    ::mprotect(base, g_page, PROT_NONE);
    ::mprotect(const_cast<char*>(g_guard_high), g_page, PROT_NONE);
    data = reinterpret_cast<double*>(const_cast<char*>(g_guard_high) - bytes);
    for (size_t i = 0; i < count; ++i) data[i] = std::nan("");
  }
  ~GuardedBuffer() {
    if (mapping != MAP_FAILED) ::munmap(mapping, mapping_size);
  }
  GuardedBuffer(const GuardedBuffer&) = delete;
  GuardedBuffer& operator=(const GuardedBuffer&) = delete;
};

// ---- Arguments ---------------------------------------------------------------------------

bool ReadNumber(const std::string& text, double& value) {
  char* end = nullptr;
  value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size();
}

int Fail(const std::string& line) {
  std::fprintf(stderr, "%s\n", line.c_str());
  return 1;
}

// The usage, then the problem (last, where the grader's log tail shows it).
int Usage(const std::string& problem) {
  std::fprintf(stderr, "%ssirupp-planner-host: %s\n", kUsage, problem.c_str());
  return 2;
}

std::string NameOf(const std::string& library) {
  const size_t slash = library.find_last_of('/');
  return slash == std::string::npos ? library : library.substr(slash + 1);
}

}  // namespace

int RunPlannerHost(const std::vector<std::string>& args) {
  if (args.size() < 8)
    return Usage("expected at least 8 arguments, got " + std::to_string(args.size()));
  const std::string& library = args[0];
  const std::string& model_file = args[1];
  const std::string& environment_file = args[2];
  double padding = 0, time_s = 0;
  if (!ReadNumber(args[3], padding)) return Usage("PADDING_M '" + args[3] + "' is not a number");
  if (!ReadNumber(args[4], time_s) || !(time_s > 0)) {
    return Usage("TIME_S '" + args[4] + "' is not a number > 0");
  }
  const std::string& out_file = args[5];
  std::vector<double> values;
  for (size_t i = 6; i < args.size(); ++i) {
    double value = 0;
    if (!ReadNumber(args[i], value) || !std::isfinite(value)) {
      return Usage("argument " + std::to_string(i + 1) + " '" + args[i] +
                   "' is not a finite number");
    }
    values.push_back(value);
  }

  // The scene, from the project's collision model.
  std::optional<core::RobotModel> model;
  std::optional<planning::CollisionModel> collision;
  try {
    model = core::LoadRobotModel(model_file);
    planning::CollisionOptions options;
    options.padding_m = padding;
    collision.emplace(*model, core::LoadEnvironment(environment_file), options);
  } catch (const std::exception& error) {
    return Usage(error.what());
  }
  const int n = model->num_joints();
  if (values.size() != static_cast<size_t>(2 * n)) {
    return Usage("expected " + std::to_string(2 * n) + " joint values (start, goal) for " +
                 model->name + ", got " + std::to_string(values.size()));
  }
  const core::MotionLimits soft = core::DefaultMotionLimits(*model);
  std::vector<double> lower(static_cast<size_t>(n)), upper(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    lower[static_cast<size_t>(j)] = core::SoftMin(*model, soft, j);
    upper[static_cast<size_t>(j)] = core::SoftMax(*model, soft, j);
  }
  SceneContext context;
  context.model = &*collision;
  context.n = n;
  sirupp_planning_scene scene{};
  scene.abi_version = SIRUPP_PLANNER_ABI_VERSION;
  scene.num_joints = n;
  scene.lower = lower.data();
  scene.upper = upper.data();
  scene.padding_m = padding;
  scene.time_limit_s = time_s;
  scene.context = &context;
  scene.is_free = IsFreeCallback;
  scene.edge_free = EdgeFreeCallback;
  scene.describe = DescribeCallback;
  scene.states_checked = StatesCheckedCallback;

  // The buffers and the messages the handlers write, before any of the library's code runs.
  const std::string name = NameOf(library);
  const std::string limit = core::FormatNumber(time_s) + " s (the suite's limits.plan_s)";
  g_timeout_loading =
      name + ": did not finish loading (its static initializers) within " + limit + "\n";
  g_timeout_planning = "sirupp_plan did not return within " + limit + "\n";
  g_past_end = "sirupp_plan wrote past the end of the path buffer (max_waypoints = " +
               std::to_string(kMaxPlanWaypoints) + " waypoints of " + std::to_string(n) +
               " joints)\n";
  g_before_start = "sirupp_plan wrote before the start of the path buffer\n";
  std::optional<GuardedBuffer> path;
  try {
    path.emplace(static_cast<size_t>(kMaxPlanWaypoints) * static_cast<size_t>(n));
  } catch (const std::exception& error) {
    return Fail(error.what());
  }
  std::vector<char> error_text(kPlanErrorSize, '\0');
  const std::vector<double> start(values.begin(), values.begin() + n);
  const std::vector<double> goal(values.begin() + n, values.end());
  InstallHandlers();

  // Load the library (its static initializers run here) and plan, both within the time limit.
  ArmTimer(time_s);
  void* handle = ::dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = ::dlerror();
    return Fail(name + ": cannot be loaded: " + (why ? why : "dlopen failed"));
  }
  const auto version =
      reinterpret_cast<VersionFunction>(::dlsym(handle, "sirupp_planner_abi_version"));
  if (version == nullptr) {
    return Fail(name +
                ": not a SIRUPP planner: no sirupp_planner_abi_version (write "
                "SIRUPP_PLANNER_ABI() once; include/sirupp/student_planner.h)");
  }
  const int abi = version();
  if (abi != SIRUPP_PLANNER_ABI_VERSION) {
    return Fail(name + ": built against planner ABI version " + std::to_string(abi) +
                "; this grader has version " + std::to_string(SIRUPP_PLANNER_ABI_VERSION) +
                " (rebuild it against this include/sirupp/student_planner.h)");
  }
  const auto plan = reinterpret_cast<PlanFunction>(::dlsym(handle, "sirupp_plan"));
  if (plan == nullptr) {
    return Fail(name + ": no function sirupp_plan (include/sirupp/student_planner.h; in C++ " +
                "its definition must match the header's declaration to be extern \"C\")");
  }

  // The call.
  g_planning = 1;
  int count = -1;
  int code = 0;
  const auto began = std::chrono::steady_clock::now();
  try {
    code = plan(start.data(), goal.data(), n, &scene, path->data, kMaxPlanWaypoints, &count,
                error_text.data(), kPlanErrorSize);
  } catch (const std::exception& error) {
    DisarmTimer();
    return Fail("sirupp_plan threw " + TypeName(typeid(error)) + ": " + error.what());
  } catch (...) {
    DisarmTimer();
    return Fail("sirupp_plan threw an exception that is not a std::exception");
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  DisarmTimer();
  g_planning = 0;
  error_text.back() = '\0';
  const std::string misuse =
      context.misuse.empty() ? "" : " (the first bad scene call: " + context.misuse + ")";
  if (code != SIRUPP_PLAN_OK) {
    const std::string why = error_text[0] != '\0' ? error_text.data() : "no error text";
    return Fail("sirupp_plan returned " + std::to_string(code) + ": " + why + misuse);
  }
  if (count < 1 || count > kMaxPlanWaypoints) {
    return Fail("sirupp_plan returned " +
                (count == -1 ? std::string("without setting *num_waypoints")
                             : "*num_waypoints = " + std::to_string(count)) +
                "; allowed 1 to " + std::to_string(kMaxPlanWaypoints) + " (max_waypoints)" +
                misuse);
  }
  FILE* out = std::fopen(out_file.c_str(), "w");
  if (out == nullptr) return Fail("cannot write " + out_file + ": " + std::strerror(errno));
  std::fprintf(out, "# seconds %.17g\n", seconds);
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < n; ++j) {
      std::fprintf(out, j ? " %.17g" : "%.17g", path->data[static_cast<size_t>(i * n + j)]);
    }
    std::fputc('\n', out);
  }
  if (std::fclose(out) != 0) return Fail("cannot write " + out_file + ": " + std::strerror(errno));
  return 0;
}

}  // namespace sirupp::grade
