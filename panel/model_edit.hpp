#pragma once
// Editing a robot model file's values from the page: the DH rows, the joint limits and friction
// and the link masses, as they are written in the file (its units line applies). An edit replaces
// the value's text where it stands in the file, so comments, anchors and every other line stay as
// they were; the edited text is then read by the model loader itself (core::ParseRobotModel), so
// the page gets the same error as `sirupp model check`: file:line, the key path of the field
// ("joints[1].friction.static") and what is allowed.

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace sirupp::panel {

// One value the page may edit.
struct ModelField {
  std::string key;    // the loader's key path: "dh[0].a", "joints[2].limits[1]", "links[3].mass_kg"
  std::string group;  // "dh", "joints" or "links"
  std::string text;   // as written in the file ("-90", "[0.7, 0.75]")
  int line = 0;       // 1-based
  size_t begin = 0;   // byte span of the value in the file's text
  size_t end = 0;
};

// The editable values of a model file's text. Throws core::ConfigError when the text is not YAML.
std::vector<ModelField> EditableFields(const std::string& text, const std::string& file_name);

// `text` with the values of `edits` (key -> new text) put in. A value is one number, or for
// joints[i].friction.coulomb also "[positive, negative]". Throws std::invalid_argument naming the
// key for an unknown key or a value of another form (nothing is changed then).
std::string ApplyModelEdits(const std::string& text, const std::vector<ModelField>& fields,
                            const std::map<std::string, std::string>& edits);

// The result of checking an edited text with the model loader: ok, or the error with its line
// and key path (and the edited key it concerns, when one matches).
struct ModelCheck {
  bool ok = true;
  std::string error;
  int line = 0;
  std::string key_path;
  std::string field;  // the edited field's key the error is about ("" when none matches)
  std::string model_name;
};
ModelCheck CheckModelText(const std::string& text, const std::string& file_name,
                          const std::vector<ModelField>& fields);

// Throws std::invalid_argument unless `name` is a new model file name: 1 to 60 letters, digits,
// '_' and '-' (".yaml" is added).
void CheckModelFileName(const std::string& name);

}  // namespace sirupp::panel
