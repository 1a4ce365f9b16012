#include "logger/log_import.hpp"

#include <filesystem>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>

#include "core/errors.hpp"
#include "core/printable.hpp"
#include "core/tick_batch.hpp"
#include "logger/lcm_log.hpp"

namespace sirupp::logger {

namespace {

template <class Msg>
Msg Decode(const LcmLogReader& reader, const LcmLogEvent& event) {
  Msg message{};
  int status = -1;
  try {
    status = message.decode(event.data.data(), 0, static_cast<int>(event.data.size()));
  } catch (const std::exception&) {
    status = -1;
  }
  if (status < 0) {
    throw core::ConfigError(
        core::SourceLocation{reader.path(), 0, 0},
        "byte " + std::to_string(event.offset) + " (event " + std::to_string(event.index) + ")",
        "channel " + core::Printable(event.channel, 256) + ": the data does not decode as sirupp." +
            Msg::getTypeName() + " (another type, or damaged)");
  }
  return message;
}

class Importer {
 public:
  Importer(const std::string& path, const ImportOptions& options)
      : path_(path), options_(options), aligner_(options.aligner) {}

  std::vector<RunTable> Run() {
    FindJoints();
    LcmLogReader reader(path_);
    LcmLogEvent event;
    while (reader.Next(event)) {
      const Channels& c = options_.channels;
      if (event.channel == c.sim_arm_state || event.channel == c.real_arm_state) {
        AddArmState(reader, event, Decode<sirupp::arm_state_t>(reader, event),
                    event.channel == c.real_arm_state, event.timestamp_us);
      } else if (event.channel == c.arm_setpoint) {
        AddSetpoint(reader, event, Decode<sirupp::servo_setpoint_t>(reader, event),
                    event.timestamp_us);
      } else if (event.channel == c.sim_arm_ticks) {
        // Several ticks of SIM_ARM_STATE and ARM_SETPOINT, each at the time it would have come
        // alone (core/tick_batch.hpp).
        const auto batch = Decode<sirupp::arm_ticks_t>(reader, event);
        for (size_t k = 0; k < batch.states.size(); ++k) {
          AddArmState(
              reader, event, batch.states[k], false,
              core::TickReceiveTime(event.timestamp_us, batch.sent_utime, batch.state_utime[k]));
        }
        for (size_t k = 0; k < batch.setpoints.size(); ++k) {
          AddSetpoint(
              reader, event, batch.setpoints[k],
              core::TickReceiveTime(event.timestamp_us, batch.sent_utime, batch.setpoint_utime[k]));
        }
      } else if (event.channel == c.controller_status) {
        aligner_.AddStatus(StatusFromMessage(Decode<sirupp::controller_status_t>(reader, event),
                                             event.timestamp_us));
      } else {
        continue;
      }
      aligner_.TakeRows(event.timestamp_us, false, [this](const Row& row) { Take(row); });
    }
    aligner_.TakeRows(0, true, [this](const Row& row) { Take(row); });
    if (tables_.empty()) {
      throw core::ConfigError(
          core::SourceLocation{path_, 0, 0}, "",
          "no joint states in this LCM log (channels " + options_.channels.arm_setpoint + ", " +
              options_.channels.sim_arm_state + ", " + options_.channels.real_arm_state +
              "); with a rig prefix, give it with --prefix");
    }
    rates_.resize(tables_.size());
    const bool real_on_sim_clock = aligner_.real_sources() == 1 << sirupp::arm_state_t::SOURCE_SIM;
    for (size_t t = 0; t < tables_.size(); ++t) {
      RunTable& table = tables_[t];
      for (const std::string& note : reader.notes()) table.notes.push_back(note);
      table.closed = true;
      table.realtime_factor = rates_[t].factor();
      table.real_on_sim_clock = real_on_sim_clock;
    }
    return std::move(tables_);
  }

 private:
  using Channels = core::Channels;

  void AddArmState(const LcmLogReader& reader, const LcmLogEvent& event,
                   const sirupp::arm_state_t& message, bool real, int64_t recv_utime) {
    CheckJoints(reader, event, message.num_joints);
    Sample sample =
        SampleFromArmState(message, real ? Stream::kReal : Stream::kVirtual, recv_utime);
    sample.lost_before = (real ? real_seq_ : virt_seq_).Next(message.seq);
    aligner_.Add(std::move(sample));
  }

