#pragma once
// The live logger's settings in its raw log: each LOGGER_PASS carries the settings that shape the
// data files (row clock, --max-age, --idle, --split, --velocities, --efforts, --note, the model
// file and the channel prefix), so that `sirupp-logger --from-log LOG` writes the same files
// without them given again (docs/logging.md, "Raw logs").

#include <optional>
#include <string>

#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/messages.hpp"
#include "core/robot_model.hpp"
#include "logger/lcm_log.hpp"
#include "logger/logger_node.hpp"

namespace sirupp::logger {

// Fills `pass`'s settings from the live logger's options, model and channel prefix.
void PutSettings(const LoggerOptions& options, const core::RobotModel& model,
                 const std::string& prefix, core::LoggerPass& pass);

// core::ConfigError for a LOGGER_PASS event of the raw log `log_path`: the log, the event's byte
// and number, its channel and `problem`.
core::ConfigError PassEventError(const std::string& log_path, const LcmLogEvent& event,
                                 const std::string& problem);

// A LOGGER_PASS event decoded; PassEventError if it does not decode or holds bad values.
core::LoggerPass DecodePassEvent(const std::string& log_path, const LcmLogEvent& event);

// The first LOGGER_PASS of a raw log: on `prefix` + LOGGER_PASS when the prefix is given, else on
// the first channel whose name ends in LOGGER_PASS. Nothing for a log without passes (one from
// lcm-logger). Throws core::ConfigError (the log, byte, event) for a pass that does not decode.
std::optional<core::LoggerPass> RecordedSettings(const std::string& log_path,
                                                 const std::optional<std::string>& prefix,
                                                 const core::Channels& channels = {});

// `options` with the recorded settings put in, except those `given` says the command line gave
// (by flag name: rate, max-age, idle, split, velocities, efforts, note).
template <class Given>
void TakeRecordedSettings(const core::LoggerPass& recorded, const Given& given,
                          LoggerOptions& options) {
  if (!given("rate")) options.aligner.period_us = recorded.period_us;
  if (!given("max-age")) options.aligner.max_age_us = recorded.max_age_us;
  if (!given("idle")) options.aligner.idle_us = recorded.idle_us;
  if (!given("split")) options.split_per_plan = recorded.split_per_plan;
  if (!given("velocities")) options.velocities = recorded.velocities;
  if (!given("efforts")) options.efforts = recorded.efforts;
  if (!given("note")) options.note = recorded.note;
}

}  // namespace sirupp::logger
