#include "panel/model_edit.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/printable.hpp"

namespace sirupp::panel {
namespace {

// The end of the value that starts at `begin`: a flow sequence to its closing bracket, a plain
// scalar to the next separator (',', ']', '}', '#', end of line), trailing blanks dropped.
size_t ValueEnd(const std::string& text, size_t begin) {
  if (begin < text.size() && text[begin] == '[') {
    const size_t close = text.find(']', begin);
    return close == std::string::npos ? text.size() : close + 1;
  }
  size_t end = text.find_first_of(",]}#\r\n", begin);
  if (end == std::string::npos) end = text.size();
  while (end > begin && (text[end - 1] == ' ' || text[end - 1] == '\t')) --end;
  return end;
}

void Add(std::vector<ModelField>& fields, const std::string& text, const YAML::Node& node,
         const std::string& key, const std::string& group) {
  if (!node || !(node.IsScalar() || node.IsSequence())) return;
  const YAML::Mark mark = node.Mark();
  if (mark.pos < 0 || static_cast<size_t>(mark.pos) >= text.size()) return;
  ModelField field;
  field.key = key;
  field.group = group;
  field.begin = static_cast<size_t>(mark.pos);
  field.end = ValueEnd(text, field.begin);
  field.text = text.substr(field.begin, field.end - field.begin);
  field.line = mark.line + 1;
  // Only values written in one piece on one line (no block sequences, no aliases to elsewhere).
  if (field.text.empty() || field.text.find('\n') != std::string::npos || field.text[0] == '*' ||
      field.text[0] == '&') {
    return;
  }
  fields.push_back(field);
}

bool IsNumber(const std::string& text) {
  if (text.empty() || text.size() > 40) return false;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size() && std::isfinite(value);
}

std::string Trim(const std::string& text) {
  const size_t a = text.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  const size_t b = text.find_last_not_of(" \t");
  return text.substr(a, b - a + 1);
}

}  // namespace

std::vector<ModelField> EditableFields(const std::string& text, const std::string& file_name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& error) {
    throw core::ConfigError(
        core::SourceLocation{file_name, error.mark.line + 1, error.mark.column + 1}, "",
        "not YAML: " + error.msg);
  }
  std::vector<ModelField> fields;
  if (!root.IsMap()) return fields;
  if (root["dh"] && root["dh"].IsSequence()) {
    for (size_t i = 0; i < root["dh"].size(); ++i) {
      const YAML::Node row = root["dh"][i];
      if (!row.IsMap()) continue;
      for (const char* key : {"alpha", "a", "d", "theta"}) {
        Add(fields, text, row[key], "dh[" + std::to_string(i) + "]." + key, "dh");
      }
    }
  }
  if (root["joints"] && root["joints"].IsSequence()) {
    for (size_t i = 0; i < root["joints"].size(); ++i) {
      const YAML::Node joint = root["joints"][i];
      if (!joint.IsMap()) continue;
      const std::string base = "joints[" + std::to_string(i) + "]";
      const YAML::Node limits = joint["limits"];
      if (limits && limits.IsSequence() && limits.size() == 2) {
        Add(fields, text, limits[0], base + ".limits[0]", "joints");
        Add(fields, text, limits[1], base + ".limits[1]", "joints");
      }
      Add(fields, text, joint["max_velocity"], base + ".max_velocity", "joints");
      Add(fields, text, joint["max_effort"], base + ".max_effort", "joints");
      const YAML::Node friction = joint["friction"];
      if (friction && friction.IsMap()) {
        for (const char* key : {"static", "coulomb", "viscous"}) {
          Add(fields, text, friction[key], base + ".friction." + key, "joints");
        }
      }
    }
  }
  if (root["links"] && root["links"].IsSequence()) {
    for (size_t i = 0; i < root["links"].size(); ++i) {
      const YAML::Node link = root["links"][i];
      if (!link.IsMap()) continue;
      Add(fields, text, link["mass_kg"], "links[" + std::to_string(i) + "].mass_kg", "links");
    }
  }
  // A value reached twice (an alias) is left out: editing it would change both places.
  std::map<size_t, int> uses;
  for (const ModelField& field : fields) ++uses[field.begin];
  fields.erase(std::remove_if(fields.begin(), fields.end(),
                              [&](const ModelField& field) { return uses[field.begin] > 1; }),
               fields.end());
  return fields;
}

