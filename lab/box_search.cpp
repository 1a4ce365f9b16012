#include "lab/box_search.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sirupp::lab {

BoxSearch::BoxSearch(std::vector<double> start, double start_cost, double size, double min_size,
                     double tolerance)
    : n_(start.size()),
      best_(std::move(start)),
      best_cost_(start_cost),
      size_(size),
      min_size_(min_size),
      tolerance_(tolerance) {
  for (double& x : best_) x = std::clamp(x, 0.0, 1.0);
  restarts_ = -1;  // the first simplex is not a restart
  Restart();
}

void BoxSearch::Restart() {
  ++restarts_;
  simplex_.assign(n_ + 1, best_);
  f_.assign(n_ + 1, best_cost_);
  for (size_t i = 0; i < n_; ++i) {
    double& u = simplex_[i + 1][i];
    u = u + size_ <= 1 ? u + size_ : u - size_;
  }
  phase_ = Phase::kInit;
  index_ = 1;
  if (n_ == 0) {
    pending_ = best_;  // nothing to search: the start again, for ever
    return;
  }
  pending_ = simplex_[index_];
}

std::vector<double> BoxSearch::Along(double t) const {
  std::vector<double> u(n_);
  for (size_t d = 0; d < n_; ++d) {
    u[d] = std::clamp(mean_[d] + t * (simplex_[hi_][d] - mean_[d]), 0.0, 1.0);
  }
  return u;
}

void BoxSearch::Replace(size_t i, const std::vector<double>& u, double cost) {
  simplex_[i] = u;
  f_[i] = cost;
}

void BoxSearch::Iterate() {
  std::vector<size_t> order(n_ + 1);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return f_[a] < f_[b]; });
  lo_ = order[0];
  hi_ = order[n_];
  second_ = order[n_ - 1];
  double spread = 0;
  for (size_t i = 0; i <= n_; ++i) {
    for (size_t d = 0; d < n_; ++d) {
      spread = std::max(spread, std::abs(simplex_[i][d] - simplex_[lo_][d]));
    }
  }
  if (spread < tolerance_) {
    size_ = std::max(min_size_, size_ / 2);
    Restart();
    return;
  }
  mean_.assign(n_, 0.0);
  for (size_t i = 0; i <= n_; ++i) {
    if (i == hi_) continue;
    for (size_t d = 0; d < n_; ++d) mean_[d] += simplex_[i][d] / static_cast<double>(n_);
  }
  reflected_ = Along(-1);
  pending_ = reflected_;
  phase_ = Phase::kReflect;
}

void BoxSearch::Tell(double cost) {
  if (cost < best_cost_) {
    best_cost_ = cost;
    best_ = pending_;
  }
  if (n_ == 0) return;
  switch (phase_) {
    case Phase::kInit:
      f_[index_] = cost;
      if (++index_ <= n_) {
        pending_ = simplex_[index_];
      } else {
        Iterate();
      }
      return;
    case Phase::kReflect:
      reflected_cost_ = cost;
      if (cost < f_[lo_]) {
        pending_ = Along(-2);
        phase_ = Phase::kExpand;
      } else if (cost < f_[second_]) {
        Replace(hi_, reflected_, cost);
        Iterate();
      } else {
        pending_ = Along(cost < f_[hi_] ? -0.5 : 0.5);
        phase_ = Phase::kContract;
      }
      return;
    case Phase::kExpand:
      if (cost < reflected_cost_) {
        Replace(hi_, pending_, cost);
      } else {
        Replace(hi_, reflected_, reflected_cost_);
      }
      Iterate();
      return;
    case Phase::kContract:
      if (cost < std::min(reflected_cost_, f_[hi_])) {
        Replace(hi_, pending_, cost);
        Iterate();
        return;
      }
      // Shrink every vertex towards the best, evaluating them in turn.
      for (size_t i = 0; i <= n_; ++i) {
        if (i == lo_) continue;
        for (size_t d = 0; d < n_; ++d) {
          simplex_[i][d] = simplex_[lo_][d] + 0.5 * (simplex_[i][d] - simplex_[lo_][d]);
        }
      }
      index_ = lo_ == 0 ? 1 : 0;
      pending_ = simplex_[index_];
      phase_ = Phase::kShrink;
      return;
    case Phase::kShrink:
      f_[index_] = cost;
      do {
        ++index_;
      } while (index_ == lo_);
      if (index_ <= n_) {
        pending_ = simplex_[index_];
      } else {
        Iterate();
      }
      return;
  }
}

}  // namespace sirupp::lab
