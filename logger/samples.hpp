#pragma once
// What the logger takes from the bus (or from an LCM log file), as plain values: one Sample per
// joint-state message of the three streams the paper records, and the controller's plan status.
// Pure data; the bus side (logger_node) and the log reader (log_import) both produce these, so the
// alignment and the files are the same for a live run and a replayed one.

#include <cstdint>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <string>
#include <vector>

namespace sirupp::logger {

// The three streams of the paper's data files.
enum class Stream : int { kSetpoint = 0, kVirtual = 1, kReal = 2 };
inline constexpr int kNumStreams = 3;
inline constexpr Stream kAllStreams[kNumStreams] = {Stream::kSetpoint, Stream::kVirtual,
                                                    Stream::kReal};

// "set", "virt", "real": the column name parts.
const char* StreamKey(Stream stream);
// "set-point", "virtual", "real": for people.
const char* StreamTitle(Stream stream);

// Which clock a sample's utime is on.
enum class SampleClock { kSim, kWall };

// One message of one stream. Units as on the wire: rad, rad/s, N*m (m, m/s, N for prismatic).
struct Sample {
  Stream stream = Stream::kVirtual;
  SampleClock clock = SampleClock::kSim;
  int64_t utime = 0;        // the message's own utime (sim time, or wall clock for a real arm)
  int64_t recv_utime = 0;   // wall clock when it was received (an LCM log: the event timestamp)
  int64_t lost_before = 0;  // messages missing before this one (seq gaps, queue overflow)
  int8_t source = 0;        // arm_state_t::SOURCE_* (real stream), 0 otherwise
  int64_t move_id = -1;     // set-point stream: the move in progress
  std::vector<double> position;
  std::vector<double> velocity;
  std::vector<double> effort;
  std::vector<int8_t> done;  // set-point stream: 1 when the joint's profile has finished
};

// The part of controller_status_t that splits a run into movement sets.
struct PlanStatus {
  int64_t utime = 0;  // sim time
  int64_t recv_utime = 0;
  std::string plan_name;  // empty when no plan
  int32_t plan_step = -1;
  int32_t plan_steps = 0;
  int8_t mode = 0;  // controller_status_t::MODE_*
};

// Where a servo_gains_t came from: ARM_GAINS (a request to change them), CONTROLLER_GAINS (the
// gains the virtual servos run with) or REAL_ARM_GAINS (the gains loaded into the real boards).
enum class GainsSource : int { kRequest = 0, kController = 1, kReal = 2 };
inline constexpr int kNumGainsSources = 3;
const char* GainsSourceTitle(GainsSource source);  // "requested", "virtual servos", "real boards"

// One servo_gains_t (chip units): for file headers and the gain-change lines of the data files.
struct GainsRecord {
  GainsSource source = GainsSource::kRequest;
  int64_t utime = 0;
  int64_t recv_utime = 0;  // wall clock when received
  std::vector<double> kp, kd, ki, integration_limit, output_limit, current_limit, error_limit,
      servo_rate_divisor, deadband;
};
inline constexpr int kNumGainFields = 9;
const char* GainFieldName(int field);  // "kp", "kd", "ki", "integration_limit", ...
const std::vector<double>& GainField(const GainsRecord& gains, int field);

// What changed from `before` to `after`, per joint: "j2 kp 100 -> 120, kd 1000 -> 900; j3 ki 0 ->
// 5"; "" when nothing did.
std::string DescribeGainsChange(const GainsRecord& before, const GainsRecord& after);
// Every value: "kp 100 100 ...; kd ...; ...".
std::string DescribeGains(const GainsRecord& gains);

// The real-time factor of a stretch of sim samples: sim time elapsed over wall time elapsed (the
// sim's utime against the receive time), 0.5 when the sim ran at half the wall clock's pace.
class ClockRate {
 public:
  void Add(int64_t sim_utime, int64_t wall_utime);
  void Reset() { have_ = false; }
  // Known once the samples span at least 0.1 s of wall clock.
  bool known() const;
  double factor() const;  // NaN while not known
  double sim_s() const;
  double wall_s() const;
  // "0.50012 (sim 10.240 s over wall 20.475 s)", or "not known yet".
  std::string Describe() const;

 private:
  bool have_ = false;
  int64_t first_sim_ = 0, first_wall_ = 0, last_sim_ = 0, last_wall_ = 0;
};

// Keeps the running count of missing sequence numbers of one channel, with the Bus's rule: a gap
// of k counts k; a smaller seq (the publisher restarted) counts nothing and starts afresh.
class SequenceCounter {
 public:
  // Messages missing before `seq`.
  int64_t Next(int64_t seq);

 private:
  bool have_ = false;
  int64_t last_ = 0;
};

}  // namespace sirupp::logger

// ---- From messages
// ------------------------------------------------------------------------------- (Here so that the
// live logger and the log importer convert messages the same way.)
namespace sirupp::logger {

// A joint state as a sample of `stream` (kVirtual or kReal). A real-arm state whose source is
// SOURCE_SIM is on the sim clock (a second sim standing in for the arm); REAL and EMULATED are on
// the wall clock.
Sample SampleFromArmState(const sirupp::arm_state_t& message, Stream stream, int64_t recv_utime);
Sample SampleFromSetpoint(const sirupp::servo_setpoint_t& message, int64_t recv_utime);
PlanStatus StatusFromMessage(const sirupp::controller_status_t& message, int64_t recv_utime);
GainsRecord GainsFromMessage(const sirupp::servo_gains_t& message, GainsSource source,
                             int64_t recv_utime);

}  // namespace sirupp::logger
