#include "class/class_config.hpp"

#include <algorithm>
#include <filesystem>
#include <set>

#include "core/errors.hpp"
#include "core/yaml_reader.hpp"
#include "grade/suite.hpp"
#include "runtime/data_path.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kTopKeys = {"class",    "description", "robot",   "students",
                                           "data",     "limits",      "server",  "rigs",
                                           "real_arm", "grading",     "cluster", "notebooks"};
const std::vector<std::string> kLimitKeys = {"max_rigs", "idle_timeout_s", "rig_memory_mb",
                                             "rig_nice", "pin_rigs"};
const std::vector<std::string> kServerKeys = {"listen",         "port",
                                              "public_url",     "tls_cert",
                                              "tls_key",        "request_timeout_s",
                                              "keep_alive_s",   "connections_per_address",
                                              "max_connections"};
const std::vector<std::string> kRigKeys = {"first_port", "port_count", "pace_ticks"};
const std::vector<std::string> kRealArmKeys = {"lcm_url", "turn_s", "warn_before_s",
                                               "home_tolerance_deg", "home_speed_fraction"};

// The udpm port of an LCM address "udpm://GROUP:PORT?...", or -1.
int UdpmPort(const std::string& url) {
  const std::string scheme = "udpm://";
  if (url.rfind(scheme, 0) != 0) return -1;
  const size_t colon = url.find(':', scheme.size());
  if (colon == std::string::npos) return -1;
  const size_t end = url.find('?', colon);
  const std::string digits =
      url.substr(colon + 1, end == std::string::npos ? end : end - colon - 1);
  if (digits.empty() || digits.size() > 5 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return -1;
  }
  const int port = std::stoi(digits);
  return port >= 1 && port <= 65535 ? port : -1;
}

RealArmConfig ReadRealArm(const core::YamlValue& value, const ClassConfig& config) {
  const core::YamlMap map = value.Map(kRealArmKeys);
  RealArmConfig arm;
  const core::YamlValue url =
      map.Get("lcm_url", "the bus of sirupp-hardware (udpm://GROUP:PORT?ttl=0)");
  arm.lcm_url = url.String();
  const int port = UdpmPort(arm.lcm_url);
  if (port < 0) {
    url.Fail("'" + arm.lcm_url +
             "' is not a udpm address; expected udpm://GROUP:PORT?ttl=0 (the bus sirupp-hardware "
             "runs on)");
  }
  if (port >= config.first_port && port < config.first_port + config.port_count) {
    url.Fail("port " + std::to_string(port) +
             " is one the rigs lease (rigs: " + std::to_string(config.first_port) + ".." +
             std::to_string(config.first_port + config.port_count - 1) +
             "); give the real arm's bus a port outside that range");
  }
  arm.turn_s = map.NumberOr("turn_s", arm.turn_s, core::NumberInRange(5, 86400, "s"));
  if (const auto warn = map.Find("warn_before_s")) {
    arm.warn_before_s.clear();
    for (const core::YamlValue& entry : warn->Sequence(0, 10)) {
      const double s = entry.Number(core::NumberInRange(0.5, 86400, "s"));
      if (s >= arm.turn_s) {
        entry.Fail("a warning " + core::FormatApprox(s) + " s before the end of a " +
                   core::FormatApprox(arm.turn_s) + " s turn; allowed: less than turn_s");
      }
      arm.warn_before_s.push_back(s);
    }
  }
  arm.home_tolerance_deg = map.NumberOr("home_tolerance_deg", arm.home_tolerance_deg,
                                        core::NumberInRange(0.05, 10, "deg"));
  arm.home_speed_fraction = map.NumberOr("home_speed_fraction", arm.home_speed_fraction,
                                         core::NumberInRange(0.05, 1, ""));
  return arm;
}
const std::vector<std::string> kNotebookKeys = {
    "hub_url", "hub_port", "folder", "idle_timeout_s", "memory_mb", "processes", "assignments"};
const std::vector<std::string> kAssignmentKeys = {"name", "notebook", "tests", "timeout_s",
                                                  "memory_mb"};
const std::vector<std::string> kGradingKeys = {"suite", "safety_tasks", "max_source_kb"};

std::string CheckedName(const core::YamlValue& value, const std::string& what) {
  const std::string text = value.String();
  if (!IsValidName(text)) {
    value.Fail(
        "'" + text + "' is not a valid " + what +
        "; allowed: 1 to 32 letters, digits, '-', '_' and '.', not starting with '.' or '-'");
  }
  return text;
}

