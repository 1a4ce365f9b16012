#pragma once
// Helpers shared by the `sirupp` commands that talk to a running rig (reset, move, plan, gains,
// status): the model, the bus and joint positions from the command line, and a wall clock.

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "core/bus.hpp"
#include "core/robot_model.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"

namespace sirupp::tools {

// `flags` plus --lcm-url URL and --prefix PREFIX, for runtime::Args.
std::vector<runtime::Flag> WithRigFlags(std::vector<runtime::Flag> flags);

// `flags` plus --pose NAME, --deg Q.., --rad Q.. (runtime/joint_args.hpp).
std::vector<runtime::Flag> WithJointFlags(std::vector<runtime::Flag> flags);

// The declaration of --timeout S (seconds > 0) and its value, or `fallback` when absent.
runtime::Flag TimeoutFlag(const std::string& what);
double TimeoutFrom(const runtime::Args& parsed, double fallback);

// Handles messages on `bus` until done() holds or timeout_s passed; returns done().
using core::HandleUntil;

// --model FILE, default runtime::kDefaultModelFile (found from any working directory).
core::RobotModel ModelFromArgs(const runtime::Args& parsed);

// --lcm-url URL and --prefix PREFIX (defaults: LCM's default URL, no prefix).
core::Bus BusFromArgs(const runtime::Args& parsed);

// Joint positions (rad or m) from exactly one of --pose NAME, --deg Q.., --rad Q..
// (runtime/joint_args.hpp: the one convention), each within the joint's limits; throws
// core::UsageError naming `command`, the joint and the allowed range.
std::vector<double> PositionsFromArgs(const runtime::Args& parsed, const core::RobotModel& model,
                                      const std::string& command);

// Microseconds since the epoch (utime of messages sent by people).
using core::WallMicros;

// "sent CHANNEL: MODEL to Q1 .. QN (rad or m)" without a line end.
void PrintSent(std::ostream& out, const core::Bus& bus, const std::string& channel,
               const core::RobotModel& model, const std::vector<double>& position);

}  // namespace sirupp::tools
