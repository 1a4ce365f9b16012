#include "grade/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "control/servo_bank.hpp"
#include "core/errors.hpp"
#include "core/motion_limits.hpp"
#include "core/units.hpp"

namespace sirupp::grade {
namespace {

constexpr int kDegree = 5;        // quintic pieces
constexpr int kRootSamples = 64;  // sub-intervals searched for a sign change, per piece

// Degrees (mm for a prismatic joint) per SI unit.
double Shown(const core::RobotModel& model, size_t joint) {
  return model.joints[joint].type == core::JointType::kRevolute ? 180 / kPi : 1000;
}

// 6 significant digits for the plan's speeds and accelerations, 9 for its goals (the plan stays
// short; the profile's fixed point resolves far less).
std::string Digits(double value, int digits) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}
std::string Short(double value) { return Digits(value, 6); }
std::string Goal(double value) { return Digits(value, 9); }

// The coefficients of the `order`-th derivative (in u) of sum c[k] u^k, k = 0..kDegree.
void Derivative(const double* c, int order, double* out) {
  for (int k = 0; k <= kDegree; ++k) {
    double value = 0;
    if (k + order <= kDegree) {
      value = c[k + order];
      for (int f = 0; f < order; ++f) value *= k + order - f;
    }
    out[k] = value;
  }
}

double Evaluate(const double* c, double u) {
  double value = c[kDegree];
  for (int k = kDegree - 1; k >= 0; --k) value = value * u + c[k];
  return value;
}

// The points in (0, 1) where sum c[k] u^k changes sign (or is exactly zero at a sample), in order.
std::vector<double> SignChanges(const double* c) {
  std::vector<double> roots;
  double a = 0;
  double fa = Evaluate(c, a);
  for (int i = 1; i <= kRootSamples; ++i) {
    const double b = static_cast<double>(i) / kRootSamples;
    const double fb = Evaluate(c, b);
    if (i < kRootSamples && fb == 0) {
      roots.push_back(b);
    } else if ((fa < 0 && fb > 0) || (fa > 0 && fb < 0)) {
      double lo = a, hi = b, flo = fa;
      for (int k = 0; k < 60; ++k) {
        const double mid = 0.5 * (lo + hi);
        const double fm = Evaluate(c, mid);
        if ((fm < 0) == (flo < 0)) {
          lo = mid;
          flo = fm;
        } else {
          hi = mid;
        }
      }
      roots.push_back(0.5 * (lo + hi));
    }
    a = b;
    fa = fb;
  }
  return roots;
}

}  // namespace

JointPath::JointPath(std::vector<Knot> knots) {
  if (knots.empty()) throw std::invalid_argument("a path needs at least one knot");
  first_ = knots.front().at;
  last_ = knots.back().at;
  start_s_ = knots.front().t_s;
  for (size_t i = 0; i + 1 < knots.size(); ++i) {
    const Knot& k0 = knots[i];
    const Knot& k1 = knots[i + 1];
    const double T = k1.t_s - k0.t_s;
    if (!(T > 0)) throw std::invalid_argument("a path's knots must be in time order");
    // The quintic meeting both knots' position, velocity and acceleration (u in [0, 1]).
    const double d = k1.at.position - k0.at.position;
    const double v0 = k0.at.velocity * T, v1 = k1.at.velocity * T;
    const double a0 = k0.at.acceleration * T * T, a1 = k1.at.acceleration * T * T;
    Piece piece;
    piece.start_s = k0.t_s;
    piece.duration_s = T;
    piece.c[0] = k0.at.position;
    piece.c[1] = v0;
    piece.c[2] = a0 / 2;
    piece.c[3] = 10 * d - 6 * v0 - 4 * v1 - (3 * a0 - a1) / 2;
    piece.c[4] = -15 * d + 8 * v0 + 7 * v1 + (3 * a0 - 2 * a1) / 2;
    piece.c[5] = 6 * d - 3 * v0 - 3 * v1 - (a0 - a1) / 2;
    pieces_.push_back(piece);
  }
  // Where the joint comes to rest or reverses: knots at rest, and sign changes of the velocity.
  for (size_t i = 0; i < knots.size(); ++i) {
    if (i > 0 && knots[i].at.velocity == 0) turns_.push_back(knots[i].t_s);
    if (i + 1 < knots.size()) {
      const Piece& piece = pieces_[i];
      double velocity[kDegree + 1];
      Derivative(piece.c, 1, velocity);
      for (double u : SignChanges(velocity)) turns_.push_back(piece.start_s + u * piece.duration_s);
    }
  }
  if (turns_.empty() || turns_.back() != knots.back().t_s) turns_.push_back(knots.back().t_s);
}

