#include "tools/rig_args.hpp"

#include <algorithm>
#include <chrono>
#include <ostream>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "runtime/data_path.hpp"
#include "runtime/joint_args.hpp"
#include "tools/cli.hpp"

namespace sirupp::tools {

core::RobotModel ModelFromArgs(const runtime::Args& parsed) {
  return core::LoadRobotModel(runtime::ModelFileArg(parsed));
}

std::vector<double> PositionsFromArgs(const runtime::Args& parsed, const core::RobotModel& model,
                                      const std::string& command) {
  return *runtime::PositionsArg(parsed, model, command, true);
}

core::Bus BusFromArgs(const runtime::Args& parsed) {
  return core::Bus(parsed.Has("lcm-url") ? parsed.String("lcm-url") : "",
                   parsed.Has("prefix") ? parsed.String("prefix") : "");
}

void PrintSent(std::ostream& out, const core::Bus& bus, const std::string& channel,
               const core::RobotModel& model, const std::vector<double>& position) {
  out << "sent " << bus.FullName(channel) << ": " << model.name << " to";
  for (double q : position) out << " " << core::FormatApprox(q);
  out << " (rad or m)";
}

std::vector<runtime::Flag> WithRigFlags(std::vector<runtime::Flag> flags) {
  flags.emplace_back("lcm-url", "LCM URL");
  flags.back().Takes("URL");
  flags.emplace_back("prefix", "channel prefix of the rig");
  flags.back().Takes("PREFIX");
  return flags;
}

std::vector<runtime::Flag> WithJointFlags(std::vector<runtime::Flag> flags) {
  const std::vector<runtime::Flag> joints = runtime::JointFlags();
  flags.insert(flags.begin() + (flags.empty() ? 0 : 1), joints.begin(), joints.end());
  return flags;
}

runtime::Flag TimeoutFlag(const std::string& what) {
  return runtime::Flag("timeout", what).Takes("S").Above(0);
}

double TimeoutFrom(const runtime::Args& parsed, double fallback) {
  return parsed.Number("timeout", fallback);  // > 0: TimeoutFlag
}

}  // namespace sirupp::tools
