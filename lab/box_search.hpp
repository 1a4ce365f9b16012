#pragma once
// Nelder-Mead on the unit box [0, 1]^n (points clamped into it), restarted around the best point
// with a smaller simplex whenever the simplex collapses. Ask-and-tell: the caller asks for the
// next point, evaluates it however it likes and tells the cost, so several searches can share one
// evaluation (identify.cpp runs one per joint on the same simulation) or stop at any budget. The
// fit of the emulated arm (emulator_fit.cpp) and the identification (identify.cpp) use it.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace sirupp::lab {

// One coordinate of the box: x = min + u (max - min), or min (max / min)^u on a log scale, for u
// in [0, 1] (clamped; x clamped into [min, max] the other way).
struct BoxAxis {
  double min, max;
  bool log_scale;
  double FromUnit(double u) const {
    u = std::clamp(u, 0.0, 1.0);
    return log_scale ? min * std::pow(max / min, u) : min + u * (max - min);
  }
  double ToUnit(double x) const {
    x = std::clamp(x, min, max);
    return log_scale ? std::log(x / min) / std::log(max / min) : (x - min) / (max - min);
  }
};

class BoxSearch {
 public:
  // From `start` (clamped into the box) whose cost is `start_cost`; the first simplex's edges are
  // `size` long, each restart's half the last (at least `min_size`); a simplex collapses when no
  // vertex is more than `tolerance` from the best in any coordinate.
  BoxSearch(std::vector<double> start, double start_cost, double size = 0.15,
            double min_size = 0.03, double tolerance = 0.004);

  // The next point to evaluate; Tell its cost before asking again.
  const std::vector<double>& Ask() const { return pending_; }
  void Tell(double cost);

  const std::vector<double>& best() const { return best_; }
  double best_cost() const { return best_cost_; }
  int restarts() const { return restarts_; }

 private:
  enum class Phase { kInit, kReflect, kExpand, kContract, kShrink };
  void Restart();  // a new simplex around the best point
  void Iterate();  // the next reflection (or a restart if the simplex has collapsed)
  std::vector<double> Along(double t) const;  // mean + t (worst - mean), clamped
  void Replace(size_t i, const std::vector<double>& u, double cost);

  size_t n_;
  std::vector<std::vector<double>> simplex_;
  std::vector<double> f_;
  std::vector<double> best_;
  double best_cost_;
  double size_, min_size_, tolerance_;
  int restarts_ = 0;
  Phase phase_ = Phase::kInit;
  size_t index_ = 0;                     // kInit, kShrink: the vertex being evaluated
  size_t lo_ = 0, hi_ = 0, second_ = 0;  // best, worst and second-worst vertex
  std::vector<double> mean_, reflected_, pending_;
  double reflected_cost_ = 0;
};

}  // namespace sirupp::lab
