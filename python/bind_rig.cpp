// The client of a running rig (client/client.hpp), a recorder of its per-tick channels, and the
// pieces of a private local rig (grade/child.hpp, grade/port_lease.hpp), for sirupp/rig.py.
//
// Waits: the client is single-threaded and handles messages only inside its calls, so every wait
// here runs in slices of at most kSliceS with the GIL released, and checks for signals between
// slices (PyErr_CheckSignals): Ctrl-C or a notebook's "interrupt kernel" raises KeyboardInterrupt
// within a slice. A wait for a move or a plan that is interrupted first stops the arm (the stop
// button: ARM_PLAN abort, a smooth stop) and then raises.
#include <pthread.h>
#include <pybind11/stl.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "client/client.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "grade/child.hpp"
#include "grade/port_lease.hpp"
#include "proc/rig.hpp"
#include "python/bindings.hpp"
#include "python/convert.hpp"

namespace sirupp::python {

namespace {

constexpr double kSliceS = 0.05;

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

py::dict AnswerDict(const client::Answer& answer) {
  py::dict d;
  d["accepted"] = answer.accepted();
  d["result"] = answer.result == client::Result::kAccepted  ? "accepted"
                : answer.result == client::Result::kRefused ? "refused"
                                                            : "no answer";
  d["error"] = answer.error;
  d["move_id"] = answer.move_id;
  d["status_seq"] = answer.status_seq;
  return d;
}

const char* EndName(client::End end) {
  switch (end) {
    case client::End::kDone:
      return "done";
    case client::End::kFault:
      return "fault";
    case client::End::kSuperseded:
      return "superseded";
    case client::End::kAborted:
      return "aborted";
    case client::End::kTimeout:
      return "timeout";
    case client::End::kControllerSilent:
      return "controller silent";
  }
  return "unknown";
}

// An optional per-joint vector (None: empty, the defaults), checked finite.
std::vector<double> Values(const py::handle& value, const std::string& name) {
  if (value.is_none()) return {};
  const Eigen::VectorXd v =
      VectorArg(value, static_cast<int>(py::len(value)), name, "one per joint");
  return std::vector<double>(v.data(), v.data() + v.size());
}

class ClientHandle {
 public:
  ClientHandle(const std::string& lcm_url, const std::string& prefix, const std::string& sender,
               double answer_timeout_s) {
    client::Options options;
    options.lcm_url = lcm_url;
    options.prefix = prefix;
    options.sender = sender;
    options.answer_timeout_s = answer_timeout_s;
    try {
      client_ = std::make_unique<client::Client>(options);
    } catch (const std::exception& error) {
      throw RigError(std::string("cannot join the rig's bus: ") + error.what());
    }
  }

  // Runs step(slice_s) without the GIL until it returns true or timeout_s passed, checking for
  // signals between slices. Returns whether it finished. A pending signal wins over an error the
  // step met (a signal can also cut a wait short inside LCM).
  template <class Step>
  bool Sliced(double timeout_s, Step step, bool stop_arm_on_interrupt) {
    const Clock::time_point start = Clock::now();
    for (;;) {
      const double left = timeout_s - Since(start);
      if (left <= 0) return false;
      bool done = false;
      std::string failure;
      {
        py::gil_scoped_release release;
        try {
          done = step(std::min(kSliceS, left));
        } catch (const std::exception& error) {
          failure = error.what();
        }
      }
      if (PyErr_CheckSignals() != 0) {
        if (stop_arm_on_interrupt) {
          py::error_already_set pending;  // keep the KeyboardInterrupt while we stop the arm
          StopArm();
          throw pending;
        }
        throw py::error_already_set();
      }
      if (!failure.empty()) throw RigError(failure);
      if (done) return true;
    }
  }

  // The stop button (ARM_PLAN abort: a smooth stop), without the GIL; best effort.
  void StopArm() {
    py::gil_scoped_release release;
    try {
      client_->Plan(client::PlanCommand::kAbort);
    } catch (const std::exception&) {
    }
  }

