#pragma once
// The viewer's camera, free of OpenGL: an eye orbiting a target point (azimuth, elevation,
// distance), world z up on screen, and the view and projection matrices the renderer loads. Tests
// project points with the same matrices to know which pixel shows them.
//
// Conventions: world frame z up (as the robot models and environments); azimuth is the eye's angle
// about world z measured from +x towards +y, elevation its angle above the x-y plane. Matrices are
// OpenGL's (column vectors, camera looking down its -z, normalised device coordinates -1..1).

#include <Eigen/Geometry>
#include <optional>
#include <string>

namespace sirupp::viewer {

struct Camera {
  double azimuth_rad = -0.87;   // -50 degrees: in front of the arm (+x), to its right (-y)
  double elevation_rad = 0.38;  // about 22 degrees above the horizon
  double distance_m = 1.45;     // eye to target
  Eigen::Vector3d target_m{0.18, 0.0, 0.30};
  double fov_y_rad = 0.70;  // vertical field of view, about 40 degrees
  double near_m = 0.05;
  double far_m = 20.0;

  Eigen::Vector3d Eye() const;
};

// Limits every camera (flags, config file, VIEWER_CAMERA) is checked against.
constexpr double kMaxElevationRad = 1.55;  // the view direction must not be parallel to z
constexpr double kMaxDistanceM = 100.0;

// "" when the camera can be used, else the first problem, naming the field with its value and the
// allowed range ("elevation 1.6 rad is outside [-1.55, 1.55]").
std::string CameraProblem(const Camera& camera);

// World to eye coordinates (gluLookAt with up = world z).
Eigen::Matrix4d ViewMatrix(const Camera& camera);
// Eye to clip coordinates (gluPerspective) for an image of aspect width / height.
Eigen::Matrix4d ProjectionMatrix(const Camera& camera, double aspect);

// The pixel (column, row; row 0 at the top, pixel centres at +0.5) where a world point appears in a
// width x height image, or nullopt when it lies behind the eye or outside the depth range.
std::optional<Eigen::Vector2d> ProjectToPixel(const Camera& camera, int width, int height,
                                              const Eigen::Vector3d& point_m);

}  // namespace sirupp::viewer
