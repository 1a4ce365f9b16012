#include "planning/sweep.hpp"

#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::planning {

SetpointSweep::SetpointSweep(CollisionModel& model, double step_rad)
    : model_(model), step_(step_rad) {
  if (!(step_rad > 0 && step_rad <= 1)) {
    throw std::invalid_argument("sweep step " + core::FormatNumber(step_rad) +
                                " rad: allowed (0, 1] rad");
  }
  free_reported_.assign(model.environment().objects.size(), false);
}

std::optional<SweepFinding> SetpointSweep::Feed(const JointVector& state, double time_s, int step,
                                                bool force) {
  if (error_) return error_;
  const bool due =
      force || last_.size() == 0 || (state - last_).cwiseAbs().maxCoeff() >= step_ - 1e-12;
  if (!due) return std::nullopt;
  last_ = state;
  ++checked_;
  for (const Contact& contact : model_.Contacts(state)) {
    SweepFinding finding{contact, state, time_s, step};
    if (contact.kind == ContactKind::kFreeObject) {
      const auto object = static_cast<size_t>(contact.object);
      if (!free_reported_[object]) {
        free_reported_[object] = true;
        free_touches_.push_back(finding);
      }
      continue;
    }
    // The deepest error at this state.
    if (!error_ || contact.depth_m > error_->contact.depth_m) error_ = finding;
  }
  return error_;
}

}  // namespace sirupp::planning