  // Runs a client command without the GIL (it waits up to the answer timeout for the reply);
  // after a Ctrl-C meanwhile the arm is stopped and KeyboardInterrupt raised. Unlocked: the
  // answer as a dict for Python.
  template <class Command>
  client::Answer Call(Command command) {
    client::Answer answer;
    std::string failure;
    {
      py::gil_scoped_release release;
      try {
        answer = command();
      } catch (const std::exception& error) {
        failure = error.what();
      }
    }
    if (PyErr_CheckSignals() != 0) {
      py::error_already_set pending;
      StopArm();
      throw pending;
    }
    if (!failure.empty()) throw RigError(failure);
    return answer;
  }
  template <class Command>
  py::dict Unlocked(Command command) {
    return AnswerDict(Call(command));
  }

  // Waits until the rig's status, gains and state were all heard (CONTROLLER_STATUS,
  // CONTROLLER_GAINS, SIM_ARM_STATE; the controller sends its gains once a second), at most
  // timeout_s. Returns the channels still not heard: empty when the rig is all there.
  py::list WaitForRig(double timeout_s) {
    const client::Snapshot& seen = client_->snapshot();
    const auto all_heard = [&seen] {
      return seen.controller.has_value() && seen.virtual_gains.has_value() &&
             seen.sim_arm.has_value();
    };
    Sliced(
        timeout_s, [&](double s) { return client_->Until(all_heard, s); }, false);
    const core::Channels& channels = client_->channels();
    py::list missing;
    if (!seen.controller) missing.append(client_->bus().FullName(channels.controller_status));
    if (!seen.virtual_gains) missing.append(client_->bus().FullName(channels.controller_gains));
    if (!seen.sim_arm) missing.append(client_->bus().FullName(channels.sim_arm_state));
    return missing;
  }

  void Listen(double seconds) {
    Sliced(
        seconds,
        [this](double s) {
          client_->Listen(s);
          return false;
        },
        false);
  }

  void WatchJoints(bool on) { client_->WatchJoints(on); }

  py::dict MoveJoints(const py::handle& q, const py::handle& max_velocity,
                      const py::handle& acceleration) {
    client::JointTarget target;
    target.position = Values(q, "q");
    target.max_velocity = Values(max_velocity, "qd_max");
    target.acceleration = Values(acceleration, "qdd_max");
    return Unlocked([&] { return client_->MoveJoints(target); });
  }

  py::dict MovePose(const py::handle& position, const py::handle& quaternion, bool position_only,
                    std::optional<bool> shoulder_left, std::optional<bool> elbow_up,
                    std::optional<bool> wrist_flip, double speed_scale) {
    client::PoseTarget target;
    const Eigen::VectorXd p = VectorArg(position, 3, "position", "x y z in metres");
    const Eigen::VectorXd w = VectorArg(quaternion, 4, "quaternion", "w x y z");
    if (!(speed_scale > 0 && speed_scale <= 1)) {
      throw py::value_error("speed_scale: " + core::FormatNumber(speed_scale) +
                            "; expected (0, 1]");
    }
    for (int i = 0; i < 3; ++i) target.position[i] = p[i];
    for (int i = 0; i < 4; ++i) target.orientation[i] = w[i];
    target.position_only = position_only;
    target.shoulder_left = shoulder_left;
    target.elbow_up = elbow_up;
    target.wrist_flip = wrist_flip;
    target.speed_scale = speed_scale;
    return Unlocked([&] { return client_->MovePose(target); });
  }

  py::dict RunPlan(const std::string& name, const std::string& text) {
    return Unlocked([&] { return client_->RunPlan(name, text); });
  }

  py::dict PlanCommand(const std::string& word) {
    const std::optional<client::PlanCommand> command = client::PlanCommandFromName(word);
    if (!command) {
      std::string allowed;
      for (const client::PlanCommand c : client::kPlanCommands) {
        allowed += std::string(allowed.empty() ? "" : ", ") + client::PlanCommandName(c);
      }
      throw py::value_error("plan command '" + word + "'; expected one of " + allowed);
    }
    return Unlocked([&] { return client_->Plan(*command); });
  }

