#pragma once
// Strict reading of YAML configuration files. Every value is read through YamlValue/YamlMap, which
// know the key path ("joints[2].friction.static_nm") and the file:line:column of each node, so any
// problem becomes one ConfigError naming the place, the bad value and what is allowed. Unknown
// keys, duplicate keys, wrong types, missing keys and non-finite numbers are all errors.
//
// Paths count list entries from 0, like YAML and JSON tools do. YAML merge keys ("<<: *anchor", or
// a list of anchors) are resolved here, since yaml-cpp 0.7 leaves them as a literal "<<" key: keys
// written in the mapping override merged ones, and an earlier anchor in a list overrides a later
// one.
//
// A document is refused on load when it expands to more than kMaxYamlNodes nodes, counting every
// use of an alias (and so every merge) as a copy of what it names, or nests deeper than
// kMaxYamlDepth: a ten-line "billion laughs" of aliases or merge keys would otherwise keep every
// reader busy for minutes. Configuration files are far below both limits.

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/errors.hpp"

namespace sirupp::core {

// Limits on a YAML document's size after alias and merge-key expansion, and on its nesting.
inline constexpr size_t kMaxYamlNodes = 250000;
inline constexpr int kMaxYamlDepth = 100;

// What numbers a field allows, written into error messages ("a number > 0 (kg)").
struct NumberRule {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_inclusive = true;
  bool max_inclusive = true;
  std::string unit;  // shown in messages; empty for plain numbers

  bool Allows(double value) const;
  std::string Describe() const;  // e.g. "a finite number > 0 (kg)"
};
NumberRule AnyNumber(std::string unit = "");
NumberRule PositiveNumber(std::string unit = "");
NumberRule NonNegativeNumber(std::string unit = "");
NumberRule NumberInRange(double min, double max, std::string unit = "");

class YamlMap;

// Shared by all values of one document: the file name and where each key path was found.
struct YamlContext {
  std::string file;
  std::map<std::string, YAML::Mark> locations;
};

class YamlValue {
 public:
  YamlValue(YAML::Node node, std::string path, std::shared_ptr<YamlContext> context);

  const std::string& path() const { return path_; }
  SourceLocation location() const;
  const YAML::Node& node() const { return node_; }
  // A value below this one (an entry of this list or mapping) at `child_path`.
  YamlValue Child(const YAML::Node& child, const std::string& child_path) const;

  // Throws ConfigError at this node with the given problem text.
  [[noreturn]] void Fail(const std::string& problem) const;

  bool IsNull() const { return node_.IsNull(); }
  double Number(const NumberRule& rule) const;
  int64_t Integer(int64_t min, int64_t max) const;
  bool Bool() const;
  std::string String() const;  // a non-empty text scalar
  std::string Choice(const std::vector<std::string>& allowed) const;
  std::vector<YamlValue> Sequence(size_t min_size = 0,
                                  size_t max_size = std::numeric_limits<size_t>::max()) const;
  // A list of exactly `count` numbers, each checked against `rule`.
  std::vector<double> Numbers(size_t count, const NumberRule& rule) const;
  // A mapping whose keys must all be in `allowed_keys` (and appear once).
  YamlMap Map(const std::vector<std::string>& allowed_keys) const;
  // A mapping with free-form keys (names chosen by the user), in file order; keys appear once.
  std::vector<std::pair<std::string, YamlValue>> Entries() const;

  // How the value appears in the file, for error messages: the scalar text, "a mapping", "a list".
  std::string Describe() const;

 private:
  YAML::Node node_;
  std::string path_;
  std::shared_ptr<YamlContext> context_;
};

class YamlMap {
 public:
  YamlMap(YamlValue self, std::vector<std::string> allowed_keys);

  const YamlValue& self() const { return self_; }
  bool Has(const std::string& key) const;
  // A required key; `expected` describes the value in the "missing required key" message.
  YamlValue Get(const std::string& key, const std::string& expected) const;
  std::optional<YamlValue> Find(const std::string& key) const;

  double Number(const std::string& key, const NumberRule& rule) const;
  double NumberOr(const std::string& key, double fallback, const NumberRule& rule) const;
  std::string String(const std::string& key) const;
  std::string StringOr(const std::string& key, const std::string& fallback) const;

 private:
  YamlValue self_;
  YAML::Node entries_;  // self_'s mapping with YAML merge keys ("<<: *anchor") resolved
  std::vector<std::string> allowed_keys_;
};

// A parsed document. Load() reads a file; Parse() takes text (tests, messages).
class YamlDocument {
 public:
  static YamlDocument Load(const std::string& file);
  static YamlDocument Parse(const std::string& text, const std::string& name);

  YamlValue Root() const;
  const std::string& text() const { return text_; }
  const std::string& file() const { return context_->file; }
  // Where a key path was read, or the nearest enclosing path that was (file start if none).
  SourceLocation LocationOf(const std::string& key_path) const;

 private:
  YamlDocument(YAML::Node root, std::string text, std::shared_ptr<YamlContext> context);
  YAML::Node root_;
  std::string text_;
  std::shared_ptr<YamlContext> context_;
};

// Reads a whole file into a string; throws ConfigError naming the file when it cannot.
std::string ReadTextFile(const std::string& file);

}  // namespace sirupp::core
