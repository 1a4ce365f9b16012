#pragma once
// The node side of a rig that runs as a job on a cluster (the class file's cluster:; issue 39).
// A Slurm job runs `sirupp-rig-job` on a node; it starts the rig there exactly as the class server
// starts a local one (class/rig.hpp: sirupp-sim, sirupp-control, sirupp-logger on a private udpm
// port with ttl=0, the panel's hub and API in this process), serves the panel's API and live
// event stream over HTTP on a port it picks on the node, and tells the class server where
// (POST report_url/cluster/report {student, job, host, port}). The class server proxies the
// student's requests to it, so a student's address and token stay the same.
//
// Every request to the node, and the report, carries the rig's secret in kRigSecretHeader: one
// secret per rig start, made by the class server and given to the job in a file only the class's
// user reads (never a student's token; students never see it). A request without it is 403.
//
// The job ends everything when Slurm ends it (SIGTERM from scancel or at the time limit; the
// children also have PR_SET_PDEATHSIG) and writes why into FOLDER/logs/rig-job-JOB.end, which the
// class server reads when Slurm no longer lists the job.

#include <memory>
#include <string>

#include "class/rig.hpp"

namespace sirupp::classroom {

inline constexpr const char* kRigSecretHeader = "X-Sirupp-Rig-Secret";
inline constexpr const char* kRigReportPath = "/cluster/report";

struct RigJobOptions {
  RigSpec spec;           // port: 0 = lease one of [first_port, first_port + port_count)
  int first_port = 7900;  // the rigs' udpm ports on a node (ttl=0: per node)
  int port_count = 200;
  std::string secret;      // the rig's secret (at least 32 characters)
  std::string job_id;      // the job's id (SLURM_JOB_ID), told in the report and the end record
  std::string report_url;  // the class server as the node reaches it; "" = report nothing
  // The address the endpoint binds; "" = the address this node reaches report_url from (so the
  // class server reaches it there), 127.0.0.1 when there is no report_url.
  std::string listen;
  int http_port = 0;      // 0 = any free port
  double stream_hz = 30;  // the fastest live stream a page may ask for
  double report_timeout_s = 30;
};

// Where a finished job's record of its own end goes: FOLDER/logs/rig-job-JOB.end.
std::string RigJobEndFile(const std::string& folder, const std::string& job_id);

// The local address this machine uses to reach `url`'s host (a UDP socket connected there, no
// packet sent); throws std::runtime_error naming the host when it cannot be resolved.
std::string LocalAddressTowards(const std::string& url);

class RigJob {
 public:
  explicit RigJob(RigJobOptions options);
  ~RigJob();
  RigJob(const RigJob&) = delete;
  RigJob& operator=(const RigJob&) = delete;

  // Leases a quiet udpm port, starts the rig (ready when it returns), binds the endpoint.
  // Throws std::runtime_error saying what failed.
  void Start();
  // POSTs the endpoint to the class server, retrying for report_timeout_s; throws with the last
  // answer when it was not taken.
  void Report();
  // Serves the endpoint on a thread of its own.
  void Serve();
  // "" while the rig's processes run, else which one ended and why.
  std::string CheckProcesses();
  // Stops the endpoint and the rig, and writes the end record with `why`. Safe to call twice.
  void Stop(const std::string& why);

  std::string host() const { return host_; }
  int http_port() const { return http_port_; }
  int udpm_port() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string host_;
  int http_port_ = 0;
};

}  // namespace sirupp::classroom
