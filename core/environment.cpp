#include "core/environment.hpp"

#include <tinyxml2.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <unordered_map>
#include <utility>

#include "core/errors.hpp"
#include "core/message_helpers.hpp"
#include "core/printable.hpp"
#include "core/yaml_reader.hpp"  // NumberRule, ReadTextFile

namespace sirupp::core {

const EnvironmentObject* Environment::Find(const std::string& object_name) const {
  for (const EnvironmentObject& object : objects) {
    if (object.name == object_name) return &object;
  }
  return nullptr;
}

namespace {

using tinyxml2::XMLAttribute;
using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;
using tinyxml2::XMLNode;

const std::vector<std::string> kObjectElements = {"box", "cylinder", "sphere", "capsule"};

std::string JoinNames(const std::vector<std::string>& names, const char* separator = ", ") {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : separator) + name;
  return text;
}

bool Contains(const std::vector<std::string>& names, const std::string& name) {
  for (const std::string& candidate : names) {
    if (candidate == name) return true;
  }
  return false;
}

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

bool IsBlank(const std::string& text) {
  for (char c : text) {
    if (!IsSpace(c)) return false;
  }
  return true;
}

std::vector<std::string> SplitWords(const std::string& text) {
  std::vector<std::string> words;
  std::string word;
  for (char c : text) {
    if (IsSpace(c)) {
      if (!word.empty()) words.push_back(word);
      word.clear();
    } else {
      word += c;
    }
  }
  if (!word.empty()) words.push_back(word);
  return words;
}

// A short, one-line excerpt of free text for a message.
std::string Excerpt(const std::string& text) {
  std::string words = JoinNames(SplitWords(text), " ");
  if (words.size() > 30) words = words.substr(0, 27) + "...";
  return words;
}

std::string Lower(std::string text) {
  for (char& c : text) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return text;
}

// A number as written in a file: optional sign, digits with an optional decimal point, optional
// exponent. nan and inf (any case, optional sign) read as themselves so the caller can say they
// are not finite; anything else (hex, commas, units glued on) is not a number.
std::optional<double> ParseDecimal(const std::string& text) {
  size_t i = 0;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  const std::string rest = Lower(text.substr(i));
  if (rest == "nan" || rest == "inf" || rest == "infinity")
    return std::strtod(text.c_str(), nullptr);
  auto digits = [&] {
    const size_t start = i;
    while (i < text.size() && text[i] >= '0' && text[i] <= '9') ++i;
    return i - start;
  };
  size_t mantissa_digits = digits();
  if (i < text.size() && text[i] == '.') {
    ++i;
    mantissa_digits += digits();
  }
  if (mantissa_digits == 0) return std::nullopt;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    if (digits() == 0) return std::nullopt;
  }
  if (i != text.size()) return std::nullopt;
  return std::strtod(text.c_str(), nullptr);  // overflow gives +-inf, refused as not finite
}

// Why a word is not a number, when a common slip explains it.
std::string NotANumberHint(const std::string& word) {
  if (word.find(',') == std::string::npos) return "";
  std::string with_point = word;
  for (char& c : with_point) {
    if (c == ',') c = '.';
  }
  if (ParseDecimal(with_point)) return " (write decimals with a point)";
  return " (separate numbers with spaces, not commas)";
}

struct Units {
  std::string length_name = "m";
  double length_m = 1;
  std::string angle_name = "deg";
  double angle_rad = M_PI / 180.0;
};

// Reads the attributes of one element strictly. Every problem becomes a ConfigError at the line
// of the attribute (or of the element) with the key path `path.attribute`.
class ElementReader {
 public:
  ElementReader(const XMLElement& element, std::string path, std::string file)
      : element_(element), path_(std::move(path)), file_(std::move(file)) {}

  int line() const { return element_.GetLineNum(); }

