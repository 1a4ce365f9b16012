#include "proc/rig.hpp"

#include <stdexcept>

#include "proc/udpm_listen.hpp"

namespace sirupp::proc {
namespace {

RigProcess Process(const RigSpec& rig, const std::string& name, std::vector<std::string> args,
                   const std::vector<std::string>& more) {
  RigProcess process;
  process.name = name;
  process.spec.argv = {rig.bin_dir.empty() ? name : rig.bin_dir + "/" + name};
  process.spec.argv.insert(process.spec.argv.end(), args.begin(), args.end());
  process.spec.argv.insert(process.spec.argv.end(), more.begin(), more.end());
  if (!rig.log_dir.empty()) process.spec.log_path = rig.log_dir + "/" + name + ".log";
  process.spec.limits = rig.limits;
  process.spec.death_signal = rig.death_signal;
  return process;
}

}  // namespace

std::string RigUrl(int port, const std::string& options) {
  return std::string("udpm://") + kRigGroup + ":" + std::to_string(port) + "?ttl=0" +
         (options.empty() ? "" : "&" + options);
}

std::string RigUrl(const RigSpec& rig) { return RigUrl(rig.port, rig.url_options); }

std::vector<RigProcess> RigProcesses(const RigSpec& rig) {
  if (rig.port < 1 || rig.port > 65535) {
    throw std::invalid_argument("rig port " + std::to_string(rig.port) + ": allowed 1..65535");
  }
  if (rig.model.empty()) throw std::invalid_argument("rig model: none given; a model file needed");
  if (rig.sim_mode != "realtime" && rig.sim_mode != "lockstep" && rig.sim_mode != "fast") {
    throw std::invalid_argument("rig sim_mode '" + rig.sim_mode +
                                "': allowed realtime, lockstep or fast");
  }
  if (rig.pace_ticks < 1) {
    throw std::invalid_argument("rig pace_ticks " + std::to_string(rig.pace_ticks) +
                                ": allowed a whole number >= 1");
  }
  const std::string url = RigUrl(rig);
  std::vector<std::string> sim = {"--mode", rig.sim_mode};
  if (rig.pace_ticks != 1) sim.insert(sim.end(), {"--pace-ticks", std::to_string(rig.pace_ticks)});
  if (!rig.participants.empty()) {
    sim.emplace_back("--participants");
    sim.insert(sim.end(), rig.participants.begin(), rig.participants.end());
  }
  sim.insert(sim.end(), {"--model", rig.model, "--lcm-url", url});
  std::vector<std::string> control = {"--model", rig.model, "--lcm-url", url};
  if (!rig.controller.empty()) control.insert(control.end(), {"--controller", rig.controller});
  std::vector<RigProcess> processes = {Process(rig, "sirupp-sim", sim, rig.sim_args),
                                       Process(rig, "sirupp-control", control, rig.control_args)};
  if (!rig.results_dir.empty()) {
    processes.push_back(Process(rig, "sirupp-logger",
                                {"--out", rig.results_dir, "--model", rig.model, "--lcm-url", url},
                                rig.logger_args));
  }
  return processes;
}

}  // namespace sirupp::proc