  py::dict SetGains(const py::dict& gains) {
    const auto& snap = client_->snapshot();
    if (!snap.virtual_gains) {
      throw RigError("no CONTROLLER_GAINS heard yet: is sirupp-control running on this bus?");
    }
    sirupp::servo_gains_t message = *snap.virtual_gains;
    const int n = message.num_joints;
    struct Field {
      const char* name;
      std::vector<double>* values;
    };
    const Field fields[] = {{"kp", &message.kp},
                            {"kd", &message.kd},
                            {"ki", &message.ki},
                            {"integration_limit", &message.integration_limit},
                            {"output_limit", &message.output_limit},
                            {"current_limit", &message.current_limit},
                            {"error_limit", &message.error_limit},
                            {"servo_rate_divisor", &message.servo_rate_divisor},
                            {"deadband", &message.deadband}};
    for (const auto& item : gains) {
      const std::string key = py::str(item.first);
      const Field* field = nullptr;
      for (const Field& f : fields) {
        if (key == f.name) field = &f;
      }
      if (field == nullptr) {
        throw py::value_error("gains: '" + key +
                              "'; expected kp, kd, ki, integration_limit, output_limit, "
                              "current_limit, error_limit, servo_rate_divisor or deadband");
      }
      const Eigen::VectorXd v = VectorArg(item.second, n, key, "one per joint, chip units");
      field->values->assign(v.data(), v.data() + n);
    }
    // As `sirupp gains` does: the controller's answer, the bridge's when one was heard, then
    // the rig's gains showing the new ones.
    const bool with_real = snap.real_gains.has_value();
    const client::Answer answer = Call([&] { return client_->SetGains(message); });
    if (!answer.accepted()) return AnswerDict(answer);
    if (with_real) {
      const client::Answer bridge = Call([&] {
        return client_->AwaitHardwareAnswer(answer.request, client_->options().answer_timeout_s);
      });
      if (bridge.result == client::Result::kRefused) {
        throw RigError("set_gains: refused by sirupp-hardware: " + bridge.error);
      }
    }
    const bool shown = Sliced(
        client::Client::kGainsShownS,
        [&](double s) { return client_->WaitGainsShown(message, with_real, s); }, false);
    if (!shown) {
      throw RigError(
          std::string("set_gains: accepted, but ") +
          (with_real ? "CONTROLLER_GAINS and REAL_ARM_GAINS do" : "CONTROLLER_GAINS does") +
          " not show the new gains within " + core::FormatApprox(client::Client::kGainsShownS) +
          " s");
    }
    return AnswerDict(answer);
  }

  void Estop(bool engage, const std::string& reason) { client_->Estop(engage, reason); }

  py::tuple WaitMove(int64_t move_id, double timeout_s, int64_t from_seq) {
    client::Outcome outcome;
    const bool ended = Sliced(
        timeout_s,
        [&](double s) {
          outcome = client_->WaitForMove(move_id, s, from_seq);
          return outcome.end != client::End::kTimeout;
        },
        true);
    if (!ended) {
      return py::make_tuple("timeout",
                            "still moving after " + core::FormatApprox(timeout_s) + " s");
    }
    return py::make_tuple(EndName(outcome.end), outcome.detail);
  }

  py::tuple WaitPlan(const std::string& name, int steps, double timeout_s, int64_t from_seq) {
    client::Outcome outcome;
    const bool ended = Sliced(
        timeout_s,
        [&](double s) {
          outcome = client_->WaitForPlan(name, steps, s, nullptr, from_seq);
          return outcome.end != client::End::kTimeout;
        },
        true);
    if (!ended) {
      return py::make_tuple("timeout",
                            "plan still running after " + core::FormatApprox(timeout_s) + " s");
    }
    return py::make_tuple(EndName(outcome.end), outcome.detail);
  }