  [[noreturn]] void Fail(int line, const std::string& problem) const {
    throw ConfigError(SourceLocation{file_, line, 0}, Printable(path_, 256), Printable(problem));
  }
  [[noreturn]] void Fail(const XMLAttribute& attribute, const std::string& problem) const {
    throw ConfigError(SourceLocation{file_, attribute.GetLineNum(), 0},
                      Printable(path_ + "." + attribute.Name(), 256), Printable(problem));
  }

  void CheckAttributes(const std::vector<std::string>& allowed) const {
    for (const XMLAttribute* a = element_.FirstAttribute(); a != nullptr; a = a->Next()) {
      if (!Contains(allowed, a->Name())) {
        Fail(*a, "unknown attribute '" + std::string(a->Name()) +
                     "'; allowed attributes: " + JoinNames(allowed));
      }
    }
  }

  const XMLAttribute* Find(const char* name) const { return element_.FindAttribute(name); }

  const XMLAttribute& Require(const char* name, const std::string& what) const {
    const XMLAttribute* attribute = Find(name);
    if (attribute == nullptr) {
      Fail(line(), "missing required attribute '" + std::string(name) + "' (" + what + ")");
    }
    return *attribute;
  }

  std::string Choice(const XMLAttribute& attribute, const std::vector<std::string>& allowed) const {
    const std::string value = attribute.Value();
    if (!Contains(allowed, value)) {
      Fail(attribute, "'" + value + "' is not allowed; expected one of: " + JoinNames(allowed));
    }
    return value;
  }

  std::string Name(const XMLAttribute& attribute, const std::string& what) const {
    const std::string value = attribute.Value();
    if (IsBlank(value)) {
      Fail(attribute, "an empty name is not allowed; expected " + what);
    }
    return value;
  }

  // Between min_count and components.size() numbers, each allowed by `rule` (values as written,
  // before unit conversion). `why` ends the "expected" part of a range message.
  std::vector<double> Numbers(const XMLAttribute& attribute,
                              const std::vector<std::string>& components, size_t min_count,
                              const NumberRule& rule, const std::string& why = "") const {
    const std::vector<std::string> words = SplitWords(attribute.Value());
    const size_t max_count = components.size();
    const bool single = max_count == 1;
    for (size_t i = 0; i < words.size() && i < max_count; ++i) {
      const std::string label = single ? "" : components[i] + " = ";
      const std::optional<double> value = ParseDecimal(words[i]);
      if (!value) {
        Fail(attribute, label + "'" + words[i] + "' is not a number" + NotANumberHint(words[i]) +
                            "; expected " + rule.Describe());
      }
      if (!rule.Allows(*value)) {
        Fail(attribute,
             label + FormatNumber(*value) + " is not allowed; expected " + rule.Describe() + why);
      }
    }
    if (words.size() < min_count || words.size() > max_count) {
      const std::string count =
          min_count == max_count ? std::to_string(max_count)
                                 : std::to_string(min_count) + " or " + std::to_string(max_count);
      const std::string written = "\"" + std::string(attribute.Value()) + "\"";
      if (single) {
        Fail(attribute, written + " is not one number; expected " + rule.Describe());
      }
      Fail(attribute, written + " has " + std::to_string(words.size()) + " number" +
                          (words.size() == 1 ? "" : "s") + "; expected " + count + " (" +
                          JoinNames(components, " ") + "), each " + rule.Describe());
    }
    std::vector<double> values;
    for (const std::string& word : words) values.push_back(*ParseDecimal(word));
    return values;
  }

  double Number(const XMLAttribute& attribute, const NumberRule& rule,
                const std::string& why = "") const {
    return Numbers(attribute, {""}, 1, rule, why)[0];
  }

  // An optional number: `fallback` when the attribute is absent.
  double NumberOr(const char* name, double fallback, const NumberRule& rule) const {
    const XMLAttribute* attribute = Find(name);
    return attribute == nullptr ? fallback : Number(*attribute, rule);
  }

