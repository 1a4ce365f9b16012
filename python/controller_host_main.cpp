// sirupp-python-controller-host: runs one controller written in Python for sirupp-control
// (`sirupp-control --controller my_controller.py`), in a process of its own, exactly like
// sirupp-controller-host runs a library (control/isolated_law.hpp: the same shared block and
// socket pair, the same faults), with an embedded interpreter in place of dlopen
// (python/python_law.hpp). Started by sirupp-control, never by hand:
//
//   sirupp-python-controller-host FILE.py ARGS     descriptor 3: the call socket, 4: the block
//
// Like the library host it has SIGKILL as its parent-death signal and ignores SIGINT and SIGTERM
// (they are set before the interpreter starts, so Python installs no KeyboardInterrupt handler).
// The module `sirupp` of this build is put first on sys.path.
#include <pybind11/embed.h>

#include <memory>
#include <string>

#include "control/isolated_law.hpp"
#include "python/python_law.hpp"

int main(int argc, char** argv) {
  if (!sirupp::control::PrepareHostProcess(argc, "sirupp-python-controller-host", "FILE.py")) {
    return 2;
  }
  pybind11::scoped_interpreter interpreter(false);  // no Python signal handlers
  pybind11::module_::import("sys").attr("path").attr("insert")(0, SIRUPP_PYTHON_DIR);
  return sirupp::control::RunControllerHost(
      3, 4, argv[1], argv[2],
      [](const std::string& file, const std::string& args, const sirupp::core::RobotModel& model) {
        return std::make_unique<sirupp::python::PythonEffortLaw>(file, args, model);
      });
}