std::string Absolute(const std::string& path, const std::string& base_dir) {
  const fs::path p(path);
  if (p.is_absolute()) return p.lexically_normal().string();
  return (fs::absolute(fs::path(base_dir)) / p).lexically_normal().string();
}

// A file that must exist: relative to the class file's folder, else (robot models) the source tree.
std::string ExistingFile(const core::YamlValue& value, const std::string& base_dir,
                         bool data_fallback) {
  const std::string text = value.String();
  std::string path = Absolute(text, base_dir);
  if (!fs::is_regular_file(path) && data_fallback && !fs::path(text).is_absolute()) {
    const std::string resolved = runtime::ResolveDataPath(text);
    if (fs::is_regular_file(resolved)) path = fs::absolute(resolved).lexically_normal().string();
  }
  if (!fs::is_regular_file(path)) {
    value.Fail("'" + text + "': no such file (looked for " + path + ")");
  }
  return path;
}

// grading: {suite, safety_tasks, max_source_kb}. The suite is read here, so a bad suite or a
// safety task it does not have stops `sirupp class check` rather than the first submission.
void ReadGrading(const core::YamlValue& value, const std::string& base_dir, ClassConfig& config) {
  const core::YamlMap map = value.Map(kGradingKeys);
  const core::YamlValue suite = map.Get("suite", "a grading suite file (config/grading/*.yaml)");
  config.grading_suite = ExistingFile(suite, base_dir, true);
  grade::Suite loaded;
  try {
    loaded = grade::LoadSuite(config.grading_suite, &runtime::ResolveDataPath);
  } catch (const std::exception& e) {
    suite.Fail("the suite '" + suite.String() + "' does not load: " + e.what());
  }
  std::vector<std::string> names;
  for (const grade::Task& task : loaded.tasks) names.push_back(task.name);
  if (const auto safety = map.Find("safety_tasks")) {
    for (const core::YamlValue& entry : safety->Sequence(1, 1000)) {
      const std::string name = entry.String();
      if (std::find(names.begin(), names.end(), name) == names.end()) {
        std::string allowed;
        for (const std::string& n : names) allowed += (allowed.empty() ? "" : ", ") + n;
        entry.Fail("'" + name + "' is not a task of " + loaded.name + "; allowed: " + allowed);
      }
      if (std::find(config.safety_tasks.begin(), config.safety_tasks.end(), name) !=
          config.safety_tasks.end()) {
        entry.Fail("safety task '" + name + "' is listed twice");
      }
      config.safety_tasks.push_back(name);
    }
  } else {
    config.safety_tasks = names;
  }
  if (const auto v = map.Find("max_source_kb")) {
    config.max_source_kb = static_cast<int>(v->Integer(1, 900));
  }
}

// A folder that must exist: relative to the class file's folder, else the source tree.
std::string ExistingFolder(const core::YamlValue& value, const std::string& base_dir) {
  const std::string text = value.String();
  std::string path = Absolute(text, base_dir);
  if (!fs::is_directory(path) && !fs::path(text).is_absolute()) {
    const std::string resolved = runtime::ResolveDataPath(text);
    if (fs::is_directory(resolved)) path = fs::absolute(resolved).lexically_normal().string();
  }
  if (!fs::is_directory(path))
    value.Fail("'" + text + "': no such folder (looked for " + path + ")");
  return path;
}

