// SIRUPP student controller interface: the only file a controller library needs.
//
// A controller replaces the PIC-SERVO PID filter inside sirupp-control. The profile generators keep
// running, so `sirupp move joints ...` still produces smooth set-points; each servo tick (0.512 ms
// on the PUMA 260) your Update gets the measured joint state, the set-points and the arm's
// dynamics at the measured state, and writes one effort per joint. Plain C++17, no other
// dependency: build it into a shared library and load it with
//
//   g++ -std=c++17 -O2 -shared -fPIC -I SIRUPP/include my_controller.cpp -o my_controller.so
//
// (SIRUPP: the project's folder; this header needs no install.)
//   sirupp-control --controller ./my_controller.so --controller-args "kp=100 kd=5"
//
// Units: SI, joint by joint: rad, rad/s, rad/s^2 and N*m for revolute joints; m, m/s, m/s^2 and N
// for prismatic ones. Positive effort drives the joint positive. Tutorial:
// docs/student-controllers.md.
//
// Rules the host enforces: efforts are clamped to ArmInfo::effort_max. The library runs in a child
// process of sirupp-control (sirupp-controller-host). A crash (any signal), a Reset or Update call
// longer than the call limit (--controller-tick-limit, 0.5 s), an exception from Reset or Update,
// or a non-finite effort stops the controller: the arm is held by its brakes and CONTROLLER_STATUS
// reports STATE_FAULT naming the controller, the tick and the cause, until `sirupp clear-fault`
// starts the library afresh (a new process: constructor, then Reset).

#ifndef SIRUPP_CONTROLLER_H_
#define SIRUPP_CONTROLLER_H_

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

// Changes whenever a struct, the class or a factory function below changes layout or meaning.
// sirupp-control refuses a library built against another version.
#define SIRUPP_CONTROLLER_ABI_VERSION 1

namespace sirupp {

// The arm, fixed for the whole run. Arrays have num_joints entries and stay valid until the
// controller is destroyed.
struct ArmInfo {
  int num_joints;
  const char* model_name;      // e.g. "puma260"
  double servo_tick_s;         // time between Update calls (simulated time in lockstep)
  const double* effort_max;    // N*m or N; larger efforts are clamped
  const double* position_min;  // rad or m
  const double* position_max;
};

// One servo tick. Every array has num_joints entries and is valid only during the call.
struct State {
  double time_s;  // time of the measurement (sim: simulated time since the start)
  int64_t tick;   // the tick the measurement belongs to (the sim's physics tick)
  int num_joints;
  // Measured.
  const double* position;  // rad or m, unwrapped
  const double* velocity;  // rad/s or m/s
  const double* effort;    // effort applied during the last tick, after the limits
  // From the profile generators (trapezoidal moves from `sirupp move` and plans).
  const double* setpoint_position;
  const double* setpoint_velocity;
  const double* setpoint_acceleration;
  const double* goal;  // where each joint's present move ends
  // The arm's rigid-body dynamics at the measured position and velocity, computed by the host:
  //   effort = mass_matrix * acceleration + bias_effort
  const double* gravity_effort;  // G(q): holds the arm still
  const double* bias_effort;     // C(q, qd) qd + G(q): Coriolis, centrifugal and gravity
  const double* mass_matrix;     // M(q), row-major num_joints x num_joints, armature included
};

// Derive from this and export the class with SIRUPP_EXPORT_CONTROLLER(YourClass). The class needs
// a constructor taking `const std::string& args` (the text of --controller-args, "" if none);
// throw std::invalid_argument from it to refuse bad arguments.
class Controller {
 public:
  virtual ~Controller() = default;
  // Called once, with the first state, before the first Update.
  virtual void Reset(const ArmInfo& arm, const State& state) = 0;
  // Writes num_joints efforts into `effort` (which arrives filled with zeros).
  virtual void Update(const State& state, double* effort) = 0;
};

// The controller's arguments (--controller-args) as "key=number" words, for the constructor:
//
//   explicit MyLaw(const std::string& args) {
//     sirupp::Params params(args);               // "wn=150 zeta=0.8"
//     wn_ = params.Positive("wn", 100);          // the default when the key is absent
//     zeta_ = params.Positive("zeta", 1);
//     bias_ = params.Number("bias", 0);          // any finite number
//     params.Finish();                           // refuses keys nobody asked for
//   }
//
// Every problem is a std::invalid_argument naming the word and what is allowed, which the host
// reports as "the controller refused its arguments '...': ..." (and sirupp-control exits 2):
// "'wn=fast': expected key=number", "'wn=-3': wn must be > 0", "'wn=1 wn=2': wn given twice",
// "unknown argument 'gain' (allowed: wn, zeta, bias)".
class Params {
 public:
  explicit Params(const std::string& args) {
    std::istringstream words(args);
    std::string word;
    while (words >> word) {
      const std::size_t equals = word.find('=');
      const std::string key = word.substr(0, equals);
      double value = 0;
      std::size_t used = 0;
      try {
        if (equals == std::string::npos || key.empty()) throw std::invalid_argument(word);
        const std::string number = word.substr(equals + 1);
        value = std::stod(number, &used);
        if (used != number.size() || !std::isfinite(value)) throw std::invalid_argument(word);
      } catch (const std::exception&) {
        throw std::invalid_argument("'" + word + "': expected key=number");
      }
      if (values_.count(key) != 0) {
        throw std::invalid_argument("'" + args + "': " + key + " given twice");
      }
      values_[key] = Given{value, word};
    }
  }