std::string ApplyModelEdits(const std::string& text, const std::vector<ModelField>& fields,
                            const std::map<std::string, std::string>& edits) {
  std::vector<std::pair<const ModelField*, std::string>> changes;
  for (const auto& [key, raw] : edits) {
    const auto it = std::find_if(fields.begin(), fields.end(),
                                 [&](const ModelField& field) { return field.key == key; });
    if (it == fields.end()) {
      throw std::invalid_argument("edits." + core::Printable(key, 80) +
                                  ": not an editable value of this model file");
    }
    const std::string value = Trim(raw);
    bool ok = IsNumber(value);
    std::string written = value;
    const bool pair_allowed = key.size() > 18 && key.rfind(".friction.coulomb") == key.size() - 17;
    if (!ok && pair_allowed && value.size() > 2 && value.front() == '[' && value.back() == ']') {
      const std::string inner = value.substr(1, value.size() - 2);
      const size_t comma = inner.find(',');
      if (comma != std::string::npos && inner.find(',', comma + 1) == std::string::npos) {
        const std::string a = Trim(inner.substr(0, comma));
        const std::string b = Trim(inner.substr(comma + 1));
        ok = IsNumber(a) && IsNumber(b);
        written = "[" + a + ", " + b + "]";
      }
    }
    if (!ok) {
      throw std::invalid_argument(
          "edits." + key + ": '" + core::Printable(raw, 40) + "' is not " +
          (pair_allowed ? "a number or [positive, negative] numbers" : "a finite number"));
    }
    changes.emplace_back(&*it, written);
  }
  // From the end of the text backwards, so earlier spans keep their offsets.
  std::sort(changes.begin(), changes.end(),
            [](const auto& x, const auto& y) { return x.first->begin > y.first->begin; });
  std::string out = text;
  for (const auto& [field, value] : changes) {
    out.replace(field->begin, field->end - field->begin, value);
  }
  return out;
}

ModelCheck CheckModelText(const std::string& text, const std::string& file_name,
                          const std::vector<ModelField>& fields) {
  ModelCheck check;
  try {
    check.model_name = core::ParseRobotModel(text, file_name).name;
  } catch (const core::ConfigError& error) {
    check.ok = false;
    check.error = error.what();
    check.line = error.where().line;
    check.key_path = error.key_path();
    // The edited value the error names: the longest field key the key path starts with, else
    // the only field on the error's line.
    size_t best = 0;
    for (const ModelField& field : fields) {
      const std::string& key = field.key;
      if (check.key_path.rfind(key, 0) == 0 && key.size() > best &&
          (check.key_path.size() == key.size() || check.key_path[key.size()] == '.' ||
           check.key_path[key.size()] == '[')) {
        best = key.size();
        check.field = key;
      }
    }
    if (check.field.empty()) {
      std::vector<std::string> on_line;
      for (const ModelField& field : fields) {
        if (field.line == check.line) on_line.push_back(field.key);
      }
      if (on_line.size() == 1) check.field = on_line[0];
    }
  }
  return check;
}

void CheckModelFileName(const std::string& name) {
  const bool ok =
      !name.empty() && name.size() <= 60 && std::all_of(name.begin(), name.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
               c == '_' || c == '-';
      });
  if (!ok) {
    throw std::invalid_argument("name '" + core::Printable(name, 60) +
                                "': allowed 1 to 60 letters, digits, '_' and '-' (the file "
                                "becomes config/robots/NAME.yaml)");
  }
}

}  // namespace sirupp::panel