  py::object Status() const {
    const auto& snap = client_->snapshot();
    if (!snap.controller) return py::none();
    const sirupp::controller_status_t& s = *snap.controller;
    py::dict d;
    d["mode"] = client::ControllerModeName(s.mode);
    d["state"] = client::ControllerStateName(s.state);
    d["move_id"] = s.move_id;
    d["plan_name"] = s.plan_name;
    d["plan_step"] = s.plan_step;
    d["plan_steps"] = s.plan_steps;
    d["plan_line"] = s.plan_line;
    d["last_error"] = s.last_error;
    d["seq"] = s.seq;
    if (snap.sim) {
      py::dict sim;
      sim["time_s"] = snap.sim->sim_time_s;
      sim["realtime_factor"] = snap.sim->realtime_factor;
      sim["estop"] = snap.sim->estop != 0;
      sim["estop_reason"] = snap.sim->estop_reason;
      sim["tick"] = snap.sim->tick;
      d["sim"] = sim;
    } else {
      d["sim"] = py::none();
    }
    py::list processes;
    for (const auto& entry : snap.heartbeats) processes.append(entry.first);
    d["processes"] = processes;
    return d;
  }

  py::object ArmState() const {
    const auto& snap = client_->snapshot();
    if (!snap.sim_arm) return py::none();
    py::dict d;
    d["tick"] = snap.sim_arm->tick;
    d["utime"] = snap.sim_arm->utime;
    d["q"] = ToArray(snap.sim_arm->position);
    d["qd"] = ToArray(snap.sim_arm->velocity);
    d["effort"] = ToArray(snap.sim_arm->effort);
    std::vector<double> flags(snap.sim_arm->flags.begin(), snap.sim_arm->flags.end());
    d["flags"] = ToArray(flags);
    if (snap.setpoint) {
      d["q_setpoint"] = ToArray(snap.setpoint->position);
      d["qd_setpoint"] = ToArray(snap.setpoint->velocity);
      d["goal"] = ToArray(snap.setpoint->goal);
    }
    return d;
  }

  py::object Gains(bool real) const {
    const auto& snap = client_->snapshot();
    const std::optional<sirupp::servo_gains_t>& g = real ? snap.real_gains : snap.virtual_gains;
    if (!g) return py::none();
    py::dict d;
    d["kp"] = ToArray(g->kp);
    d["kd"] = ToArray(g->kd);
    d["ki"] = ToArray(g->ki);
    d["integration_limit"] = ToArray(g->integration_limit);
    d["output_limit"] = ToArray(g->output_limit);
    d["current_limit"] = ToArray(g->current_limit);
    d["error_limit"] = ToArray(g->error_limit);
    d["servo_rate_divisor"] = ToArray(g->servo_rate_divisor);
    d["deadband"] = ToArray(g->deadband);
    return d;
  }

 private:
  std::unique_ptr<client::Client> client_;
};

// Every SIM_ARM_STATE, ARM_SETPOINT and REAL_ARM_STATE of a rig from start to stop, taken on a
// bus and thread of its own (the client hears only the newest of them).
class Recorder {
 public:
  Recorder(const std::string& lcm_url, const std::string& prefix) {
    try {
      bus_ = std::make_unique<core::Bus>(lcm_url, prefix);
    } catch (const std::exception& error) {
      throw RigError(std::string("cannot join the rig's bus: ") + error.what());
    }
    const core::Channels channels;
    constexpr int kQueue = 10000;
    bus_->Subscribe(channels.sim_arm_state,
                    std::function<void(const sirupp::arm_state_t&, const core::ReceiveInfo&)>(
                        [this](const sirupp::arm_state_t& m, const core::ReceiveInfo&) {
                          std::lock_guard<std::mutex> lock(mutex_);
                          Append(sim_, m.tick, m.utime, m.position, m.velocity, m.effort);
                        }),
                    kQueue);
    bus_->Subscribe(channels.arm_setpoint,
                    std::function<void(const sirupp::servo_setpoint_t&, const core::ReceiveInfo&)>(
                        [this](const sirupp::servo_setpoint_t& m, const core::ReceiveInfo&) {
                          std::lock_guard<std::mutex> lock(mutex_);
                          Append(setpoint_, m.tick, m.utime, m.position, m.velocity, m.goal);
                        }),
                    kQueue);
    bus_->Subscribe(channels.real_arm_state,
                    std::function<void(const sirupp::arm_state_t&, const core::ReceiveInfo&)>(
                        [this](const sirupp::arm_state_t& m, const core::ReceiveInfo&) {
                          std::lock_guard<std::mutex> lock(mutex_);
                          Append(real_, m.tick, m.utime, m.position, m.velocity, m.effort);
                        }),
                    kQueue);
    thread_ = std::thread([this] {
      sigset_t all;  // Ctrl-C is the interpreter's, on its own thread
      sigfillset(&all);
      pthread_sigmask(SIG_BLOCK, &all, nullptr);
      while (running_) {
        try {
          bus_->Handle(20);
        } catch (const std::exception&) {
          running_ = false;  // the bus failed: the recording ends here
        }
      }
    });
  }
  ~Recorder() { Stop(); }

