// What the hostile test controllers share (issue 34, docs/sandbox.md): each does one thing a
// student's code must not do to the machine, other rigs or other students, in its first Update
// (Act) or in its constructor, and reports how far it got by throwing: the text becomes the
// fault's (or the load error's) reason, which the tests read. Built against
// include/sirupp/controller.h alone, each into a folder of its own, like a student's library.
// Never run them unsandboxed except net_publish and read_other (harmless without the sandbox:
// the tests do, to show the tests can fail).
#pragma once

#include <sirupp/controller.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace hostile {

inline std::string Errno() { return std::strerror(errno); }

class Hostile : public sirupp::Controller {
 public:
  void Reset(const sirupp::ArmInfo& /*arm*/, const sirupp::State& /*state*/) override {}
  void Update(const sirupp::State& /*state*/, double* /*effort*/) override { Act(); }

 protected:
  // Does the hostile thing; throws what happened.
  virtual void Act() = 0;
};

}  // namespace hostile