// notebooks: {hub_url, hub_port, folder, idle_timeout_s, memory_mb, processes, assignments}.
NotebooksConfig ReadNotebooks(const core::YamlValue& value, const std::string& base_dir,
                              const ClassConfig& config) {
  const core::YamlMap map = value.Map(kNotebookKeys);
  NotebooksConfig notebooks;
  if (const auto v = map.Find("hub_url")) {
    std::string url = v->String();
    if (url.rfind("http://", 0) != 0 && url.rfind("https://", 0) != 0) {
      v->Fail("'" + url + "' is not an address; expected http://HOST[:PORT] or https://...");
    }
    while (!url.empty() && url.back() == '/') url.pop_back();
    if (!config.public_url.empty() && url == config.public_url) {
      v->Fail("'" + url +
              "' is the class server's own address; the hub needs a hostname of its "
              "own (JupyterHub 3.0, CVE-2024-28233)");
    }
    notebooks.hub_url = url;
  }
  if (const auto v = map.Find("hub_port")) {
    notebooks.hub_port = static_cast<int>(v->Integer(1024, 65535));
    if (notebooks.hub_port == config.port) {
      v->Fail("port " + std::to_string(config.port) + " is the class server's own (server.port)");
    }
  }
  if (const auto v = map.Find("folder")) {
    notebooks.folder = ExistingFolder(*v, base_dir);
  } else {
    notebooks.folder =
        fs::absolute(runtime::ResolveDataPath("notebooks")).lexically_normal().string();
  }
  notebooks.idle_timeout_s = map.NumberOr("idle_timeout_s", notebooks.idle_timeout_s,
                                          core::NumberInRange(60, 7 * 86400, "s"));
  if (const auto v = map.Find("memory_mb")) {
    notebooks.memory_mb = static_cast<int>(v->Integer(512, 1 << 20));
  }
  if (const auto v = map.Find("processes")) {
    notebooks.processes = static_cast<int>(v->Integer(16, 4096));
  }
  if (const auto list = map.Find("assignments")) {
    std::set<std::string> names;
    for (const core::YamlValue& entry : list->Sequence(0, 100)) {
      const core::YamlMap a = entry.Map(kAssignmentKeys);
      NotebookAssignment assignment;
      const core::YamlValue name = a.Get("name", "the assignment's name");
      assignment.name = CheckedName(name, "assignment name");
      if (!names.insert(assignment.name).second) {
        name.Fail("assignment '" + assignment.name + "' is listed twice");
      }
      assignment.notebook =
          ExistingFile(a.Get("notebook", "the assignment's notebook (.ipynb)"), base_dir, true);
      assignment.tests =
          ExistingFile(a.Get("tests", "the hidden tests (a Python file)"), base_dir, true);
      assignment.timeout_s =
          a.NumberOr("timeout_s", assignment.timeout_s, core::NumberInRange(5, 3600, "s"));
      if (const auto v = a.Find("memory_mb")) {
        assignment.memory_mb = static_cast<int>(v->Integer(512, 1 << 20));
      }
      notebooks.assignments.push_back(assignment);
    }
  }
  return notebooks;
}