  // Objects hold attributes only: any child element or text is a mistake.
  void CheckNoContent(const std::string& type) const {
    for (const XMLNode* node = element_.FirstChild(); node != nullptr; node = node->NextSibling()) {
      if (node->ToComment() != nullptr) continue;
      if (const XMLElement* child = node->ToElement()) {
        Fail(child->GetLineNum(), "element <" + std::string(child->Name()) +
                                      "> is not allowed inside <" + type +
                                      ">; give the object's values as attributes");
      }
      Fail(node->GetLineNum(), "text '" + Excerpt(node->Value()) + "' is not allowed inside <" +
                                   type + ">; give the object's values as attributes");
    }
  }

 private:
  const XMLElement& element_;
  std::string path_;
  std::string file_;
};

Units ReadUnits(const ElementReader& root) {
  Units units;
  if (const XMLAttribute* length = root.Find("length_unit")) {
    units.length_name = root.Choice(*length, {"m", "mm", "cm", "inch"});
    units.length_m = units.length_name == "mm"     ? 0.001
                     : units.length_name == "cm"   ? 0.01
                     : units.length_name == "inch" ? 0.0254
                                                   : 1.0;
  }
  if (const XMLAttribute* angle = root.Find("angle_unit")) {
    units.angle_name = root.Choice(*angle, {"deg", "rad"});
    units.angle_rad = units.angle_name == "deg" ? M_PI / 180.0 : 1.0;
  }
  return units;
}

// The key path of an object: by name when it has one, else by its place among the objects.
std::string ObjectPath(const XMLElement& element, size_t index) {
  const char* name = element.Attribute("name");
  if (name != nullptr && !IsBlank(name)) return element.Name() + std::string(" \"") + name + "\"";
  return element.Name() + std::string(" #") + std::to_string(index + 1);
}

// Reads the shape-specific attributes (sizes) of a box, cylinder, capsule or sphere.
void ReadShapeSize(const ElementReader& reader, const std::string& type, const Units& units,
                   Shape& shape) {
  const NumberRule dimension = PositiveNumber(units.length_name);
  if (type == "box") {
    shape.type = ShapeType::kBox;
    const std::vector<double> size =
        reader.Numbers(reader.Require("size", "x y z edge lengths in " + units.length_name),
                       {"x", "y", "z"}, 3, dimension);
    shape.size_m = Eigen::Vector3d(size[0], size[1], size[2]) * units.length_m;
    return;
  }
  shape.size_m.x() = reader.Number(reader.Require("radius", "in " + units.length_name), dimension) *
                     units.length_m;
  if (type == "sphere") {
    shape.type = ShapeType::kSphere;
    return;
  }
  shape.type = type == "cylinder" ? ShapeType::kCylinder : ShapeType::kCapsule;
  const std::string what = type == "cylinder" ? "along the local z axis, in "
                                              : "of the straight part along local z, in ";
  shape.size_m.y() =
      reader.Number(reader.Require("length", what + units.length_name), dimension) * units.length_m;
}

