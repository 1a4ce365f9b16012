#include "viewer/camera.hpp"

#include <cmath>

#include "core/errors.hpp"

namespace sirupp::viewer {

Eigen::Vector3d Camera::Eye() const {
  const double c = std::cos(elevation_rad);
  return target_m + distance_m * Eigen::Vector3d(c * std::cos(azimuth_rad),
                                                 c * std::sin(azimuth_rad),
                                                 std::sin(elevation_rad));
}

std::string CameraProblem(const Camera& camera) {
  using core::FormatNumber;
  if (!std::isfinite(camera.azimuth_rad)) {
    return "azimuth " + FormatNumber(camera.azimuth_rad) + " rad: a finite angle is needed";
  }
  if (!(std::abs(camera.elevation_rad) <= kMaxElevationRad)) {
    return "elevation " + FormatNumber(camera.elevation_rad) + " rad is outside [-" +
           FormatNumber(kMaxElevationRad) + ", " + FormatNumber(kMaxElevationRad) +
           "] (about +-89 degrees)";
  }
  if (!(camera.distance_m > 0 && camera.distance_m <= kMaxDistanceM)) {
    return "distance " + FormatNumber(camera.distance_m) + " m is outside (0, " +
           FormatNumber(kMaxDistanceM) + "]";
  }
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(camera.target_m[i])) {
      return "target[" + std::to_string(i) + "] " + FormatNumber(camera.target_m[i]) +
             " m: a finite number is needed";
    }
  }
  if (!(camera.fov_y_rad > 0.05 && camera.fov_y_rad < 3.0)) {
    return "field of view " + FormatNumber(camera.fov_y_rad) + " rad is outside (0.05, 3)";
  }
  return "";
}

Eigen::Matrix4d ViewMatrix(const Camera& camera) {
  const Eigen::Vector3d eye = camera.Eye();
  const Eigen::Vector3d forward = (camera.target_m - eye).normalized();
  const Eigen::Vector3d side = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(forward);
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();
  view.block<1, 3>(0, 0) = side.transpose();
  view.block<1, 3>(1, 0) = up.transpose();
  view.block<1, 3>(2, 0) = -forward.transpose();
  view(0, 3) = -side.dot(eye);
  view(1, 3) = -up.dot(eye);
  view(2, 3) = forward.dot(eye);
  return view;
}

Eigen::Matrix4d ProjectionMatrix(const Camera& camera, double aspect) {
  const double f = 1.0 / std::tan(camera.fov_y_rad / 2);
  const double n = camera.near_m;
  const double far = camera.far_m;
  Eigen::Matrix4d projection = Eigen::Matrix4d::Zero();
  projection(0, 0) = f / aspect;
  projection(1, 1) = f;
  projection(2, 2) = (far + n) / (n - far);
  projection(2, 3) = 2 * far * n / (n - far);
  projection(3, 2) = -1;
  return projection;
}

std::optional<Eigen::Vector2d> ProjectToPixel(const Camera& camera, int width, int height,
                                              const Eigen::Vector3d& point_m) {
  const Eigen::Vector4d clip = ProjectionMatrix(camera, static_cast<double>(width) / height) *
                               ViewMatrix(camera) * point_m.homogeneous();
  if (clip.w() <= 0) return std::nullopt;
  const Eigen::Vector3d ndc = clip.head<3>() / clip.w();
  if (ndc.z() < -1 || ndc.z() > 1) return std::nullopt;
  return Eigen::Vector2d((ndc.x() + 1) / 2 * width, (1 - ndc.y()) / 2 * height);
}

}  // namespace sirupp::viewer
