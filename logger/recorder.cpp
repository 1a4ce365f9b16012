#include "logger/recorder.hpp"

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <utility>

#include "core/errors.hpp"
#include "core/printable.hpp"
#include "core/translate.hpp"

namespace sirupp::logger {

namespace {

// The first data file of run `name` in `dir` (NAME.csv, NAME-..., NAME.K.csv), "" when none.
std::string ExistingRunFile(const std::string& dir, const std::string& name) {
  namespace fs = std::filesystem;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string file = entry.path().filename().string();
    if (entry.path().extension() != ".csv") continue;
    if (file == name + ".csv" || file.rfind(name + "-", 0) == 0 || file.rfind(name + ".", 0) == 0) {
      return file;
    }
  }
  return "";
}

}  // namespace

void Recorder::CheckRunName(const std::string& name) {
  const bool ok_chars = std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
  if (name.empty() || name.size() > 100 || !ok_chars || name[0] == '.' || name[0] == '-') {
    throw std::invalid_argument("run name '" + name +
                                "': allowed 1 to 100 letters, digits, '_', '-' and '.', not "
                                "starting with '.' or '-'");
  }
}

Recorder::Recorder(core::Bus& bus, const core::RobotModel& model, LoggerOptions options,
                   bool record_now)
    : bus_(bus),
      model_(model),
      options_(std::move(options)),
      heartbeat_(bus, options_.process_name, options_.channels.heartbeat),
      replier_(bus, options_.channels.logger_reply, options_.process_name) {
  options_.heartbeat = &heartbeat_;
  name_ = options_.name;
  if (record_now) {
    node_ = std::make_unique<LoggerNode>(bus_, model_, options_);
    name_ = node_->name();
    continues_ = node_->continues();
    runs_ = 1;
  } else {
    heartbeat_.Publish(core::ProcessState::kStarting, "");
  }
  // Carried out inside the handler: a run's subscriptions are made (and, through the Bus, ended)
  // safely there, and the reply goes out with the run already started or closed.
  subscription_ = &bus_.Subscribe<sirupp::logger_command_t>(
      options_.channels.logger_command,
      [this](const sirupp::logger_command_t& message, const core::ReceiveInfo& info) {
        try {
          replier_.Answer(
              message, info,
              [&] {
                const core::LoggerCommand command =
                    core::LoggerCommandFromMessage(message, info.channel);
                if (command.action == core::LoggerAction::kStart) {
                  Start(command.name, command.sender);
                } else {
                  Stop(command.sender);
                }
              },
              [] { return core::ReplyFacts{}; });
        } catch (const std::exception& error) {
          std::cerr << options_.process_name << ": " << info.channel << " from '"
                    << core::Printable(message.sender, 60) << "' refused: " << error.what()
                    << std::endl;
          throw;
        }
      });
}

std::string Recorder::raw_log() const { return node_ ? node_->raw_log() : ""; }

Recorder::~Recorder() {
  if (subscription_ != nullptr) subscription_->Unsubscribe();
  try {
    Close();
  } catch (const std::exception&) {  // only a failed join; nothing to add
  }
}

void Recorder::Service(int max_wait_ms) {
  if (node_) {
    LoggerNode& node = *node_;  // a STOP handled inside keeps it alive in retired_
    node.Service(max_wait_ms);
  } else {
    bus_.HandleAvailable();
    bus_.Handle(max_wait_ms);
    heartbeat_.PublishIfDue(core::ProcessState::kRunning, IdleDetail());
  }
  retired_.reset();
}

void Recorder::Start(const std::string& requested, const std::string& sender) {
  if (node_) {
    throw std::runtime_error("run '" + name_ + "' is being recorded: stop it first");
  }
  const std::string name = requested.empty() ? DefaultRunName() : requested;
  CheckRunName(name);
  const std::string existing = ExistingRunFile(options_.out_dir, name);
  if (!existing.empty()) {
    throw std::runtime_error("run '" + name + "' has files in " + options_.out_dir + " already (" +
                             existing + "): choose another name");
  }
  LoggerOptions options = options_;
  options.name = name;
  node_ = std::make_unique<LoggerNode>(bus_, model_, options);
  name_ = name;
  ++runs_;
  std::cerr << options_.process_name << ": recording run '" << name_ << "' into "
            << options_.out_dir << " (started by '" << sender << "')" << std::endl;
}

void Recorder::Stop(const std::string& sender) {
  if (!node_) throw std::runtime_error("nothing is being recorded");
  node_->Close();
  const LoggerStats run = node_->stats();
  // Ended after the handler returns (Service), never inside the node's own Service call.
  retired_ = std::move(node_);
  AddFinished(run);
  std::cerr << options_.process_name << ": run '" << name_ << "' stopped by '" << sender
            << "': " << run.rows << " rows in " << run.files.size() << " file(s)" << std::endl;
  heartbeat_.Publish(core::ProcessState::kRunning, IdleDetail());
}

void Recorder::AddFinished(const LoggerStats& run) {
  finished_.rows += run.rows;
  for (size_t s = 0; s < run.samples.size(); ++s) {
    finished_.samples[s] += run.samples[s];
    finished_.lost[s] += run.lost[s];
  }
  finished_.queue_overflow += run.queue_overflow;
  finished_.kernel_dropped += run.kernel_dropped;
  finished_.files.insert(finished_.files.end(), run.files.begin(), run.files.end());
  if (finished_.error.empty()) finished_.error = run.error;
}

void Recorder::Close() {
  if (!node_) return;
  node_->Close();
  const LoggerStats run = node_->stats();
  node_.reset();
  AddFinished(run);
}

bool Recorder::failed() const { return node_ && node_->failed(); }

LoggerStats Recorder::stats() const {
  LoggerStats total = finished_;
  if (node_) {
    const LoggerStats run = node_->stats();
    total.rows += run.rows;
    for (size_t s = 0; s < run.samples.size(); ++s) {
      total.samples[s] += run.samples[s];
      total.lost[s] += run.lost[s];
    }
    total.queue_overflow += run.queue_overflow;
    total.kernel_dropped += run.kernel_dropped;
    total.files.insert(total.files.end(), run.files.begin(), run.files.end());
    if (total.error.empty()) total.error = run.error;
  }
  return total;
}

std::string Recorder::IdleDetail() const {
  if (runs_ == 0) return "not recording (waiting for START on LOGGER_COMMAND)";
  return "not recording; last run " + name_ + ": " + std::to_string(finished_.rows) + " rows in " +
         std::to_string(finished_.files.size()) + " file(s) so far";
}

}  // namespace sirupp::logger
