#include "launch/layout.hpp"

#include <algorithm>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/yaml_reader.hpp"

namespace sirupp::launch {
namespace {

const std::vector<std::string> kTopKeys = {"lab", "description", "lcm_url", "prefix", "processes"};
const std::vector<std::string> kProcessKeys = {"name",
                                               "host",
                                               "run",
                                               "lcm",
                                               "ready",
                                               "ready_file",
                                               "ready_timeout_s",
                                               "restart",
                                               "max_restarts",
                                               "critical",
                                               "stop_timeout_s"};

bool IsNameChar(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
         c == '_' || c == '.';
}

std::string CheckedName(const core::YamlValue& value, const std::string& what) {
  const std::string text = value.String();
  if (!std::all_of(text.begin(), text.end(), IsNameChar)) {
    value.Fail("'" + text + "' is not a valid " + what +
               "; allowed: letters, digits, '-', '_' and '.'");
  }
  return text;
}

// `run` is a line of words split at spaces, or a list of words (for an argument with spaces).
std::vector<std::string> ReadCommand(const core::YamlValue& value) {
  std::vector<std::string> words;
  if (value.node().IsSequence()) {
    for (const core::YamlValue& word : value.Sequence(1)) words.push_back(word.String());
  } else {
    std::istringstream in(value.String());
    for (std::string word; in >> word;) words.push_back(word);
  }
  if (words.empty()) value.Fail("an empty command; expected a program and its arguments");
  return words;
}

bool IsPrefixChar(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
}

Layout Read(const core::YamlDocument& document) {
  Layout layout;
  layout.file = document.file();
  const core::YamlMap top = document.Root().Map(kTopKeys);
  layout.lab = CheckedName(top.Get("lab", "the layout's name"), "lab name");
  layout.description = top.StringOr("description", "");
  if (const auto url = top.Find("lcm_url")) {
    layout.lcm_url = url->String();
    if (layout.lcm_url.rfind("udpm://", 0) != 0 && layout.lcm_url.rfind("memq://", 0) != 0) {
      url->Fail("'" + layout.lcm_url + "' is not an LCM URL this launcher can share; allowed: " +
                "udpm://GROUP:PORT?ttl=N (or memq:// for one process)");
    }
  }
  if (const auto prefix = top.Find("prefix")) {
    if (!prefix->IsNull()) {
      const std::string text = prefix->node().as<std::string>();
      if (!std::all_of(text.begin(), text.end(), IsPrefixChar)) {
        prefix->Fail("'" + text + "' is not a channel prefix; allowed: letters, digits and '_'");
      }
      layout.prefix = text;
    }
  }
  const core::YamlValue processes = top.Get("processes", "a list of processes");
  std::set<std::string> names;
  for (const core::YamlValue& entry : processes.Sequence(1)) {
    const core::YamlMap map = entry.Map(kProcessKeys);
    ProcessSpec spec;
    spec.line = entry.location().line;
    const core::YamlValue name = map.Get("name", "the process's name");
    spec.name = CheckedName(name, "process name");
    if (!names.insert(spec.name).second) {
      name.Fail("process name '" + spec.name + "' is used twice; each name must be unique");
    }
    spec.host = "local";
    if (const auto host = map.Find("host")) spec.host = CheckedName(*host, "host name");
    spec.command = ReadCommand(map.Get("run", "a program and its arguments"));
    if (const auto lcm = map.Find("lcm")) spec.lcm = lcm->Bool();
    spec.ready = spec.lcm ? Ready::kHeartbeat : Ready::kStarted;
    if (const auto ready = map.Find("ready")) {
      const std::string choice = ready->Choice({"heartbeat", "started", "file"});
      spec.ready = choice == "heartbeat" ? Ready::kHeartbeat
                   : choice == "file"    ? Ready::kFile
                                         : Ready::kStarted;
      if (spec.ready == Ready::kHeartbeat && !spec.lcm) {
        ready->Fail("'heartbeat' needs lcm: true (a process without LCM sends no heartbeat)");
      }
    }
    if (const auto file = map.Find("ready_file")) {
      if (spec.ready != Ready::kFile) file->Fail("ready_file is only used with ready: file");
      spec.ready_file = file->String();
    } else if (spec.ready == Ready::kFile) {
      map.Get("ready_file", "the path whose existence means ready (with ready: file)");
    }
    spec.ready_timeout_s =
        map.NumberOr("ready_timeout_s", spec.ready_timeout_s, core::NumberInRange(0.1, 600, "s"));
    if (const auto restart = map.Find("restart")) {
      const std::string choice = restart->Choice({"never", "on-failure", "always"});
      spec.restart = choice == "always"       ? Restart::kAlways
                     : choice == "on-failure" ? Restart::kOnFailure
                                              : Restart::kNever;
    }
    if (const auto max = map.Find("max_restarts")) {
      spec.max_restarts = static_cast<int>(max->Integer(0, 1000));
    }
    if (const auto critical = map.Find("critical")) spec.critical = critical->Bool();
    spec.stop_timeout_s =
        map.NumberOr("stop_timeout_s", spec.stop_timeout_s, core::NumberInRange(0.1, 120, "s"));
    if (std::find(layout.hosts.begin(), layout.hosts.end(), spec.host) == layout.hosts.end()) {
      layout.hosts.push_back(spec.host);
    }
    layout.processes.push_back(std::move(spec));
  }
  return layout;
}

}  // namespace

std::vector<ProcessSpec> Layout::ProcessesOn(const std::string& host) const {
  std::vector<ProcessSpec> out;
  for (const ProcessSpec& p : processes) {
    if (p.host == host) out.push_back(p);
  }
  return out;
}

Layout LoadLayout(const std::string& file) { return Read(core::YamlDocument::Load(file)); }

Layout ParseLayout(const std::string& text, const std::string& name) {
  return Read(core::YamlDocument::Parse(text, name));
}

std::string ChooseHost(const Layout& layout, const std::string& wanted,
                       const std::string& machine_name) {
  std::string list;
  for (const std::string& h : layout.hosts) list += (list.empty() ? "" : ", ") + h;
  if (!wanted.empty()) {
    if (std::find(layout.hosts.begin(), layout.hosts.end(), wanted) != layout.hosts.end()) {
      return wanted;
    }
    throw core::UsageError("--host " + wanted + ": not a host of " + layout.file +
                           "; its hosts: " + list);
  }
  if (layout.hosts.size() == 1) return layout.hosts.front();
  if (std::find(layout.hosts.begin(), layout.hosts.end(), machine_name) != layout.hosts.end()) {
    return machine_name;
  }
  throw core::UsageError(layout.file + " has several hosts (" + list + ") and none is named '" +
                         machine_name + "' like this machine; choose one with --host NAME");
}

std::string Expand(const std::string& text,
                   const std::vector<std::pair<std::string, std::string>>& variables) {
  std::string out;
  size_t i = 0;
  while (i < text.size()) {
    const size_t start = text.find("${", i);
    if (start == std::string::npos) {
      out += text.substr(i);
      break;
    }
    out += text.substr(i, start - i);
    const size_t end = text.find('}', start);
    if (end == std::string::npos) {
      throw std::invalid_argument("'" + text + "': '${' without a closing '}'");
    }
    const std::string name = text.substr(start + 2, end - start - 2);
    const auto found = std::find_if(variables.begin(), variables.end(),
                                    [&](const auto& v) { return v.first == name; });
    if (found == variables.end()) {
      std::string known;
      for (const auto& v : variables) known += (known.empty() ? "" : ", ") + ("${" + v.first + "}");
      throw std::invalid_argument("'" + text + "': unknown variable ${" + name +
                                  "}; known: " + known);
    }
    out += found->second;
    i = end + 1;
  }
  return out;
}

const char* RestartName(Restart restart) {
  switch (restart) {
    case Restart::kNever:
      return "never";
    case Restart::kOnFailure:
      return "on-failure";
    case Restart::kAlways:
      return "always";
  }
  return "?";
}

}  // namespace sirupp::launch
