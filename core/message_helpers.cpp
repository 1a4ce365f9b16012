#include "core/message_helpers.hpp"

namespace sirupp::core::detail {

void PutVector(const Eigen::Vector3d& from, double (&to)[3]) {
  for (int i = 0; i < 3; ++i) to[i] = from[i];
}

void PutQuaternion(const Eigen::Quaterniond& from, double (&to)[4]) {
  to[0] = from.w();
  to[1] = from.x();
  to[2] = from.y();
  to[3] = from.z();
}

Eigen::Vector3d GetVector(const double (&from)[3]) { return {from[0], from[1], from[2]}; }

Eigen::Quaterniond GetQuaternion(const double (&from)[4]) {
  return Eigen::Quaterniond(from[0], from[1], from[2], from[3]);
}

sirupp::shape_t ShapeToMessage(const Shape& shape) {
  sirupp::shape_t message{};
  message.type = static_cast<int8_t>(shape.type);
  PutVector(shape.pose.position_m, message.position);
  PutQuaternion(shape.pose.orientation, message.orientation);
  PutVector(shape.size_m, message.size);
  for (int i = 0; i < 4; ++i) message.color[i] = shape.rgba[static_cast<size_t>(i)];
  return message;
}

Shape ShapeFromMessage(const sirupp::shape_t& message, const std::string& channel,
                       const std::string& field) {
  if (message.type < sirupp::shape_t::TYPE_BOX || message.type > sirupp::shape_t::TYPE_CAPSULE) {
    throw MessageError(channel, field + ".type",
                       std::to_string(message.type) + " is not allowed; expected 0..3 (TYPE_*)");
  }
  Shape shape;
  shape.type = static_cast<ShapeType>(message.type);
  shape.pose.position_m = GetVector(message.position);
  shape.pose.orientation = GetQuaternion(message.orientation);
  shape.size_m = GetVector(message.size);
  for (int i = 0; i < 4; ++i) {
    if (!(message.color[i] >= 0 && message.color[i] <= 1)) {
      throw MessageError(channel, field + ".color[" + std::to_string(i) + "]",
                         FormatNumber(message.color[i]) + " is not allowed; expected 0..1");
    }
    shape.rgba[static_cast<size_t>(i)] = message.color[i];
  }
  return shape;
}

}  // namespace sirupp::core::detail
