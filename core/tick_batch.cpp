#include "core/tick_batch.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace sirupp::core {

TickBatch::TickBatch(int max_ticks) : max_ticks_(max_ticks) {
  if (max_ticks < 1 || max_ticks > kTickBatchMaxTicks) {
    throw std::invalid_argument("tick batch of " + std::to_string(max_ticks) +
                                " ticks: allowed 1 to " + std::to_string(kTickBatchMaxTicks));
  }
}

void TickBatch::Add(const sirupp::arm_state_t& state, int64_t made_utime) {
  batch_.states.push_back(state);
  batch_.state_utime.push_back(made_utime);
  ++batch_.num_states;
  // Nested, a message has no fingerprint of its own (8 bytes less than alone); its made_utime
  // takes those 8 bytes.
  last_state_ = state.getEncodedSize();
  bytes_ += last_state_;
}

void TickBatch::Add(const sirupp::servo_setpoint_t& setpoint, int64_t made_utime) {
  batch_.setpoints.push_back(setpoint);
  batch_.setpoint_utime.push_back(made_utime);
  ++batch_.num_setpoints;
  const int size = setpoint.getEncodedSize();  // as for a state
  bytes_ += size;
  largest_tick_ = std::max(largest_tick_, last_state_ + size);
}

bool TickBatch::Full() const {
  if (batch_.num_states >= max_ticks_) return true;
  return bytes_ + std::max(largest_tick_, last_state_) > kTickBatchMaxBytes;
}

const sirupp::arm_ticks_t& TickBatch::Take(int64_t sent_utime) {
  batch_.sent_utime = sent_utime;
  batch_.seq = seq_++;
  std::swap(taken_, batch_);
  // Keep the vectors' capacity: the next batch fills them again.
  batch_.num_states = 0;
  batch_.num_setpoints = 0;
  batch_.states.clear();
  batch_.state_utime.clear();
  batch_.setpoints.clear();
  batch_.setpoint_utime.clear();
  bytes_ = kEmptyBytes;
  return taken_;
}

int64_t TickReceiveTime(int64_t recv_utime, int64_t sent_utime, int64_t made_utime) {
  const int64_t waited = sent_utime - made_utime;
  return waited > 0 ? recv_utime - waited : recv_utime;
}

void CheckTickBatch(const sirupp::arm_ticks_t& batch) {
  if (batch.num_states < 0 || static_cast<size_t>(batch.num_states) != batch.states.size() ||
      batch.states.size() != batch.state_utime.size() || batch.num_setpoints < 0 ||
      static_cast<size_t>(batch.num_setpoints) != batch.setpoints.size() ||
      batch.setpoints.size() != batch.setpoint_utime.size()) {
    throw std::invalid_argument("num_states " + std::to_string(batch.num_states) +
                                " and num_setpoints " + std::to_string(batch.num_setpoints) +
                                " do not match the batch's arrays");
  }
}

}  // namespace sirupp::core
