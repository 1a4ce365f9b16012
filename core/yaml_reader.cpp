#include "core/yaml_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include "core/printable.hpp"

namespace sirupp::core {

// ---- NumberRule
// -----------------------------------------------------------------------------------

bool NumberRule::Allows(double value) const {
  if (!std::isfinite(value)) return false;
  if (min_inclusive ? value < min : value <= min) return false;
  if (max_inclusive ? value > max : value >= max) return false;
  return true;
}

std::string NumberRule::Describe() const {
  std::string text = "a finite number";
  const bool has_min = std::isfinite(min);
  const bool has_max = std::isfinite(max);
  if (has_min && has_max) {
    text += std::string(" in ") + (min_inclusive ? "[" : "(") + FormatNumber(min) + ", " +
            FormatNumber(max) + (max_inclusive ? "]" : ")");
  } else if (has_min) {
    text += std::string(min_inclusive ? " >= " : " > ") + FormatNumber(min);
  } else if (has_max) {
    text += std::string(max_inclusive ? " <= " : " < ") + FormatNumber(max);
  }
  if (!unit.empty()) text += " (" + unit + ")";
  return text;
}

NumberRule AnyNumber(std::string unit) {
  NumberRule rule;
  rule.unit = std::move(unit);
  return rule;
}
NumberRule PositiveNumber(std::string unit) {
  NumberRule rule = AnyNumber(std::move(unit));
  rule.min = 0;
  rule.min_inclusive = false;
  return rule;
}
NumberRule NonNegativeNumber(std::string unit) {
  NumberRule rule = AnyNumber(std::move(unit));
  rule.min = 0;
  return rule;
}
NumberRule NumberInRange(double min, double max, std::string unit) {
  NumberRule rule = AnyNumber(std::move(unit));
  rule.min = min;
  rule.max = max;
  return rule;
}

// ---- YamlValue
// ------------------------------------------------------------------------------------

namespace {

SourceLocation ToLocation(const std::string& file, const YAML::Mark& mark) {
  SourceLocation where;
  where.file = file;
  if (!mark.is_null()) {
    where.line = mark.line + 1;
    where.column = mark.column + 1;
  }
  return where;
}

bool IsQuoted(const YAML::Node& node) { return node.Tag() == "!"; }

// Parses a plain YAML scalar as a double; nullopt when it is not a number at all.
std::optional<double> ParseNumber(const std::string& text) {
  std::string lower = text;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == ".nan" || lower == "nan") return std::nan("");
  if (lower == ".inf" || lower == "+.inf" || lower == "inf" || lower == "+inf")
    return std::numeric_limits<double>::infinity();
  if (lower == "-.inf" || lower == "-inf") return -std::numeric_limits<double>::infinity();
  if (text.empty()) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return std::nullopt;
  if (errno == ERANGE && std::isinf(value)) return value;  // overflow reads as infinite
  return value;
}

}  // namespace

YamlValue::YamlValue(YAML::Node node, std::string path, std::shared_ptr<YamlContext> context)
    : node_(std::move(node)), path_(std::move(path)), context_(std::move(context)) {
  context_->locations.emplace(path_, node_.Mark());
}

YamlValue YamlValue::Child(const YAML::Node& child, const std::string& child_path) const {
  return YamlValue(child, child_path, context_);
}

SourceLocation YamlValue::location() const { return ToLocation(context_->file, node_.Mark()); }

void YamlValue::Fail(const std::string& problem) const {
  throw ConfigError(location(), Printable(path_, 256), Printable(problem));
}

std::string YamlValue::Describe() const {
  if (node_.IsMap()) return "a mapping";
  if (node_.IsSequence()) return "a list";
  if (node_.IsNull()) return "an empty value";
  if (IsQuoted(node_)) return "the text \"" + node_.Scalar() + "\"";
  return node_.Scalar();
}

double YamlValue::Number(const NumberRule& rule) const {
  if (!node_.IsScalar() || IsQuoted(node_)) {
    Fail(Describe() + " is not a number; expected " + rule.Describe());
  }
  const std::string& text = node_.Scalar();
  const std::optional<double> value = ParseNumber(text);
  if (!value) {
    std::string hint;
    if (text.find(',') != std::string::npos &&
        ParseNumber(std::string(text).replace(text.find(','), 1, "."))) {
      hint = " (write decimals with a point)";
    }
    Fail(text + " is not a number" + hint + "; expected " + rule.Describe());
  }
  if (!rule.Allows(*value)) Fail(text + " is not allowed; expected " + rule.Describe());
  return *value;
}