EnvironmentObject ReadObject(const XMLElement& element, size_t index, const Units& units,
                             const std::string& file) {
  const std::string type = element.Name();
  const ElementReader reader(element, ObjectPath(element, index), file);
  std::vector<std::string> allowed = {"name"};
  if (type == "box") {
    allowed.push_back("size");
  } else {
    allowed.push_back("radius");
    if (type != "sphere") allowed.push_back("length");
  }
  for (const char* common :
       {"position", "rpy", "static", "mass", "color", "friction", "restitution"}) {
    allowed.push_back(common);
  }
  reader.CheckAttributes(allowed);
  reader.CheckNoContent(type);

  EnvironmentObject object;
  object.source_line = element.GetLineNum();
  object.name = reader.Name(reader.Require("name", "a unique name for the object"),
                            "a unique, non-empty object name");
  ReadShapeSize(reader, type, units, object.shape);
  if (const XMLAttribute* position = reader.Find("position")) {
    const std::vector<double> xyz =
        reader.Numbers(*position, {"x", "y", "z"}, 3, AnyNumber(units.length_name));
    object.shape.pose.position_m = Eigen::Vector3d(xyz[0], xyz[1], xyz[2]) * units.length_m;
  }
  if (const XMLAttribute* rpy = reader.Find("rpy")) {
    const std::vector<double> angles =
        reader.Numbers(*rpy, {"roll", "pitch", "yaw"}, 3, AnyNumber(units.angle_name));
    object.shape.pose.orientation = QuaternionFromRpy(
        angles[0] * units.angle_rad, angles[1] * units.angle_rad, angles[2] * units.angle_rad);
  }
  if (const XMLAttribute* is_static = reader.Find("static")) {
    object.is_static = reader.Choice(*is_static, {"true", "false"}) == "true";
  }
  const XMLAttribute* mass = reader.Find("mass");
  if (object.is_static) {
    if (mass != nullptr) object.mass_kg = reader.Number(*mass, NonNegativeNumber("kg"));
  } else {
    if (mass == nullptr) {
      reader.Fail(reader.line(),
                  "missing required attribute 'mass' (kg, > 0), needed because the object is "
                  "free (static=\"false\")");
    }
    object.mass_kg =
        reader.Number(*mass, PositiveNumber("kg"), " for a free object (static=\"false\")");
  }
  if (const XMLAttribute* color = reader.Find("color")) {
    const std::vector<double> rgba =
        reader.Numbers(*color, {"r", "g", "b", "a"}, 3, NumberInRange(0, 1));
    object.shape.rgba = {{0, 0, 0, 1}};
    for (size_t i = 0; i < rgba.size(); ++i) object.shape.rgba[i] = static_cast<float>(rgba[i]);
  }
  object.friction =
      reader.NumberOr("friction", object.friction, NonNegativeNumber("Coulomb coefficient"));
  object.restitution = reader.NumberOr("restitution", object.restitution, NumberInRange(0, 1));
  return object;
}

// What went wrong, for people, from tinyxml2's error code and detail.
std::string SyntaxProblem(const XMLDocument& document) {
  const std::string detail = document.ErrorStr();
  std::string element;
  const std::string marker = "XMLElement name=";
  const size_t at = detail.find(marker);
  if (at != std::string::npos) {
    element = detail.substr(at + marker.size());
    element = element.substr(0, element.find(' '));
  }
  const std::string in_element = element.empty() ? "" : " in <" + element + ">";
  std::string problem;
  switch (document.ErrorID()) {
    case tinyxml2::XML_ERROR_PARSING_ELEMENT:
      problem = "a malformed tag" + in_element + " (check its < > and /)";
      break;
    case tinyxml2::XML_ERROR_PARSING_ATTRIBUTE:
      problem = "a malformed or repeated attribute" + in_element +
                "; write name=\"value\" with quotes, each name once";
      break;
    case tinyxml2::XML_ERROR_PARSING_TEXT:
      problem = "malformed text, or text outside the elements";
      break;
    case tinyxml2::XML_ERROR_PARSING_CDATA:
      problem = "an unterminated CDATA section";
      break;
    case tinyxml2::XML_ERROR_PARSING_COMMENT:
      problem = "an unterminated comment; write <!-- ... -->";
      break;
    case tinyxml2::XML_ERROR_PARSING_DECLARATION:
      problem = "a malformed <?...?> declaration (<?xml ...?> may only open the file)";
      break;
    case tinyxml2::XML_ERROR_PARSING_UNKNOWN:
      problem = "a malformed <!...> declaration";
      break;
    case tinyxml2::XML_ERROR_MISMATCHED_ELEMENT:
      problem = element.empty() ? "a closing tag does not match the open element"
                                : "<" + element +
                                      "> is not closed before its parent ends (end it "
                                      "with /> or close it with </" +
                                      element + ">)";
      break;
    case tinyxml2::XML_ERROR_PARSING:
      problem = "an element that is never closed, or a malformed tag";
      break;
    default:
      problem = "the text is not well-formed XML";
      break;
  }
  return "XML syntax error: " + problem + " (tinyxml2: " + document.ErrorName() + ")";
}