JointPath JointPath::Hold(double position) {
  Knot knot;
  knot.at.position = position;
  return JointPath({knot});
}

JointPath JointPath::BackAndForth(double centre, double amplitude, double period_s, int cycles) {
  std::vector<Knot> knots;
  double t = 0;
  const auto rest = [&](double position) {
    Knot knot;
    knot.t_s = t;
    knot.at.position = position;
    knots.push_back(knot);
  };
  rest(centre);
  for (int c = 0; c < cycles; ++c) {
    t += period_s / 4;
    rest(centre + amplitude);
    t += period_s / 2;
    rest(centre - amplitude);
    t += period_s / 4;
    rest(centre);
  }
  return JointPath(std::move(knots));
}

JointPath::Sample JointPath::At(double t_s) const {
  if (pieces_.empty() || t_s <= start_s_) return {first_.position, 0, 0};
  for (const Piece& piece : pieces_) {
    if (t_s >= piece.start_s + piece.duration_s) continue;
    const double u = (t_s - piece.start_s) / piece.duration_s;
    const double T = piece.duration_s;
    double velocity[kDegree + 1], acceleration[kDegree + 1];
    Derivative(piece.c, 1, velocity);
    Derivative(piece.c, 2, acceleration);
    return {Evaluate(piece.c, u), Evaluate(velocity, u) / T, Evaluate(acceleration, u) / (T * T)};
  }
  return {last_.position, 0, 0};
}

double JointPath::end_s() const {
  return pieces_.empty() ? start_s_ : pieces_.back().start_s + pieces_.back().duration_s;
}

bool JointPath::moves() const {
  for (const Piece& piece : pieces_) {
    for (int k = 1; k <= kDegree; ++k) {
      if (piece.c[k] != 0) return true;
    }
  }
  return false;
}

JointPath::Extreme JointPath::Find(int order, int sign) const {
  const auto better = [sign](double value, double than) {
    return sign > 0 ? value > than : sign < 0 ? value < than : std::abs(value) > std::abs(than);
  };
  Extreme best;
  best.t_s = start_s_;
  best.value = order == 0 ? first_.position : 0;
  for (const Piece& piece : pieces_) {
    double f[kDegree + 1], next[kDegree + 1];
    Derivative(piece.c, order, f);
    Derivative(piece.c, order + 1, next);
    std::vector<double> candidates = SignChanges(next);
    candidates.push_back(0);
    candidates.push_back(1);
    const double scale = std::pow(piece.duration_s, -order);
    for (double u : candidates) {
      const double value = Evaluate(f, u) * scale;
      if (better(value, best.value)) best = {value, piece.start_s + u * piece.duration_s};
    }
  }
  if (sign == 0) best.value = std::abs(best.value);
  return best;
}

JointPath::Extreme JointPath::peak_velocity() const { return Find(1, 0); }
JointPath::Extreme JointPath::peak_acceleration() const { return Find(2, 0); }
JointPath::Extreme JointPath::lowest() const { return Find(0, -1); }
JointPath::Extreme JointPath::highest() const { return Find(0, 1); }

double JointPath::NextWaypoint(double t_s) const {
  for (double turn : turns_) {
    if (turn > t_s) return At(turn).position;
  }
  return last_.position;
}

