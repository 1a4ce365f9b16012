#include "logger/raw_settings.hpp"

#include <sirupp/logger_pass_t.hpp>

#include "core/errors.hpp"
#include "core/translate.hpp"
#include "logger/lcm_log.hpp"

namespace sirupp::logger {

void PutSettings(const LoggerOptions& options, const core::RobotModel& model,
                 const std::string& prefix, core::LoggerPass& pass) {
  pass.period_us = options.aligner.period_us;
  pass.max_age_us = options.aligner.max_age_us;
  pass.idle_us = options.aligner.idle_us;
  pass.split_per_plan = options.split_per_plan;
  pass.velocities = options.velocities;
  pass.efforts = options.efforts;
  pass.note = options.note;
  pass.model_file = model.source_file;
  pass.prefix = prefix;
}

core::ConfigError PassEventError(const std::string& log_path, const LcmLogEvent& event,
                                 const std::string& problem) {
  return core::ConfigError(core::SourceLocation{log_path, 0, 0},
                           "byte " + std::to_string(event.offset) + " (event " +
                               std::to_string(event.index) + ") on " + event.channel,
                           problem);
}

core::LoggerPass DecodePassEvent(const std::string& log_path, const LcmLogEvent& event) {
  sirupp::logger_pass_t message;
  const int size = static_cast<int>(event.data.size());
  if (message.decode(event.data.data(), 0, size) != size) {
    throw PassEventError(
        log_path, event,
        "the data does not decode as sirupp.logger_pass_t (a log of an older sirupp-logger?)");
  }
  try {
    return core::LoggerPassFromMessage(message, event.channel);
  } catch (const std::exception& e) {
    throw PassEventError(log_path, event, e.what());
  }
}

std::optional<core::LoggerPass> RecordedSettings(const std::string& log_path,
                                                 const std::optional<std::string>& prefix,
                                                 const core::Channels& channels) {
  const std::string suffix = channels.logger_pass.name();
  LcmLogReader reader(log_path);
  LcmLogEvent event;
  while (reader.Next(event)) {
    const std::string& c = event.channel;
    const bool ours = prefix ? c == *prefix + suffix
                             : c.size() >= suffix.size() &&
                                   c.compare(c.size() - suffix.size(), suffix.size(), suffix) == 0;
    if (!ours) continue;
    return DecodePassEvent(log_path, event);
  }
  return std::nullopt;
}

}  // namespace sirupp::logger