[[noreturn]] void FailAt(const std::string& file, int line, const std::string& problem) {
  throw ConfigError(SourceLocation{file, line, 0}, "", Printable(problem));
}

// The single <environment> element of the document; anything else at the top level but comments
// and the <?xml ...?> declaration is refused.
const XMLElement& RootElement(const XMLDocument& document, const std::string& file) {
  const XMLElement* root = nullptr;
  for (const XMLNode* node = document.FirstChild(); node != nullptr; node = node->NextSibling()) {
    if (node->ToComment() != nullptr || node->ToDeclaration() != nullptr) continue;
    const XMLElement* element = node->ToElement();
    if (element == nullptr) {
      FailAt(file, node->GetLineNum(),
             "<" + Excerpt(node->Value()) +
                 "> is not allowed; an environment file holds comments and one <environment> "
                 "element");
    }
    if (root != nullptr) {
      FailAt(file, element->GetLineNum(),
             "a second top-level element <" + std::string(element->Name()) +
                 "> is not allowed; expected one <environment> element holding every object");
    }
    if (std::strcmp(element->Name(), "environment") != 0) {
      FailAt(file, element->GetLineNum(),
             "root element <" + std::string(element->Name()) +
                 "> is not allowed; expected <environment>");
    }
    root = element;
  }
  if (root == nullptr) {
    FailAt(file, 0, "no <environment> element; expected one holding the objects");
  }
  return *root;
}

// ---- messages -----------------------------------------------------------------------------------

std::string Indexed(const std::string& field, size_t i) {
  return field + "[" + std::to_string(i) + "]";
}

void CheckMessageShape(const Shape& shape, const std::string& channel, const std::string& field) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(shape.pose.position_m[k])) {
      throw MessageError(
          channel, Indexed(field + ".position", static_cast<size_t>(k)),
          FormatNumber(shape.pose.position_m[k]) + " is not allowed; expected a finite number (m)");
    }
  }
  const Eigen::Vector4d q = shape.pose.orientation.coeffs();
  if (!q.allFinite() || std::abs(q.norm() - 1) > 1e-6) {
    throw MessageError(channel, field + ".orientation",
                       "a quaternion of norm " + FormatNumber(q.norm()) +
                           " is not allowed; expected a unit quaternion (w x y z)");
  }
  const ShapeType type = shape.type;
  const std::vector<std::string> used =
      type == ShapeType::kBox      ? std::vector<std::string>{"x edge", "y edge", "z edge"}
      : type == ShapeType::kSphere ? std::vector<std::string>{"radius"}
                                   : std::vector<std::string>{"radius", "length"};
  for (size_t k = 0; k < 3; ++k) {
    const double value = shape.size_m[static_cast<Eigen::Index>(k)];
    if (k < used.size() && !(std::isfinite(value) && value > 0)) {
      throw MessageError(channel, Indexed(field + ".size", k),
                         FormatNumber(value) +
                             " is not allowed; expected a finite number > 0 (m, " +
                             ShapeTypeName(type) + " " + used[k] + ")");
    }
    if (k >= used.size() && value != 0) {
      throw MessageError(channel, Indexed(field + ".size", k),
                         FormatNumber(value) + " is not allowed; expected 0 (a " +
                             ShapeTypeName(type) + " uses " + std::to_string(used.size()) +
                             (used.size() == 1 ? " size" : " sizes") + ")");
    }
  }
}

}  // namespace