int64_t YamlValue::Integer(int64_t min, int64_t max) const {
  const std::string expected =
      "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  if (!node_.IsScalar() || IsQuoted(node_))
    Fail(Describe() + " is not an integer; expected " + expected);
  const std::string& text = node_.Scalar();
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE) {
    Fail(text + " is not an integer; expected " + expected);
  }
  if (value < min || value > max) Fail(text + " is not allowed; expected " + expected);
  return value;
}

bool YamlValue::Bool() const {
  if (node_.IsScalar() && !IsQuoted(node_)) {
    const std::string& text = node_.Scalar();
    if (text == "true") return true;
    if (text == "false") return false;
  }
  Fail(Describe() + " is not allowed; expected true or false");
}

std::string YamlValue::String() const {
  if (!node_.IsScalar() || node_.Scalar().empty()) {
    Fail(Describe() + " is not allowed; expected a non-empty text");
  }
  return node_.Scalar();
}

std::string YamlValue::Choice(const std::vector<std::string>& allowed) const {
  std::string list;
  for (const std::string& option : allowed) list += (list.empty() ? "" : ", ") + option;
  if (!node_.IsScalar()) Fail(Describe() + " is not allowed; expected one of: " + list);
  const std::string& text = node_.Scalar();
  if (std::find(allowed.begin(), allowed.end(), text) == allowed.end()) {
    Fail("'" + text + "' is not allowed; expected one of: " + list);
  }
  return text;
}

std::vector<YamlValue> YamlValue::Sequence(size_t min_size, size_t max_size) const {
  auto count_text = [&] {
    if (min_size == max_size) return std::to_string(min_size) + " entries";
    if (max_size == std::numeric_limits<size_t>::max())
      return "at least " + std::to_string(min_size) + " entr" + (min_size == 1 ? "y" : "ies");
    return std::to_string(min_size) + " to " + std::to_string(max_size) + " entries";
  };
  if (!node_.IsSequence()) Fail(Describe() + " is not a list; expected a list of " + count_text());
  if (node_.size() < min_size || node_.size() > max_size) {
    Fail("a list of " + std::to_string(node_.size()) + " entries is not allowed; expected " +
         count_text());
  }
  std::vector<YamlValue> items;
  items.reserve(node_.size());
  for (size_t i = 0; i < node_.size(); ++i) {
    items.push_back(Child(node_[i], path_ + "[" + std::to_string(i) + "]"));
  }
  return items;
}

std::vector<double> YamlValue::Numbers(size_t count, const NumberRule& rule) const {
  if (!node_.IsSequence() || node_.size() != count) {
    const std::string got =
        node_.IsSequence() ? "a list of " + std::to_string(node_.size()) : Describe();
    Fail(got + " is not allowed; expected a list of " + std::to_string(count) + " numbers (" +
         rule.Describe() + " each)");
  }
  std::vector<double> values;
  for (const YamlValue& item : Sequence(count, count)) values.push_back(item.Number(rule));
  return values;
}

YamlMap YamlValue::Map(const std::vector<std::string>& allowed_keys) const {
  return YamlMap(*this, allowed_keys);
}

std::vector<std::pair<std::string, YamlValue>> YamlValue::Entries() const {
  if (!node_.IsMap()) Fail(Describe() + " is not a mapping; expected a mapping of name: value");
  std::vector<std::pair<std::string, YamlValue>> entries;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : it->first.Tag();
    const std::string child_path = path_.empty() ? key : path_ + "." + key;
    for (const auto& entry : entries) {
      if (entry.first == key)
        Child(it->first, child_path).Fail("duplicate key '" + key + "'; each key may appear once");
    }
    entries.emplace_back(key, Child(it->second, child_path));
  }
  return entries;
}

// ---- YamlMap
// --------------------------------------------------------------------------------------

namespace {
std::string JoinPath(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}
}  // namespace