ClassConfig Read(const core::YamlDocument& document, const std::string& base_dir) {
  ClassConfig config;
  config.file = document.file();
  const core::YamlMap top = document.Root().Map(kTopKeys);
  config.name = CheckedName(top.Get("class", "the class's name"), "class name");
  config.description = top.StringOr("description", "");
  config.robot = ExistingFile(top.Get("robot", "a robot model file"), base_dir, true);
  std::set<std::string> seen;
  for (const core::YamlValue& entry :
       top.Get("students", "a list of student names").Sequence(1, 1000)) {
    const std::string name = CheckedName(entry, "student name");
    if (name == kTeacher) entry.Fail("'teacher' is reserved for the teacher's token");
    if (!seen.insert(name).second) entry.Fail("student '" + name + "' is listed twice");
    config.students.push_back(name);
  }
  config.data_dir = Absolute(top.Get("data", "the class's data folder").String(), base_dir);
  if (const auto limits = top.Find("limits")) {
    const core::YamlMap map = limits->Map(kLimitKeys);
    if (const auto v = map.Find("max_rigs"))
      config.max_rigs = static_cast<int>(v->Integer(1, 1000));
    config.idle_timeout_s =
        map.NumberOr("idle_timeout_s", config.idle_timeout_s, core::NumberInRange(1, 86400, "s"));
    if (const auto v = map.Find("rig_memory_mb")) {
      config.rig_memory_mb = static_cast<int>(v->Integer(0, 1 << 20));
      if (config.rig_memory_mb != 0 && config.rig_memory_mb < 256) {
        v->Fail(std::to_string(config.rig_memory_mb) +
                " MiB is too little for a rig process; allowed: 0 (no limit) or >= 256");
      }
    }
    if (const auto v = map.Find("rig_nice")) config.rig_nice = static_cast<int>(v->Integer(0, 19));
    if (const auto v = map.Find("pin_rigs")) config.pin_rigs = v->Bool();
  }
  if (const auto server = top.Find("server")) {
    std::vector<std::string> server_keys = kServerKeys;
    server_keys.insert(server_keys.end(), FrontConfigKeys().begin(), FrontConfigKeys().end());
    const core::YamlMap map = server->Map(server_keys);
    config.front = ReadFrontConfig(map, base_dir);
    config.listen = map.StringOr("listen", config.listen);
    if (const auto v = map.Find("port")) config.port = static_cast<int>(v->Integer(0, 65535));
    config.http.request_timeout_s = map.NumberOr("request_timeout_s", config.http.request_timeout_s,
                                                 core::NumberInRange(1, 600, "s"));
    config.http.keep_alive_s =
        map.NumberOr("keep_alive_s", config.http.keep_alive_s, core::NumberInRange(1, 300, "s"));
    if (const auto v = map.Find("max_connections")) {
      config.http.max_connections = static_cast<int>(v->Integer(16, 900));
    }
    if (const auto v = map.Find("connections_per_address")) {
      config.http.connections_per_address =
          static_cast<int>(v->Integer(2, config.http.max_connections / 2));
    } else {
      config.http.connections_per_address =
          std::min(config.http.connections_per_address, config.http.max_connections / 2);
    }
    if (const auto v = map.Find("public_url")) {
      std::string url = v->String();
      if (url.rfind("http://", 0) != 0 && url.rfind("https://", 0) != 0) {
        v->Fail("'" + url + "' is not an address; expected http://HOST[:PORT] or https://...");
      }
      while (!url.empty() && url.back() == '/') url.pop_back();
      config.public_url = url;
    }
    const auto cert = map.Find("tls_cert");
    const auto key = map.Find("tls_key");
    if (cert.has_value() != key.has_value()) {
      (cert ? *cert : *key).Fail("tls_cert and tls_key go together; give both or neither");
    }
    if (cert) {
      config.tls_cert = ExistingFile(*cert, base_dir, false);
      config.tls_key = ExistingFile(*key, base_dir, false);
    }
  }
  if (const auto rigs = top.Find("rigs")) {
    const core::YamlMap map = rigs->Map(kRigKeys);
    if (const auto v = map.Find("first_port")) {
      config.first_port = static_cast<int>(v->Integer(1024, 65000));
    }
    if (const auto v = map.Find("port_count")) {
      config.port_count = static_cast<int>(v->Integer(1, 10000));
      if (config.first_port + config.port_count > 65536) {
        v->Fail(std::to_string(config.port_count) + " ports from " +
                std::to_string(config.first_port) + " pass 65535");
      }
    }
    if (const auto v = map.Find("pace_ticks")) {
      config.pace_ticks = static_cast<int>(v->Integer(1, 64));
    }
  }
  if (const auto grading = top.Find("grading")) ReadGrading(*grading, base_dir, config);
  if (config.port_count < config.max_rigs) {
    document.Root().Fail("limits.max_rigs " + std::to_string(config.max_rigs) +
                         " is more than rigs.port_count " + std::to_string(config.port_count) +
                         "; each rig needs a port of its own");
  }
  if (const auto arm = top.Find("real_arm")) config.real_arm = ReadRealArm(*arm, config);
  if (const auto jobs = top.Find("cluster")) config.cluster = cluster::ReadClusterConfig(*jobs);
  if (const auto notebooks = top.Find("notebooks")) {
    config.notebooks = ReadNotebooks(*notebooks, base_dir, config);
  }
  return config;
}

}  // namespace

bool IsValidName(const std::string& name) {
  if (name.empty() || name.size() > 32 || name[0] == '.' || name[0] == '-') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
           c == '_' || c == '.';
  });
}

ClassConfig LoadClassConfig(const std::string& file) {
  const std::string base = fs::absolute(fs::path(file)).parent_path().string();
  return Read(core::YamlDocument::Load(file), base);
}

ClassConfig ParseClassConfig(const std::string& text, const std::string& name,
                             const std::string& base_dir) {
  return Read(core::YamlDocument::Parse(text, name), base_dir);
}

std::string BaseUrl(const ClassConfig& config, int port) {
  if (!config.public_url.empty()) return config.public_url;
  const std::string scheme = config.tls_cert.empty() ? "http" : "https";
  std::string host = config.listen;
  if (host == "0.0.0.0" || host == "::") host = "localhost";
  return scheme + "://" + host + ":" + std::to_string(port);
}

}  // namespace sirupp::classroom