EnvironmentObject EnvironmentObjectFromMessage(const sirupp::environment_object_t& message,
                                               const std::string& channel,
                                               const std::string& field) {
  if (message.name.empty()) {
    throw MessageError(channel, field + ".name",
                       "an empty name is not allowed; expected a unique, non-empty object name");
  }
  EnvironmentObject object;
  object.name = message.name;
  object.shape = detail::ShapeFromMessage(message.shape, channel, field + ".shape");
  CheckMessageShape(object.shape, channel, field + ".shape");
  if (message.is_static != 0 && message.is_static != 1) {
    throw MessageError(
        channel, field + ".is_static",
        std::to_string(message.is_static) + " is not allowed; expected 1 (static) or 0 (free)");
  }
  object.is_static = message.is_static == 1;
  const bool mass_ok =
      std::isfinite(message.mass) && (object.is_static ? message.mass >= 0 : message.mass > 0);
  if (!mass_ok) {
    throw MessageError(channel, field + ".mass",
                       FormatNumber(message.mass) + " is not allowed; expected a finite number " +
                           (object.is_static ? ">= 0 (kg)" : "> 0 (kg) for a free object"));
  }
  object.mass_kg = message.mass;
  if (!(std::isfinite(message.friction) && message.friction >= 0)) {
    throw MessageError(
        channel, field + ".friction",
        FormatNumber(message.friction) + " is not allowed; expected a finite number >= 0");
  }
  object.friction = message.friction;
  if (!(message.restitution >= 0 && message.restitution <= 1)) {
    throw MessageError(
        channel, field + ".restitution",
        FormatNumber(message.restitution) + " is not allowed; expected a finite number in [0, 1]");
  }
  object.restitution = message.restitution;
  return object;
}

sirupp::environment_object_t ToMessage(const EnvironmentObject& object) {
  sirupp::environment_object_t o{};
  o.name = object.name;
  o.shape = detail::ShapeToMessage(object.shape);
  o.is_static = object.is_static ? 1 : 0;
  o.mass = object.mass_kg;
  o.friction = object.friction;
  o.restitution = object.restitution;
  return o;
}

Environment ParseEnvironment(const std::string& xml_text, const std::string& file_name) {
  XMLDocument document;
  document.Parse(xml_text.data(), xml_text.size());
  if (document.ErrorID() == tinyxml2::XML_ERROR_EMPTY_DOCUMENT) {
    FailAt(file_name, 0, "the file is empty; expected an <environment> element");
  }
  if (document.Error()) FailAt(file_name, document.ErrorLineNum(), SyntaxProblem(document));

  const XMLElement& root_element = RootElement(document, file_name);
  const ElementReader root(root_element, "environment", file_name);
  root.CheckAttributes({"name", "length_unit", "angle_unit"});
  Environment environment;
  environment.source_file = file_name;
  environment.name =
      root.Name(root.Require("name", "the environment's name"), "a non-empty environment name");
  const Units units = ReadUnits(root);

  // Object counts against the limits: the whole file is read first, so that the message can say
  // how many objects it has.
  struct ObjectCount {
    const char* kind;
    size_t limit;
    size_t count = 0;
    int first_over_line = 0;
    std::string first_over_path;
  };
  ObjectCount statics{"static", kMaxStaticObjects, 0, 0, ""};
  ObjectCount frees{"free", kMaxFreeObjects, 0, 0, ""};
  std::unordered_map<std::string, size_t> names;  // object name -> index
  for (const XMLNode* node = root_element.FirstChild(); node != nullptr;
       node = node->NextSibling()) {
    if (node->ToComment() != nullptr) continue;
    const XMLElement* element = node->ToElement();
    if (element == nullptr) {
      root.Fail(node->GetLineNum(), "text '" + Excerpt(node->Value()) +
                                        "' is not allowed inside <environment>; expected object "
                                        "elements (" +
                                        JoinNames(kObjectElements) + ") and comments");
    }
    if (!Contains(kObjectElements, element->Name())) {
      root.Fail(element->GetLineNum(), "unknown element <" + std::string(element->Name()) +
                                           ">; allowed elements: " + JoinNames(kObjectElements));
    }
    EnvironmentObject object = ReadObject(*element, environment.objects.size(), units, file_name);
    const auto [earlier_index, unique] = names.emplace(object.name, environment.objects.size());
    if (!unique) {
      const EnvironmentObject& earlier = environment.objects[earlier_index->second];
      const XMLAttribute* name = element->FindAttribute("name");
      throw ConfigError(SourceLocation{file_name, name->GetLineNum(), 0},
                        Printable(ObjectPath(*element, environment.objects.size()) + ".name", 256),
                        "\"" + Printable(object.name, 64) + "\" is already the name of the " +
                            ShapeTypeName(earlier.shape.type) + " on line " +
                            std::to_string(earlier.source_line) + "; expected unique object names");
    }
    ObjectCount& count = object.is_static ? statics : frees;
    if (++count.count == count.limit + 1) {
      count.first_over_line = element->GetLineNum();
      count.first_over_path = ObjectPath(*element, environment.objects.size());
    }
    environment.objects.push_back(std::move(object));
  }
  for (const ObjectCount* count : {&statics, &frees}) {
    if (count->count > count->limit) {
      throw ConfigError(SourceLocation{file_name, count->first_over_line, 0},
                        Printable(count->first_over_path, 256),
                        "the file has " + std::to_string(count->count) + " " + count->kind +
                            " objects; allowed at most " + std::to_string(count->limit) +
                            " (this is the first one over the limit; docs/environment-format.md, "
                            "\"Limits\")");
    }
  }
  return environment;
}