JointPath JointPath::Chirp(double centre, double amplitude, double from_hz, double to_hz,
                           double duration_s) {
  const double fade_in = 1 / from_hz, fade_out = 1 / to_hz;
  // The envelope w and its first two derivatives at t.
  const auto envelope = [&](double t, double& w, double& dw, double& ddw) {
    w = 1;
    dw = ddw = 0;
    double u = 0, span = 0, sign = 1;
    if (t < fade_in) {
      u = t / fade_in;
      span = fade_in;
    } else if (t > duration_s - fade_out) {
      u = (duration_s - t) / fade_out;
      span = fade_out;
      sign = -1;
    } else {
      return;
    }
    w = u * u * u * (10 + u * (-15 + 6 * u));
    dw = sign * u * u * (30 + u * (-60 + 30 * u)) / span;
    ddw = u * (60 + u * (-180 + 120 * u)) / (span * span);
  };
  const double sweep = (to_hz - from_hz) / duration_s;  // Hz per s
  const double step = 1 / (64 * std::max(from_hz, to_hz));
  const auto count = static_cast<int64_t>(std::ceil(duration_s / step));
  std::vector<Knot> knots;
  for (int64_t k = 0; k <= count; ++k) {
    const double t =
        std::min(duration_s, static_cast<double>(k) * duration_s / static_cast<double>(count));
    double w = 0, dw = 0, ddw = 0;
    envelope(t, w, dw, ddw);
    const double phase = 2 * kPi * (from_hz * t + sweep * t * t / 2);
    const double rate = 2 * kPi * (from_hz + sweep * t);  // d phase / dt
    const double s = std::sin(phase), c = std::cos(phase);
    Knot knot;
    knot.t_s = t;
    const bool end = k == 0 || k == count;  // exactly at rest on the centre
    knot.at.position = end ? centre : centre + amplitude * w * s;
    knot.at.velocity = end ? 0 : amplitude * (dw * s + w * c * rate);
    knot.at.acceleration = end ? 0
                               : amplitude * (ddw * s + 2 * dw * c * rate +
                                              w * (c * 2 * kPi * sweep - s * rate * rate));
    knots.push_back(knot);
  }
  return JointPath(std::move(knots));
}

Path Path::OneJoint(const std::vector<double>& start, int joint, JointPath path) {
  std::vector<JointPath> joints;
  for (size_t j = 0; j < start.size(); ++j) {
    joints.push_back(static_cast<int>(j) == joint ? path : JointPath::Hold(start[j]));
  }
  return Path(std::move(joints));
}

Path Path::Spline(const std::vector<double>& start, const std::vector<double>& times_s,
                  const std::vector<std::vector<double>>& poses) {
  // Knot 0 is the start at time 0; m intervals.
  std::vector<double> t = {0};
  t.insert(t.end(), times_s.begin(), times_s.end());
  const size_t m = times_s.size();
  std::vector<JointPath> joints;
  for (size_t j = 0; j < start.size(); ++j) {
    std::vector<double> y = {start[j]};
    for (const std::vector<double>& pose : poses) y.push_back(pose.at(j));
    // The clamped cubic spline (velocity 0 at both ends): its second derivatives M solve a
    // tridiagonal system (Thomas algorithm).
    std::vector<double> h(m), lower(m + 1, 0), diag(m + 1, 0), upper(m + 1, 0), rhs(m + 1, 0);
    for (size_t i = 0; i < m; ++i) h[i] = t[i + 1] - t[i];
    const auto slope = [&](size_t i) { return (y[i + 1] - y[i]) / h[i]; };
    diag[0] = 2 * h[0];
    upper[0] = h[0];
    rhs[0] = 6 * slope(0);
    for (size_t i = 1; i < m; ++i) {
      lower[i] = h[i - 1];
      diag[i] = 2 * (h[i - 1] + h[i]);
      upper[i] = h[i];
      rhs[i] = 6 * (slope(i) - slope(i - 1));
    }
    lower[m] = h[m - 1];
    diag[m] = 2 * h[m - 1];
    rhs[m] = -6 * slope(m - 1);
    for (size_t i = 1; i <= m; ++i) {
      const double w = lower[i] / diag[i - 1];
      diag[i] -= w * upper[i - 1];
      rhs[i] -= w * rhs[i - 1];
    }
    std::vector<double> M(m + 1);
    M[m] = rhs[m] / diag[m];
    for (size_t i = m; i-- > 0;) M[i] = (rhs[i] - upper[i] * M[i + 1]) / diag[i];
    std::vector<JointPath::Knot> knots;
    for (size_t i = 0; i <= m; ++i) {
      JointPath::Knot knot;
      knot.t_s = t[i];
      knot.at.position = y[i];
      // At rest at both ends; inside, the cubic spline's velocity and acceleration.
      if (i > 0 && i < m) {
        knot.at.velocity = slope(i) - h[i] * (2 * M[i] + M[i + 1]) / 6;
        knot.at.acceleration = M[i];
      }
      knots.push_back(knot);
    }
    joints.emplace_back(std::move(knots));
  }
  return Path(std::move(joints));
}

