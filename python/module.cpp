// sirupp._sirupp: the compiled half of the Python module `sirupp` (python/sirupp/__init__.py
// re-exports it). Thin: every computation is a library's (core/, client/, logger/, grade/,
// planning/).
#include <pybind11/pybind11.h>

#include "python/bindings.hpp"

PYBIND11_MODULE(_sirupp, m) {
  namespace py = pybind11;
  m.doc() = "SIRUPP-LCM bindings: robot model, kinematics, dynamics, and the client of a rig";
  py::register_exception<sirupp::python::ModelError>(m, "ModelError", PyExc_ValueError);
  py::register_exception<sirupp::python::IkError>(m, "IKError", PyExc_ValueError);
  py::register_exception<sirupp::python::RigError>(m, "RigError", PyExc_RuntimeError);
  sirupp::python::BindModel(m);
  sirupp::python::BindRig(m);
  sirupp::python::BindProcessController(m);
  sirupp::python::BindData(m);
  sirupp::python::BindPlanning(m);
}