namespace {

// The mapping's entries with merge keys expanded; key nodes keep their marks, so errors about a
// merged key point into the anchored mapping it came from.
YAML::Node ResolveMergeKeys(const YAML::Node& node, const YamlValue& self, int depth = 0) {
  const YAML::Node merge = node["<<"];
  if (!merge.IsDefined()) return node;
  const YamlValue merge_value = self.Child(merge, JoinPath(self.path(), "<<"));
  if (depth > 16) merge_value.Fail("merge keys nest more than 16 deep");
  std::vector<YAML::Node> sources;
  if (merge.IsMap()) {
    sources.push_back(merge);
  } else if (merge.IsSequence()) {
    for (const YAML::Node& item : merge) sources.push_back(item);
  }
  if (sources.empty()) {
    merge_value.Fail(
        "is not allowed; a merge key takes an anchored mapping (<<: *name) or a list of them");
  }
  std::set<std::string> taken;
  YAML::Node merged(YAML::NodeType::Map);
  auto take = [&](const YAML::Node& from) {
    for (auto it = from.begin(); it != from.end(); ++it) {
      const bool is_merge_key = it->first.IsScalar() && it->first.Scalar() == "<<";
      if (!is_merge_key && it->first.IsScalar() && taken.insert(it->first.Scalar()).second) {
        merged.force_insert(it->first, it->second);
      }
    }
  };
  take(node);
  for (const YAML::Node& source : sources) {
    if (!source.IsMap()) {
      merge_value.Fail(
          "is not allowed; a merge key takes an anchored mapping (<<: *name) or a list of them");
    }
    take(ResolveMergeKeys(source, self, depth + 1));
  }
  return merged;
}

}  // namespace

YamlMap::YamlMap(YamlValue self, std::vector<std::string> allowed_keys)
    : self_(std::move(self)), allowed_keys_(std::move(allowed_keys)) {
  if (!self_.node().IsMap()) {
    self_.Fail(self_.Describe() + " is not a mapping; expected a mapping of key: value");
  }
  std::string allowed_list;
  for (const std::string& key : allowed_keys_) {
    allowed_list += (allowed_list.empty() ? "" : ", ") + key;
  }
  // Duplicates are looked for in the mapping as written; unknown keys also among merged ones.
  std::set<std::string> seen;
  const YAML::Node& written = self_.node();
  for (auto it = written.begin(); it != written.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : it->first.Tag();
    if (!seen.insert(key).second) {
      self_.Child(it->first, JoinPath(self_.path(), key))
          .Fail("duplicate key '" + key + "'; each key may appear once");
    }
  }
  entries_ = ResolveMergeKeys(self_.node(), self_);
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : it->first.Tag();
    if (std::find(allowed_keys_.begin(), allowed_keys_.end(), key) == allowed_keys_.end()) {
      // "a: 0,3" in a flow mapping splits at the comma and leaves a key "3": say so.
      const std::string hint =
          ParseNumber(key) ? " (a decimal written with a comma? use a point)" : "";
      self_.Child(it->first, JoinPath(self_.path(), key))
          .Fail("unknown key '" + key + "'" + hint + "; allowed keys: " + allowed_list);
    }
  }
}

bool YamlMap::Has(const std::string& key) const { return Find(key).has_value(); }

std::optional<YamlValue> YamlMap::Find(const std::string& key) const {
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (it->first.IsScalar() && it->first.Scalar() == key) {
      return self_.Child(it->second, JoinPath(self_.path(), key));
    }
  }
  return std::nullopt;
}

YamlValue YamlMap::Get(const std::string& key, const std::string& expected) const {
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (!it->first.IsScalar() || it->first.Scalar() != key) continue;
    const std::string child_path = JoinPath(self_.path(), key);
    // "key:" with nothing after it: point at the key, not at whatever the next line holds.
    if (it->second.IsNull())
      self_.Child(it->first, child_path).Fail("missing value; expected " + expected);
    return self_.Child(it->second, child_path);
  }
  self_.Fail("missing required key '" + key + "' (" + expected + ")");
}

double YamlMap::Number(const std::string& key, const NumberRule& rule) const {
  return Get(key, rule.Describe()).Number(rule);
}

double YamlMap::NumberOr(const std::string& key, double fallback, const NumberRule& rule) const {
  return Has(key) ? Number(key, rule) : fallback;
}

std::string YamlMap::String(const std::string& key) const {
  return Get(key, "a non-empty text").String();
}

std::string YamlMap::StringOr(const std::string& key, const std::string& fallback) const {
  const std::optional<YamlValue> value = Find(key);
  return value ? value->String() : fallback;
}

// ---- YamlDocument
// ---------------------------------------------------------------------------------