double Path::end_s() const {
  double end = 0;
  for (const JointPath& joint : joints_) end = std::max(end, joint.end_s());
  return end;
}

namespace {

// One moving joint as FollowPlanLines writes it: how the plan parser turns the written number back
// into SI (control/plan.cpp), its caps, the path's peaks, and floors for a move's speed and
// acceleration (a move needs both above 0; these are far below what changes the profile: the speed
// is reached within a tick, the path is at rest there).
struct Written {
  Written(const JointPath& path, const core::RobotModel& model, size_t j) {
    const core::MotionLimits limits = core::DefaultMotionLimits(model);
    scale = Shown(model, j);
    unit = model.joints[j].type == core::JointType::kRevolute ? M_PI / 180.0 : 1e-3;
    a_cap = limits.acceleration_max[j];
    v_cap = model.joints[j].velocity_max * limits.velocity_cap_fraction;
    v_peak = path.peak_velocity().value;
    a_peak = path.peak_acceleration().value;
    v_floor = 1e-4 * v_peak;
    a_floor = 1e-3 * a_peak;
  }
  // The values the plan holds, as sirupp-control reads them back.
  double Rate(double si) const { return std::strtod(Short(si * scale).c_str(), nullptr) * unit; }
  double Goal(double si) const {
    return std::strtod(grade::Goal(si * scale).c_str(), nullptr) * unit;
  }
  double scale = 0, unit = 0, a_cap = 0, v_cap = 0, v_floor = 0, a_floor = 0, v_peak = 0,
         a_peak = 0;
};

// A knot's move for one joint: its goal (the turning point ahead), top speed and acceleration.
struct KnotMove {
  double waypoint = 0, speed = 0, accel = 0;
};

// The move of the knot from t0 to t0 + knot_s before the chip's trial: the path's speed half a
// tick before the knot's end (the profile adds each tick's velocity to its position), and the
// change of speed over the knot.
KnotMove Nominal(const JointPath& p, const Written& c, double t0, double knot_s, double tick_s) {
  const double t1 = t0 + knot_s;
  const double v0 = p.At(t0 - tick_s / 2).velocity;
  const double v1 = p.At(t1 - tick_s / 2).velocity;
  KnotMove move;
  move.waypoint = p.NextWaypoint(t0);
  double a = std::abs(v1 - v0) / knot_s;
  // The chip slows down when it could no longer stop on its goal (the turning point ahead): the
  // acceleration must allow the speed it is to have at the knot's end.
  const double left = std::abs(move.waypoint - p.At(t1).position);
  if (left > 1e-9 * c.v_peak) a = std::max(a, 1.5 * v1 * v1 / (2 * left));
  move.accel = std::clamp(a, c.a_floor, c.a_cap);
  move.speed = std::clamp(std::abs(v1), c.v_floor, c.v_cap);
  return move;
}

}  // namespace

