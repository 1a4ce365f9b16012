#pragma once
// One description of a private rig: which processes it runs (sirupp-sim, sirupp-control and,
// when asked, sirupp-logger), with which flags, on which LCM address. Plain data: the class
// server, the grader, the Python module and the benchmarks start it here with proc::Child, and a
// cluster engine can write the same ProcessSpecs as a job script (CommandLine) to start them on a
// node. The address is made in one place (RigUrl).

#include <string>
#include <vector>

#include "proc/child.hpp"

namespace sirupp::proc {

// The LCM address of a private rig on `port`: udpm on kRigGroup with ttl=0 (this machine only),
// then `options` ("recv_buf_size=4194304") when given.
std::string RigUrl(int port, const std::string& options = "");

struct RigSpec {
  int port = 0;                           // the rig's udpm port (see RigUrl)
  std::string url_options;                // more LCM address options, "" = none
  std::string bin_dir;                    // where the sirupp programs are; "" = looked up on PATH
  std::string model;                      // the robot model file
  std::string sim_mode = "realtime";      // sirupp-sim --mode: realtime, lockstep, fast
  int pace_ticks = 1;                     // sirupp-sim --pace-ticks (realtime; 1 = the default)
  std::vector<std::string> participants;  // sirupp-sim --participants (lockstep)
  std::vector<std::string> sim_args;      // more sirupp-sim flags (start pose, environment, ...)
  // sirupp-control --controller FILE (a built library, a .py): "" = the PIC-SERVO law.
  std::string controller;
  std::vector<std::string> control_args;  // more sirupp-control flags
  std::string results_dir;                // sirupp-logger --out; "" = no logger
  std::vector<std::string> logger_args;   // more sirupp-logger flags
  std::string log_dir;                    // each process's output in LOG_DIR/NAME.log; "" = none
  Limits limits;                          // every process's
  int death_signal = SIGTERM;             // when the starting process dies
};

struct RigProcess {
  std::string name;  // "sirupp-sim", "sirupp-control", "sirupp-logger"
  ProcessSpec spec;
};

// The rig's address.
std::string RigUrl(const RigSpec& rig);
// Its processes in start order: sirupp-sim, sirupp-control, then sirupp-logger when it has one.
// Throws std::invalid_argument naming the field for a port outside 1..65535, no model, a mode
// other than realtime, lockstep or fast, or pace_ticks < 1.
std::vector<RigProcess> RigProcesses(const RigSpec& rig);

}  // namespace sirupp::proc