  void Stop() {
    running_ = false;
    if (thread_.joinable()) {
      py::gil_scoped_release release;
      thread_.join();
    }
  }

  // {"sim": {...}, "setpoint": {...}, "real": {...}}, each with tick, utime (int64 arrays) and
  // three (samples x joints) arrays: sim q, qd, effort; setpoint q, qd, goal; real q, qd, effort.
  py::dict Take() {
    std::lock_guard<std::mutex> lock(mutex_);
    py::dict d;
    d["sim"] = ToDict(sim_, "q", "qd", "effort");
    d["setpoint"] = ToDict(setpoint_, "q", "qd", "goal");
    d["real"] = ToDict(real_, "q", "qd", "effort");
    return d;
  }

 private:
  struct Stream {
    std::vector<int64_t> tick, utime;
    std::vector<std::vector<double>> a, b, c;
  };
  static void Append(Stream& s, int64_t tick, int64_t utime, const std::vector<double>& a,
                     const std::vector<double>& b, const std::vector<double>& c) {
    s.tick.push_back(tick);
    s.utime.push_back(utime);
    s.a.push_back(a);
    s.b.push_back(b);
    s.c.push_back(c);
  }
  static py::array_t<double> Rows(const std::vector<std::vector<double>>& rows) {
    const size_t n = rows.empty() ? 0 : rows.front().size();
    py::array_t<double> out({static_cast<py::ssize_t>(rows.size()), static_cast<py::ssize_t>(n)});
    auto view = out.mutable_unchecked<2>();
    for (size_t r = 0; r < rows.size(); ++r) {
      for (size_t c = 0; c < n; ++c) {
        view(static_cast<py::ssize_t>(r), static_cast<py::ssize_t>(c)) =
            c < rows[r].size() ? rows[r][c] : std::nan("");
      }
    }
    return out;
  }
  static py::dict ToDict(const Stream& s, const char* a, const char* b, const char* c) {
    py::dict d;
    d["tick"] = py::array_t<int64_t>(static_cast<py::ssize_t>(s.tick.size()), s.tick.data());
    d["utime"] = py::array_t<int64_t>(static_cast<py::ssize_t>(s.utime.size()), s.utime.data());
    d[a] = Rows(s.a);
    d[b] = Rows(s.b);
    d[c] = Rows(s.c);
    return d;
  }

