#pragma once
// The class file (CLASS.yaml) behind `sirupp class serve`: the class's name, its students, the
// robot model every rig runs, the limits (most rigs at once, idle timeout, a rig's memory and
// niceness), where the class's data lives, and how the server listens. Read strictly like every
// other config file: unknown keys, wrong types and bad values are one core::ConfigError naming
// file:line, the key, the bad value and what is allowed.
//
//   class: robotics-2026              # letters, digits, '-', '_', '.'
//   robot: config/robots/puma260.yaml # relative to the class file's folder, else the source tree
//   students: [alice, bob, carol]     # names as above; 'teacher' is reserved
//   data: robotics-2026-data          # relative to the class file's folder
//   limits: {max_rigs: 12, idle_timeout_s: 900, rig_memory_mb: 2048, rig_nice: 5,
//            pin_rigs: false}
//   server: {listen: 127.0.0.1, port: 8800, public_url: "https://lab.example.edu",
//            tls_cert: cert.pem, tls_key: key.pem,
//            trusted_proxy: 127.0.0.1, proxy_user_header: X-Remote-User,   # a front's sign-in
//            proxy_secret_file: front.secret, proxy_teachers: [jsmith]}    # (front_auth.hpp)
//   rigs: {first_port: 7900, port_count: 200,   # the udpm ports rigs lease (ttl=0)
//          pace_ticks: 4}                       # each sim sleeps once per 4 ticks (2 ms)
//   real_arm:                         # optional: the one real PUMA, shared by turns
//     lcm_url: "udpm://239.255.76.67:7700?ttl=0"   # the bus sirupp-hardware runs on
//     turn_s: 600                     # one turn
//     warn_before_s: [60, 10]         # warnings before a turn's end
//     home_tolerance_deg: 1           # the pose check after homing, between two turns
//     home_speed_fraction: 0.5        # homing speed, of each joint's default
//   grading:                                  # students' controllers from the browser
//     suite: config/grading/basic.yaml        # as robot: relative to this file, else the tree
//     safety_tasks: [set1, step_j2]           # tasks of the suite a controller must pass before
//                                             # the real arm (default: every task)
//     max_source_kb: 256                      # largest source accepted (1..900)
//   cluster: {engine: slurm, ...}     # optional: rigs and grading as jobs on a cluster
//                                     # (cluster/cluster_config.hpp, docs/cluster.md)
//   notebooks:                        # optional: notebooks in the browser (docs/notebooks.md)
//     hub_url: "https://notebooks.lab.example.edu"  # where browsers reach the hub: its own
//                                     # hostname, never the class server's (CVE-2024-28233)
//     hub_port: 8810                  # the hub's proxy listens on 127.0.0.1:hub_port
//     folder: notebooks               # copied into a student's folder on their first start
//     idle_timeout_s: 1800            # a notebook server with no activity stops
//     memory_mb: 2048                 # each server's and kernel's address-space limit
//     processes: 256                  # the processes a student's sandbox may hold
//     assignments:                    # notebooks graded with the teacher's hidden tests
//       - {name: fk3, notebook: notebooks/assignments/fk3.ipynb,
//          tests: config/grading/notebooks/fk3_hidden.py, timeout_s: 120}

#include <optional>
#include <string>
#include <vector>

#include "class/front_auth.hpp"
#include "cluster/cluster_config.hpp"

namespace sirupp::classroom {

// What one client may hold of the class server (server: in the class file; class/http_guard.hpp).
struct HttpLimits {
  double request_timeout_s = 10;     // a request's headers and body, from its first byte
  double keep_alive_s = 5;           // an idle connection between requests
  int connections_per_address = 64;  // one TCP address; one client the front vouches for
  int max_connections = 512;         // every connection (one thread each)
};

// The real arm's queue (turns/, docs/class.md "The real arm, by turns").
struct RealArmConfig {
  std::string lcm_url;  // the bridge's bus (udpm://...)
  double turn_s = 600;
  std::vector<double> warn_before_s = {60, 10};
  double home_tolerance_deg = 1.0;
  double home_speed_fraction = 0.5;
};

// One graded notebook (notebooks.assignments in the class file).
struct NotebookAssignment {
  std::string name;        // as a student name: 1 to 32 of [A-Za-z0-9_.-]
  std::string notebook;    // absolute: the notebook students get and fill in
  std::string tests;       // absolute: the teacher's hidden tests, never copied to students
  double timeout_s = 120;  // the whole graded run
  int memory_mb = 2048;    // the graded kernel's address-space limit
};

// notebooks: in the class file: the hub beside the class server, and the notebook assignments.
struct NotebooksConfig {
  std::string hub_url;  // "" = no hub (assignments only); else http(s)://HOST[:PORT], no '/'
  int hub_port = 8810;
  std::string folder;  // absolute: the class's notebooks (default: the tree's notebooks/)
  double idle_timeout_s = 1800;
  int memory_mb = 2048;
  int processes = 256;
  std::vector<NotebookAssignment> assignments;
};

struct ClassConfig {
  std::string file;  // where it was read from
  std::string name;
  std::string description;
  std::string robot;  // absolute path of the robot model file
  std::vector<std::string> students;
  std::string data_dir;  // absolute
  int max_rigs = 12;
  double idle_timeout_s = 900;
  int rig_memory_mb = 2048;  // address-space limit of each rig process; 0 = none
  int rig_nice = 5;          // niceness of each rig process (0..19)
  bool pin_rigs = false;     // each rig's processes on one CPU, the one with the fewest rigs
  std::string listen = "127.0.0.1";
  int port = 8800;         // 0 = any free port
  std::string public_url;  // the address in the tokens file; "" = http(s)://listen:port
  std::string tls_cert;    // both or neither; absolute
  std::string tls_key;
  // server.trusted_proxy and proxy_*: sign-in by the university's front (front_auth.hpp); none:
  // tokens only.
  std::optional<FrontConfig> front;
  // server.request_timeout_s, keep_alive_s, connections_per_address, max_connections: what one
  // client may hold of the server (class/http_guard.hpp).
  HttpLimits http;
  int first_port = 7900;  // udpm ports leased by the rigs
  int port_count = 200;
  int pace_ticks = 4;                     // sirupp-sim --pace-ticks of every rig (1..64)
  std::optional<RealArmConfig> real_arm;  // none: the class has no real arm
  // grading: (class/submissions.hpp). Without a suite, submissions are built and run on the rig
  // but not graded, and the real arm takes none.
  std::string grading_suite;              // absolute; "" = no grading
  std::vector<std::string> safety_tasks;  // names of the suite's tasks; all of them by default
  int max_source_kb = 256;
  // cluster: rigs and grading as jobs on a cluster; none: the server's own processes.
  std::optional<cluster::ClusterConfig> cluster;
  // notebooks: the hub and notebook assignments; none: neither.
  std::optional<NotebooksConfig> notebooks;
};

// The reserved name of the teacher's token.
inline constexpr const char* kTeacher = "teacher";

// Throws core::ConfigError (file:line: key: problem).
ClassConfig LoadClassConfig(const std::string& file);
// `base_dir`: what relative paths in the text are relative to.
ClassConfig ParseClassConfig(const std::string& text, const std::string& name,
                             const std::string& base_dir);

// True for a name a student (or the class) may have: 1 to 32 of [A-Za-z0-9_.-], not starting
// with '.' or '-'.
bool IsValidName(const std::string& name);

// The address the server is reached at, without a trailing '/' (public_url, or
// scheme://listen:port with the given port).
std::string BaseUrl(const ClassConfig& config, int port);

}  // namespace sirupp::classroom