  // The number given for `key`, or `fallback` when it is absent.
  double Number(const std::string& key, double fallback) {
    allowed_.push_back(key);
    const auto found = values_.find(key);
    return found == values_.end() ? fallback : found->second.value;
  }

  // The same, refusing zero and negative numbers.
  double Positive(const std::string& key, double fallback) {
    const double value = Number(key, fallback);
    if (!(value > 0)) {
      throw std::invalid_argument("'" + values_.at(key).word + "': " + key + " must be > 0");
    }
    return value;
  }

  // Call after the last Number/Positive: refuses a key that none of them asked for.
  void Finish() const {
    for (const auto& [key, given] : values_) {
      bool known = false;
      for (const std::string& allowed : allowed_) known = known || allowed == key;
      if (known) continue;
      std::string list;
      for (const std::string& allowed : allowed_) list += (list.empty() ? "" : ", ") + allowed;
      throw std::invalid_argument("unknown argument '" + key +
                                  "' (allowed: " + (list.empty() ? "none" : list) + ")");
    }
  }

 private:
  struct Given {
    double value;
    std::string word;
  };
  std::map<std::string, Given> values_;
  std::vector<std::string> allowed_;
};

}  // namespace sirupp

// The factory functions sirupp-control looks up in the library (made by the macro below).
extern "C" {
// SIRUPP_CONTROLLER_ABI_VERSION as compiled into the library.
int sirupp_controller_abi_version();
// A new controller for `args`, or null with a message in `error` (error_size bytes).
sirupp::Controller* sirupp_controller_create(const char* args, char* error, std::size_t error_size);
void sirupp_controller_destroy(sirupp::Controller* controller);
}

// Exports the three factory functions for `ControllerClass`. Write it once, at file scope, in one
// source file of the library.
#define SIRUPP_EXPORT_CONTROLLER(ControllerClass)                                                 \
  extern "C" __attribute__((visibility("default"))) int sirupp_controller_abi_version() {         \
    return SIRUPP_CONTROLLER_ABI_VERSION;                                                         \
  }                                                                                               \
  extern "C" __attribute__((visibility("default"))) sirupp::Controller* sirupp_controller_create( \
      const char* args, char* error, std::size_t error_size) {                                    \
    try {                                                                                         \
      return new ControllerClass(std::string(args != nullptr ? args : ""));                       \
    } catch (const std::exception& exception) {                                                   \
      std::snprintf(error, error_size, "%s", exception.what());                                   \
    } catch (...) {                                                                               \
      std::snprintf(error, error_size, "the constructor threw a non-standard exception");         \
    }                                                                                             \
    return nullptr;                                                                               \
  }                                                                                               \
  extern "C" __attribute__((visibility("default"))) void sirupp_controller_destroy(               \
      sirupp::Controller* controller) {                                                           \
    delete controller;                                                                            \
  }

#endif  // SIRUPP_CONTROLLER_H_