  std::unique_ptr<core::Bus> bus_;
  std::atomic<bool> running_{true};
  std::thread thread_;
  std::mutex mutex_;
  Stream sim_, setpoint_, real_;
};

}  // namespace

void BindRig(py::module_& m) {
  py::class_<ClientHandle>(m, "_Client",
                           "the client library (client/client.hpp); use sirupp.connect")
      .def(py::init<const std::string&, const std::string&, const std::string&, double>(),
           py::arg("lcm_url"), py::arg("prefix"), py::arg("sender"), py::arg("answer_timeout_s"))
      .def("wait_for_rig", &ClientHandle::WaitForRig, py::arg("timeout_s"))
      .def("listen", &ClientHandle::Listen, py::arg("seconds"))
      .def("watch_joints", &ClientHandle::WatchJoints, py::arg("on"))
      .def("move_joints", &ClientHandle::MoveJoints, py::arg("q"), py::arg("qd_max"),
           py::arg("qdd_max"))
      .def("move_pose", &ClientHandle::MovePose, py::arg("position"), py::arg("quaternion"),
           py::arg("position_only"), py::arg("shoulder_left"), py::arg("elbow_up"),
           py::arg("wrist_flip"), py::arg("speed_scale"))
      .def("run_plan", &ClientHandle::RunPlan, py::arg("name"), py::arg("text"))
      .def("plan_command", &ClientHandle::PlanCommand, py::arg("word"))
      .def("set_gains", &ClientHandle::SetGains, py::arg("gains"))
      .def("estop", &ClientHandle::Estop, py::arg("engage"), py::arg("reason"))
      .def("wait_move", &ClientHandle::WaitMove, py::arg("move_id"), py::arg("timeout_s"),
           py::arg("from_seq"))
      .def("wait_plan", &ClientHandle::WaitPlan, py::arg("name"), py::arg("steps"),
           py::arg("timeout_s"), py::arg("from_seq"))
      .def("status", &ClientHandle::Status)
      .def("arm_state", &ClientHandle::ArmState)
      .def("gains", &ClientHandle::Gains, py::arg("real"));

  py::class_<Recorder>(m, "_Recorder", "every per-tick state of a rig; use Rig.record()")
      .def(py::init<const std::string&, const std::string&>(), py::arg("lcm_url"),
           py::arg("prefix"))
      .def("stop", &Recorder::Stop)
      .def("take", &Recorder::Take);

  py::class_<grade::Child>(m, "_Child",
                           "a process in its own group, killed when this process dies "
                           "(grade/child.hpp)")
      .def(py::init<>())
      .def("start", &grade::Child::Start, py::arg("argv"), py::arg("log_file"))
      .def("running", &grade::Child::Running)
      .def("how_ended", &grade::Child::HowEnded)
      .def("stop", &grade::Child::Stop, py::arg("grace_s") = 1.0,
           py::call_guard<py::gil_scoped_release>())
      .def("log_tail", &grade::Child::LogTail, py::arg("lines") = 3)
      .def_property_readonly("pid", &grade::Child::pid);

  m.def(
      "_rig_url", [](int port) { return proc::RigUrl(port); }, py::arg("port"),
      "a private rig's LCM address on a udpm port (proc/rig.hpp)");
  m.def(
      "_rig_processes",
      [](int port, const std::string& bin_dir, const std::string& model, const std::string& mode,
         const std::vector<std::string>& participants, const std::vector<std::string>& sim_args,
         const std::string& controller, const std::vector<std::string>& control_args,
         const std::string& results_dir, const std::string& log_dir) {
        proc::RigSpec rig;
        rig.port = port;
        rig.bin_dir = bin_dir;
        rig.model = model;
        rig.sim_mode = mode;
        rig.participants = participants;
        rig.sim_args = sim_args;
        rig.controller = controller;
        rig.control_args = control_args;
        rig.results_dir = results_dir;
        rig.log_dir = log_dir;
        std::vector<std::tuple<std::string, std::vector<std::string>, std::string>> processes;
        for (const proc::RigProcess& process : proc::RigProcesses(rig)) {
          processes.emplace_back(process.name, process.spec.argv, process.spec.log_path);
        }
        return processes;
      },
      py::arg("port"), py::arg("bin_dir"), py::arg("model"), py::arg("mode"),
      py::arg("participants"), py::arg("sim_args"), py::arg("controller"), py::arg("control_args"),
      py::arg("results_dir"), py::arg("log_dir"),
      "a private rig's processes in start order (proc::RigProcesses): (name, argv, log file)");
  py::class_<grade::PortLease>(m, "_PortLease", "a private udpm port (grade/port_lease.hpp)")
      .def_static("acquire", &grade::PortLease::Acquire, py::arg("first"), py::arg("count"),
                  py::arg("start_offset"), py::arg("directory") = "")
      .def_property_readonly("port", &grade::PortLease::port)
      .def("release", &grade::PortLease::Release);
}

}  // namespace sirupp::python
