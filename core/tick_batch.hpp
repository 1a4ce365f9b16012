#pragma once
// Several servo ticks in one message (SIM_ARM_TICKS, lcmtypes/arm_ticks_t.lcm), both ends.
//
// While every participant lets sirupp-sim's boards drive the arm, nobody needs a tick the moment
// it is stepped: the sim then gathers each tick's SIM_ARM_STATE and ARM_SETPOINT messages in a
// TickBatch and sends them at the exchange tick, one datagram per 16 ticks where there were 32
// (docs/timing.md, "Several ticks in one message"). The Bus (core/bus.hpp) unpacks a batch for the
// subscriptions of SIM_ARM_STATE and ARM_SETPOINT with ForEachTick, so the logger, the viewer, the
// panel, Python and lcm-spy's readers get every tick as before, each with the receive time it would
// have had if sent alone (the batch's receive time less how long the tick waited in the batch).

#include <cstdint>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/arm_ticks_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <vector>

namespace sirupp::core {

// A batch is at most this many ticks and this many encoded bytes (a tick reader takes datagrams of
// up to 8192 bytes, core/tick_reader.cpp; a PUMA 260's 16 ticks take about 7.6 kB).
inline constexpr int kTickBatchMaxTicks = 64;
inline constexpr int kTickBatchMaxBytes = 8000;

// The sender's side: what has been gathered since the last Take().
class TickBatch {
 public:
  // max_ticks: 1..kTickBatchMaxTicks states per message (throws std::invalid_argument naming the
  // value otherwise).
  explicit TickBatch(int max_ticks);

  // made_utime: the wall clock when the message was made (microseconds since the Unix epoch).
  void Add(const sirupp::arm_state_t& state, int64_t made_utime);
  void Add(const sirupp::servo_setpoint_t& setpoint, int64_t made_utime);

  bool empty() const { return batch_.num_states == 0 && batch_.num_setpoints == 0; }
  // max_ticks states, or one more tick of the largest yet would pass kTickBatchMaxBytes.
  bool Full() const;
  // The message to send (seq counted here), and the batch empty again.
  const sirupp::arm_ticks_t& Take(int64_t sent_utime);

 private:
  // The encoded size of an empty batch: fingerprint, sent_utime, seq and the two counts.
  static constexpr int kEmptyBytes = 8 + 8 + 8 + 4 + 4;
  int max_ticks_;
  int64_t seq_ = 0;
  int bytes_ = kEmptyBytes;  // encoded size of the gathered messages and their times
  int largest_tick_ = 0;  // bytes of the largest state plus set-point added so far
  int last_state_ = 0;    // bytes of the last state added
  sirupp::arm_ticks_t batch_{};
  sirupp::arm_ticks_t taken_{};
};

// What one element of a batch is.
enum class TickKind { kState, kSetpoint };

// Calls fn(kind, encoded, size, recv_utime) for each state and set-point of `batch` in order
// (states first), each encoded as its own channel's message, with the receive time it would have
// had alone: recv_utime - (sent_utime - made_utime), never later than recv_utime. newest_only:
// only the last of each kind (a reader that draws the newest state). `scratch` holds the encoded
// bytes between calls (no allocation once grown). Throws std::invalid_argument when the batch's
// times do not match its counts (a decoded message always matches).
template <class Fn>
void ForEachTick(const sirupp::arm_ticks_t& batch, int64_t recv_utime, bool newest_only,
                 std::vector<uint8_t>& scratch, Fn&& fn);

// ---- implementation

int64_t TickReceiveTime(int64_t recv_utime, int64_t sent_utime, int64_t made_utime);
void CheckTickBatch(const sirupp::arm_ticks_t& batch);

template <class Msg>
int EncodeInto(const Msg& msg, std::vector<uint8_t>& scratch) {
  const int size = msg.getEncodedSize();
  scratch.resize(static_cast<size_t>(size));
  return msg.encode(scratch.data(), 0, size);
}

// Each of `messages` (all, or the last one) encoded, with its own receive time.
template <class Msg, class Fn>
void ForEachOf(const std::vector<Msg>& messages, const std::vector<int64_t>& made_utime,
               TickKind kind, int64_t recv_utime, int64_t sent_utime, bool newest_only,
               std::vector<uint8_t>& scratch, Fn& fn) {
  const size_t count = messages.size();
  for (size_t k = newest_only && count > 0 ? count - 1 : 0; k < count; ++k) {
    const int size = EncodeInto(messages[k], scratch);
    if (size < 0) continue;
    fn(kind, scratch.data(), size, TickReceiveTime(recv_utime, sent_utime, made_utime[k]));
  }
}

template <class Fn>
void ForEachTick(const sirupp::arm_ticks_t& batch, int64_t recv_utime, bool newest_only,
                 std::vector<uint8_t>& scratch, Fn&& fn) {
  CheckTickBatch(batch);
  ForEachOf(batch.states, batch.state_utime, TickKind::kState, recv_utime, batch.sent_utime,
            newest_only, scratch, fn);
  ForEachOf(batch.setpoints, batch.setpoint_utime, TickKind::kSetpoint, recv_utime,
            batch.sent_utime, newest_only, scratch, fn);
}

}  // namespace sirupp::core
