#pragma once
// The constants of angles every folder uses, once (a library's files are compiled together in
// unity batches, so each file defining its own would clash).

namespace sirupp {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDeg = kPi / 180;  // one degree in radians: 30 * kDeg, angle / kDeg

}  // namespace sirupp