  void AddSetpoint(const LcmLogReader& reader, const LcmLogEvent& event,
                   const sirupp::servo_setpoint_t& message, int64_t recv_utime) {
    CheckJoints(reader, event, message.num_joints);
    Sample sample = SampleFromSetpoint(message, recv_utime);
    sample.lost_before = set_seq_.Next(message.seq);
    aligner_.Add(std::move(sample));
  }

  // The joints from the first ROBOT_MODEL (names, prismatic or not), else revolute joints counted
  // from the first joint-state message.
  void FindJoints() {
    LcmLogReader reader(path_);
    LcmLogEvent event;
    const Channels& c = options_.channels;
    int count = -1;
    while (reader.Next(event)) {
      if (event.channel == c.robot_model) {
        const auto model = Decode<sirupp::robot_model_t>(reader, event);
        joints_.clear();
        for (const auto& joint : model.joints) {
          joints_.push_back({joint.name, joint.type == sirupp::joint_model_t::TYPE_PRISMATIC});
        }
        model_name_ = model.name;
        return;
      }
      if (count < 0 && (event.channel == c.sim_arm_state || event.channel == c.real_arm_state)) {
        count = Decode<sirupp::arm_state_t>(reader, event).num_joints;
      } else if (count < 0 && event.channel == c.arm_setpoint) {
        count = Decode<sirupp::servo_setpoint_t>(reader, event).num_joints;
      } else if (count < 0 && event.channel == c.sim_arm_ticks) {
        const auto batch = Decode<sirupp::arm_ticks_t>(reader, event);
        if (!batch.states.empty()) count = batch.states.front().num_joints;
      }
    }
    if (count > 0 && count <= 64) joints_.assign(static_cast<size_t>(count), JointInfo{});
  }

  void CheckJoints(const LcmLogReader& reader, const LcmLogEvent& event, int32_t count) {
    if (count != static_cast<int32_t>(joints_.size())) {
      throw core::ConfigError(
          core::SourceLocation{reader.path(), 0, 0},
          "byte " + std::to_string(event.offset) + " (event " + std::to_string(event.index) + ")",
          "channel " + core::Printable(event.channel, 256) + ": num_joints " +
              std::to_string(count) + "; the run's " +
              (model_name_.empty() ? "first message has " : "model " + model_name_ + " has ") +
              std::to_string(joints_.size()));
    }
  }

  void Take(const Row& row) {
    const int key_plan = options_.split_per_plan ? row.plan_run : 0;
    if (tables_.empty() || row.run != current_run_ || key_plan != current_plan_) {
      current_run_ = row.run;
      current_plan_ = key_plan;
      RunTable table;
      table.Reset(joints_);
      table.source = path_;
      const std::string plan =
          options_.split_per_plan
              ? aligner_.plan_runs()[static_cast<size_t>(row.plan_run)].plan_name
              : "";
      table.plan_name = plan;
      table.label = plan.empty() ? std::filesystem::path(path_).stem().string() : PlanLabel(plan);
      tables_.push_back(std::move(table));
    }
    tables_.back().Append(row);
    // The real-time factor of each table: the virtual arm's sim time against the log's receive
    // times.
    const auto v = static_cast<size_t>(Stream::kVirtual);
    if (rates_.size() < tables_.size()) rates_.resize(tables_.size());
    const Sample* virt = row.cell[v];
    if (virt != nullptr && row.age_us[v] == 0 && virt->recv_utime > 0) {
      rates_[tables_.size() - 1].Add(virt->utime, virt->recv_utime);
    }
  }

  std::string path_;
  ImportOptions options_;
  Aligner aligner_;
  std::vector<JointInfo> joints_;
  std::string model_name_;
  SequenceCounter set_seq_, virt_seq_, real_seq_;
  std::vector<RunTable> tables_;
  std::vector<ClockRate> rates_;  // per table
  int current_run_ = -1;
  int current_plan_ = -1;
};

}  // namespace

std::vector<RunTable> ImportLcmLog(const std::string& path, const ImportOptions& options) {
  return Importer(path, options).Run();
}

}  // namespace sirupp::logger
