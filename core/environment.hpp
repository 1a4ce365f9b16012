#pragma once
// The objects around the robot (a table, blocks, a ball): loaded from config/environments/*.xml
// (format in docs/environment-format.md), sent as environment_t on ENVIRONMENT. SI units and the
// world frame throughout (z up; the robot's base pose in the world comes from its robot model).
//
// LoadEnvironment / ParseEnvironment throw ConfigError "file:line: key.path: problem" on any bad
// input; key paths name the object by element and name (`box "table".size`), or by its position
// among the objects when it has no usable name (`box #3`). EnvironmentFromMessage throws
// MessageError "channel X: objects[2].shape.size[0]: problem".

#include <cstddef>
#include <sirupp/environment_t.hpp>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace sirupp::core {

// The most objects an environment may hold: static ones (fixed; the sim never tests them against
// each other) and free ones (bodies with contacts of their own). At these counts sirupp-sim still
// steps faster than real time (docs/environment-format.md, "Limits").
inline constexpr size_t kMaxStaticObjects = 10000;
inline constexpr size_t kMaxFreeObjects = 50;

struct EnvironmentObject {
  std::string name;        // unique within the environment, non-empty
  Shape shape;             // pose = the object's initial pose in the world frame
  bool is_static = true;   // fixed in the world; false = a free body the arm can push
  double mass_kg = 0;      // > 0 for free bodies; kept but unused for static ones
  double friction = 0.8;   // Coulomb coefficient of contacts with this object, >= 0
  double restitution = 0;  // bounciness of contacts, 0..1
  int source_line = 0;     // line of the object's element in its file; 0 when not from a file
};

struct Environment {
  std::string name;
  std::string source_file;  // as given to LoadEnvironment, or the name given to ParseEnvironment
  std::vector<EnvironmentObject> objects;

  // The object with this name, or nullptr.
  const EnvironmentObject* Find(const std::string& object_name) const;
};

Environment LoadEnvironment(const std::string& path);
// Same, from the text of a file; `file_name` stands for the file in messages and source_file.
Environment ParseEnvironment(const std::string& xml_text, const std::string& file_name);

// One object of an environment (`field` names it in errors, e.g. "objects[3]"): checks the name,
// shape, flags, mass, friction and restitution; uniqueness is EnvironmentFromMessage's.
sirupp::environment_object_t ToMessage(const EnvironmentObject& object);
EnvironmentObject EnvironmentObjectFromMessage(const sirupp::environment_object_t& message,
                                               const std::string& channel,
                                               const std::string& field);

// source_line is not sent; every other field travels exactly.
sirupp::environment_t ToMessage(const Environment& environment, int64_t utime, int64_t seq);
// Rebuilds the environment, checking counts, shape types, finiteness, sizes (> 0 where the shape
// uses them, 0 where it does not), unit quaternions, colours, flags, masses, friction,
// restitution and names (non-empty, unique). An empty environment name is allowed (no
// environment loaded).
Environment EnvironmentFromMessage(const sirupp::environment_t& message,
                                   const std::string& channel);

}  // namespace sirupp::core