Environment LoadEnvironment(const std::string& path) {
  std::error_code ignored;
  if (std::filesystem::is_directory(path, ignored)) {
    throw ConfigError(SourceLocation{path, 0, 0}, "",
                      "cannot read the file: it is a directory; expected an environment file");
  }
  return ParseEnvironment(ReadTextFile(path), path);
}

sirupp::environment_t ToMessage(const Environment& environment, int64_t utime, int64_t seq) {
  sirupp::environment_t message{};
  message.utime = utime;
  message.seq = seq;
  message.name = environment.name;
  message.source_file = environment.source_file;
  for (const EnvironmentObject& object : environment.objects) {
    message.objects.push_back(ToMessage(object));
  }
  message.num_objects = static_cast<int32_t>(message.objects.size());
  return message;
}

Environment EnvironmentFromMessage(const sirupp::environment_t& message,
                                   const std::string& channel) {
  detail::CheckCount(channel, "num_objects", message.num_objects, message.objects);
  Environment environment;
  environment.name = message.name;
  environment.source_file = message.source_file;
  std::unordered_map<std::string, size_t> names;  // object name -> index
  size_t statics = 0;
  size_t frees = 0;
  for (size_t i = 0; i < message.objects.size(); ++i) {
    const std::string field = Indexed("objects", i);
    EnvironmentObject object = EnvironmentObjectFromMessage(message.objects[i], channel, field);
    const auto [earlier, unique] = names.emplace(object.name, i);
    if (!unique) {
      throw MessageError(channel, field + ".name",
                         "\"" + object.name + "\" is already the name of " +
                             Indexed("objects", earlier->second) +
                             "; expected unique object names");
    }
    ++(object.is_static ? statics : frees);
    environment.objects.push_back(std::move(object));
  }
  if (statics > kMaxStaticObjects || frees > kMaxFreeObjects) {
    const bool too_many_static = statics > kMaxStaticObjects;
    throw MessageError(channel, "objects",
                       std::to_string(too_many_static ? statics : frees) +
                           (too_many_static ? " static" : " free") + " objects; allowed at most " +
                           std::to_string(too_many_static ? kMaxStaticObjects : kMaxFreeObjects));
  }
  return environment;
}

}  // namespace sirupp::core
