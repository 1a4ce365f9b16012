// sirupp-rig-job: one student's rig as a job on a cluster node (class/rig_job.hpp). The class
// server submits it (the class file's cluster:); by hand it is for trying a node (one line):
//   sirupp-rig-job --student alice --folder /shared/class-data/students/alice
//     --robot /shared/class-data/students/alice/config/robots/puma260.yaml
//     --secret-file /shared/class-data/cluster/alice.secret --report-url http://web01:8800
// Prints "sirupp-rig-job: HOST:PORT" when the rig is ready; ends the rig on SIGTERM or SIGINT
// (scancel, the time limit), or when one of its processes ends, writing why into
// FOLDER/logs/rig-job-JOB.end.

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "class/rig_job.hpp"
#include "core/errors.hpp"
#include "runtime/args.hpp"
#include "runtime/process_main.hpp"

namespace {

namespace fs = std::filesystem;
using sirupp::core::UsageError;
using sirupp::runtime::Args;
using sirupp::runtime::Flag;

constexpr const char* kAbout =
    "Runs one student's rig as a job on a cluster node: sirupp-sim, sirupp-control and\n"
    "sirupp-logger on a private udpm port (ttl=0), and the panel's API and live stream over HTTP\n"
    "on a port picked here, answering only requests that carry the rig's secret. Tells the class\n"
    "server where it is (--report-url), ends everything on SIGTERM (scancel, the time limit).\n"
    "Started by `sirupp class serve` for a class file with cluster: (docs/cluster.md).\n";

// The folder this program is in (sirupp-sim and the others are beside it, built or installed).
std::string ProgramDir() {
  std::error_code error;
  const fs::path self = fs::canonical("/proc/self/exe", error);
  return error ? "." : self.parent_path().string();
}

std::string ReadSecret(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw UsageError("sirupp-rig-job: --secret-file " + file + ": cannot be read");
  std::string secret;
  std::getline(in, secret);
  while (!secret.empty() && (secret.back() == '\r' || secret.back() == ' ')) secret.pop_back();
  if (secret.size() < 32) {
    throw UsageError("sirupp-rig-job: --secret-file " + file + ": holds " +
                     std::to_string(secret.size()) + " characters; at least 32 are needed");
  }
  return secret;
}

int Run(const std::vector<std::string>& argv) {
  const Args args(
      argv, "sirupp-rig-job",
      {Flag("student", "the student whose rig this is").Takes("NAME"),
       Flag("folder", "the student's folder (config/, results/, logs/)").Takes("DIR"),
       Flag("robot", "the robot model file").Takes("FILE"),
       Flag("secret-file", "a file holding the rig's secret (one line, >= 32 characters)")
           .Takes("FILE"),
       Flag("report-url", "the class server as this node reaches it").Takes("URL"),
       Flag("job", "the job's id (default: $SLURM_JOB_ID)").Takes("ID"),
       Flag("bin-dir", "where sirupp-sim, sirupp-control, sirupp-logger are (default: beside this)")
           .Takes("DIR"),
       Flag("controller", "a student's controller in place of the built-in law").Takes("FILE"),
       Flag("pace-ticks", "sirupp-sim --pace-ticks").Takes("N").Integer(1, 64),
       Flag("udpm-ports", "the udpm ports rigs lease on this node (default 7900 200)")
           .Takes("FIRST COUNT", 2)
           .Integer(1, 65535),
       Flag("listen", "the address to bind (default: the one that reaches --report-url)")
           .Takes("ADDR"),
       Flag("port", "the HTTP port (default 0: any free one)").Takes("N").Integer(0, 65535),
       Flag("memory-mb", "address-space limit of each rig process (0: none)")
           .Takes("MB")
           .Integer(0, 1 << 22)},
      kAbout);
  for (const char* required : {"student", "folder", "robot", "secret-file"}) {
    if (!args.Has(required)) {
      throw UsageError(std::string("sirupp-rig-job: --") + required + " is required");
    }
  }
  sirupp::classroom::RigJobOptions options;
  options.spec.student = args.String("student");
  options.spec.folder = fs::absolute(args.String("folder")).lexically_normal().string();
  options.spec.robot = fs::absolute(args.String("robot")).lexically_normal().string();
  if (!fs::is_regular_file(options.spec.robot)) {
    throw UsageError("sirupp-rig-job: --robot " + options.spec.robot + ": no such file");
  }
  options.spec.bin_dir = args.Has("bin-dir") ? args.String("bin-dir") : ProgramDir();
  if (args.Has("controller")) options.spec.controller = args.String("controller");
  options.spec.pace_ticks = static_cast<int>(args.Integer("pace-ticks", 4));
  options.spec.limits.memory_mb = static_cast<int>(args.Integer("memory-mb", 0));
  options.secret = ReadSecret(args.String("secret-file"));
  if (args.Has("report-url")) options.report_url = args.String("report-url");
  const char* slurm_job = std::getenv("SLURM_JOB_ID");
  options.job_id = args.Has("job") ? args.String("job") : (slurm_job ? slurm_job : "");
  if (args.Has("udpm-ports")) {
    const std::vector<double> ports = args.Numbers("udpm-ports", 2);
    options.first_port = static_cast<int>(ports[0]);
    options.port_count = static_cast<int>(ports[1]);
  }
  if (args.Has("listen")) options.listen = args.String("listen");
  options.http_port = static_cast<int>(args.Integer("port", 0));

  sirupp::runtime::InstallStopHandlers();
  sirupp::classroom::RigJob job(options);
  try {
    job.Start();
  } catch (const std::exception& e) {
    job.Stop(std::string("the rig could not start: ") + e.what());
    throw;
  }
  job.Serve();
  std::cout << "sirupp-rig-job: " << job.host() << ":" << job.http_port() << " (udpm port "
            << job.udpm_port() << ", job " << (options.job_id.empty() ? "-" : options.job_id) << ")"
            << std::endl;
  try {
    job.Report();
  } catch (const std::exception& e) {
    job.Stop(e.what());
    throw;
  }
  std::string ended;
  sirupp::runtime::ServiceUntilSignal([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    ended = job.CheckProcesses();
    return ended.empty();
  });
  // Slurm signals every process of the job at once: a rig process that ended just before this
  // one saw its own SIGTERM ended for the same reason.
  if (!ended.empty() && !sirupp::runtime::StopRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  if (!ended.empty() && !sirupp::runtime::StopRequested()) {
    job.Stop("a rig process ended: " + ended);
    std::cerr << "sirupp-rig-job: " << ended << std::endl;
    return 1;
  }
  job.Stop("the rig job was ended by a signal (scancel, the time limit, or the node stopping)");
  std::cerr << "sirupp-rig-job: stopped" << std::endl;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-rig-job", Run);
}
