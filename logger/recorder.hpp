#pragma once
// sirupp-logger's runs, started and stopped on the bus: LOGGER_COMMAND (logger_command_t) START
// NAME opens a new run (a LoggerNode writing NAME-NN-SET.csv files), STOP closes it; each command
// is answered on LOGGER_REPLY (command_reply_t, matched to its request by client/). The process
// may start recording at once (the default, as before there were commands) or wait for START.
//
// A command is carried out inside its handler (the Bus allows subscribing and unsubscribing
// there), so its reply goes out with the run already started or closed.
//
// Heartbeat: one for the process, across runs; its detail says what is recorded ("recording
// NAME: R rows in FILE") or that nothing is ("not recording; last run NAME: ...").
//
// Single-threaded like core::Bus: Service() from the thread that owns the bus.

#include <memory>
#include <sirupp/logger_command_t.hpp>
#include <string>
#include <vector>

#include "core/bus.hpp"
#include "core/command_reply.hpp"
#include "core/heartbeat.hpp"
#include "core/robot_model.hpp"
#include "logger/logger_node.hpp"

namespace sirupp::logger {

class Recorder {
 public:
  // `options` are every run's (options.name is the first run's name when record_now). Throws
  // what LoggerNode throws for the first run.
  Recorder(core::Bus& bus, const core::RobotModel& model, LoggerOptions options,
           bool record_now = true);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Handles bus traffic (commands included) for at most max_wait_ms and publishes the heartbeat
  // when due.
  void Service(int max_wait_ms);
  // Ends the present run (every row received written, the files closed). Idempotent.
  void Close();

  bool recording() const { return node_ != nullptr; }
  // The present run's writer failed (disk full, ...): the process should end with an error.
  bool failed() const;
  // Rows, files and the first error of every run so far (the present one included).
  LoggerStats stats() const;
  // The present run's name, or the last one's.
  const std::string& name() const { return name_; }
  // The first run continues an earlier logger's files (LoggerNode::continues()); "" if not.
  const std::string& continues() const { return continues_; }
  // The present run's raw log file (LoggerOptions::raw_log), "" when none or no run.
  std::string raw_log() const;

  // Throws std::invalid_argument naming the rule unless `name` can be a run's file stem: 1 to 100
  // characters, letters, digits, '_', '-' and '.', not starting with '.' or '-'.
  static void CheckRunName(const std::string& name);

 private:
  void Start(const std::string& name, const std::string& sender);
  void Stop(const std::string& sender);
  void AddFinished(const LoggerStats& run);
  std::string IdleDetail() const;

  core::Bus& bus_;
  core::RobotModel model_;
  LoggerOptions options_;
  core::Heartbeat heartbeat_;
  core::Replier replier_;
  core::Subscription* subscription_ = nullptr;
  std::unique_ptr<LoggerNode> node_;
  std::unique_ptr<LoggerNode> retired_;  // stopped inside a handler, ended by Service()
  LoggerStats finished_;                 // runs that ended
  int runs_ = 0;
  std::string name_;
  std::string continues_;
};

}  // namespace sirupp::logger