std::string ReadTextFile(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    throw ConfigError(SourceLocation{file, 0, 0}, "",
                      std::string("cannot read the file: ") + std::strerror(errno));
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

namespace {

// Counts a document's nodes as a reader would visit them: an alias (or a merge key naming one)
// counts everything it names again each time it is used. Stops at kMaxYamlNodes or kMaxYamlDepth
// with an error at the place the expansion started: the key (or list) where an alias was used, as
// far as the marks tell (an alias names an anchor written earlier in the file, so a node that
// starts before the key or list holding it was reached through an alias).
class ExpansionCounter {
 public:
  explicit ExpansionCounter(std::string file) : file_(std::move(file)) {}

  void Count(const YAML::Node& root) { Visit(root, 0); }

 private:
  struct Frame {
    YAML::Mark where;                  // the key of a mapping entry, or the list holding an item
    const std::string* key = nullptr;  // a mapping entry's key (null: a list item)
    size_t index = 0;                  // a list item's index
    bool via_alias = false;
  };

  void Visit(const YAML::Node& node, int depth) {
    if (++visited_ > kMaxYamlNodes) {
      Refuse("the document expands to more than " + std::to_string(kMaxYamlNodes) +
             " nodes, counting every use of an alias or merge key as a copy of what it names "
             "(a YAML bomb?); allowed at most " +
             std::to_string(kMaxYamlNodes));
    }
    if (depth > kMaxYamlDepth) {
      Refuse("the document nests more than " + std::to_string(kMaxYamlDepth) +
             " levels deep (counting aliases as copies); allowed at most " +
             std::to_string(kMaxYamlDepth));
    }
    if (node.IsMap()) {
      for (auto it = node.begin(); it != node.end(); ++it) {
        static const std::string kComplexKey = "?";
        const std::string* key = it->first.IsScalar() ? &it->first.Scalar() : &kComplexKey;
        stack_.push_back({it->first.Mark(), key, 0, NotAfter(it->second.Mark(), it->first.Mark())});
        Visit(it->first, depth + 1);
        Visit(it->second, depth + 1);
        stack_.pop_back();
      }
    } else if (node.IsSequence()) {
      for (size_t i = 0; i < node.size(); ++i) {
        const YAML::Node item = node[i];
        stack_.push_back({node.Mark(), nullptr, i, NotAfter(item.Mark(), node.Mark())});
        Visit(item, depth + 1);
        stack_.pop_back();
      }
    }
  }

  // A value starts after its key, an item after the start of its list, unless an alias names a
  // node written earlier.
  static bool NotAfter(const YAML::Mark& a, const YAML::Mark& b) {
    return !a.is_null() && !b.is_null() && a.pos <= b.pos;
  }

  [[noreturn]] void Refuse(const std::string& problem) const {
    // The outermost place where an alias was used; else the innermost place reached.
    size_t at = stack_.size();
    for (size_t i = 0; i < stack_.size(); ++i) {
      if (stack_[i].via_alias) {
        at = i + 1;
        break;
      }
    }
    std::string path;
    for (size_t i = 0; i < at; ++i) {
      const Frame& frame = stack_[i];
      path += frame.key != nullptr ? (path.empty() ? "" : ".") + *frame.key
                                   : "[" + std::to_string(frame.index) + "]";
    }
    SourceLocation where{file_, 1, 1};
    if (at > 0 && !stack_[at - 1].where.is_null()) where = ToLocation(file_, stack_[at - 1].where);
    throw ConfigError(where, Printable(path, 256), problem);
  }

  std::string file_;
  size_t visited_ = 0;
  std::vector<Frame> stack_;
};

}  // namespace

YamlDocument::YamlDocument(YAML::Node root, std::string text, std::shared_ptr<YamlContext> context)
    : root_(std::move(root)), text_(std::move(text)), context_(std::move(context)) {}

YamlDocument YamlDocument::Load(const std::string& file) { return Parse(ReadTextFile(file), file); }

YamlDocument YamlDocument::Parse(const std::string& text, const std::string& name) {
  auto context = std::make_shared<YamlContext>();
  context->file = name;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& error) {
    throw ConfigError(ToLocation(name, error.mark), "", "YAML syntax error: " + error.msg);
  }
  if (!root.IsDefined() || root.IsNull()) {
    throw ConfigError(SourceLocation{name, 1, 1}, "", "the file is empty; expected a mapping");
  }
  ExpansionCounter(name).Count(root);
  return YamlDocument(root, text, context);
}

YamlValue YamlDocument::Root() const { return YamlValue(root_, "", context_); }

SourceLocation YamlDocument::LocationOf(const std::string& key_path) const {
  std::string path = key_path;
  while (true) {
    const auto found = context_->locations.find(path);
    if (found != context_->locations.end()) return ToLocation(context_->file, found->second);
    if (path.empty()) return SourceLocation{context_->file, 1, 1};
    const size_t cut = path.find_last_of(".[");
    path = cut == std::string::npos ? "" : path.substr(0, cut);
  }
}

}  // namespace sirupp::core