std::string FollowPlanLines(const Path& path, const core::RobotModel& model,
                            const std::vector<double>& start, int knot_ticks) {
  const size_t n = start.size();
  std::vector<size_t> moving;
  std::vector<Written> joints;  // per moving joint
  for (size_t j = 0; j < n; ++j) {
    if (!path.joint(j).moves()) continue;
    moving.push_back(j);
    joints.emplace_back(path.joint(j), model, j);
  }
  const double knot_s = knot_ticks * model.servo_tick_s;

  // The chip itself (the profile generators sirupp-control runs), to see where each knot's moves
  // take the set-points before writing them. The joints' profiles are independent.
  control::ServoBank bank(model);
  bank.ServoOn(start);
  std::vector<control::JointMove> moves(n);
  std::vector<double> positions = start;
  const auto run = [&](control::ServoBank& chip) {
    chip.Load(moves);
    for (int k = 0; k < knot_ticks; ++k) {
      for (size_t j = 0; j < n; ++j) positions[j] = chip.SetpointPosition(static_cast<int>(j));
      chip.Tick(positions);
    }
  };

  std::ostringstream plan;
  const std::string wait = core::FormatNumber(knot_s);
  std::vector<KnotMove> knot(moving.size());
  // The plan's first step runs at tick 1, and a move loads and the profile steps in the same
  // tick, so the knot k (its moves loaded at tick 1 + k * knot_ticks) takes the set-point to the
  // path's position at (k + 1) * knot_s. Its speed is corrected by half the error the chip would
  // leave at the knot's end: a feedback that halves any drift from knot to knot.
  for (int64_t k = 0;; ++k) {
    const double t0 = static_cast<double>(k) * knot_s;
    if (t0 >= path.end_s()) break;
    for (size_t i = 0; i < moving.size(); ++i) {
      const Written& c = joints[i];
      knot[i] = Nominal(path.joint(moving[i]), c, t0, knot_s, model.servo_tick_s);
      moves[moving[i]] = {true, c.Goal(knot[i].waypoint), c.Rate(knot[i].speed),
                          c.Rate(knot[i].accel)};
    }
    control::ServoBank trial = bank;
    run(trial);
    for (size_t i = 0; i < moving.size(); ++i) {
      const Written& c = joints[i];
      KnotMove& m = knot[i];
      const int joint = static_cast<int>(moving[i]);
      const double direction = m.waypoint >= bank.SetpointPosition(joint) ? 1 : -1;
      const double error =
          trial.SetpointPosition(joint) - path.joint(moving[i]).At(t0 + knot_s).position;
      m.speed = std::clamp(m.speed - direction * error / knot_s, c.v_floor, c.v_cap);
      // Enough acceleration to reach the corrected speed within the knot.
      m.accel = std::clamp(
          std::max(m.accel, std::abs(m.speed - std::abs(bank.SetpointVelocity(joint))) / knot_s),
          c.a_floor, c.a_cap);
      moves[moving[i]] = {true, c.Goal(m.waypoint), c.Rate(m.speed), c.Rate(m.accel)};
      plan << "move j" << joint + 1 << "=" << Goal(m.waypoint * c.scale)
           << " speed=" << Short(m.speed * c.scale) << " accel=" << Short(m.accel * c.scale)
           << "\n";
    }
    run(bank);
    plan << "wait " << wait << "\n";
  }
  // Onto the last point at the path's own pace, should the profile be short of it.
  for (size_t i = 0; i < moving.size(); ++i) {
    const Written& c = joints[i];
    plan << "move j" << moving[i] + 1 << "="
         << Goal(path.joint(moving[i]).At(path.end_s()).position * c.scale)
         << " speed=" << Short(std::min(c.v_peak, c.v_cap) * c.scale)
         << " accel=" << Short(std::min(c.a_peak, c.a_cap) * c.scale) << "\n";
  }
  plan << "wait done\n";
  return plan.str();
}

}  // namespace sirupp::grade
