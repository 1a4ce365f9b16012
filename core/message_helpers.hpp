#pragma once
// Internal to sirupp_core: pieces of message translation shared by translate.cpp (robot models)
// and environment.cpp (environments). Not part of core's public interface; other folders use
// translate.hpp and environment.hpp.

#include <sirupp/shape_t.hpp>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "core/geometry.hpp"

namespace sirupp::core::detail {

void PutVector(const Eigen::Vector3d& from, double (&to)[3]);
// Writes w, x, y, z.
void PutQuaternion(const Eigen::Quaterniond& from, double (&to)[4]);
Eigen::Vector3d GetVector(const double (&from)[3]);
// Reads w, x, y, z as sent; does not normalise.
Eigen::Quaterniond GetQuaternion(const double (&from)[4]);

sirupp::shape_t ShapeToMessage(const Shape& shape);
// Checks the type (TYPE_*) and the colour components (0..1), naming `field` (e.g.
// "links[2].shapes[0]") in the MessageError; sizes and pose are copied as sent, for the caller to
// check.
Shape ShapeFromMessage(const sirupp::shape_t& message, const std::string& channel,
                       const std::string& field);

// Throws MessageError when a count field does not match the entries of its array.
template <class T>
void CheckCount(const std::string& channel, const std::string& field, int32_t count,
                const std::vector<T>& array) {
  if (count < 0 || static_cast<size_t>(count) != array.size()) {
    throw MessageError(channel, field,
                       "count " + std::to_string(count) + " does not match the " +
                           std::to_string(array.size()) + " entries sent");
  }
}

}  // namespace sirupp::core::detail
